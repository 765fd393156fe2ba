"""Spatial queries a game asks between steps (World.query_radius, query_box, nearest): checked
input, the candidate bodies (kinds, category mask), the periodic box, and the answer in body
ids. The grid and the searches are kernels/queries.py.

A body is a disc (2D) or sphere (3D) of its radius; a distance is the gap between a point
and its surface (0 inside it). Each query's answers are sorted by distance, then id.
"""
from dataclasses import dataclass

import numpy as np

from . import _validate as check
from .kernels import queries as kq


@dataclass(frozen=True)
class Hits:
    """The answers of a batch of Q queries: those of query q are ids[offsets[q]:offsets[q+1]]
    with their distances; hits[q] gives (ids, distances) of query q."""
    offsets: np.ndarray        # (Q + 1,) int64
    ids: np.ndarray            # (H,) int64 body ids
    distances: np.ndarray      # (H,) [length]

    def __len__(self):
        return self.offsets.size - 1

    def __getitem__(self, q):
        a, b = self.offsets[q], self.offsets[q + 1]
        return self.ids[a:b], self.distances[a:b]

    def counts(self):
        """(Q,) int64: how many bodies each query found."""
        return np.diff(self.offsets)


def _points(name, value, dim):
    """(Q, 3) float64 from a (dim,) point or (Q, dim) points."""
    arr = np.asarray(value, dtype=np.float64) if not isinstance(value, np.ndarray) else value
    if arr.ndim == 1:
        arr = arr[None, :]
    arr = check.floats(name, arr, (None, dim))
    out = np.zeros((arr.shape[0], 3))
    out[:, :dim] = arr
    return out


def _candidates(world, kinds, mask):
    """int64 rows of the bodies a query may find: of one of `kinds` (names or codes; None:
    every kind) and whose category shares a bit with `mask` (None: every body)."""
    n = world.n
    ok = np.ones(n, bool)
    if kinds is not None:
        names = [kinds] if isinstance(kinds, (str, int, np.integer)) else list(kinds)
        if not names:
            raise ValueError("kinds = []: give at least one kind, or None for every kind")
        codes = []
        for k in names:
            c = world.kinds.index(k) if isinstance(k, str) and k in world.kinds else \
                (check.count("kinds", k) if not isinstance(k, str) else len(world.kinds))
            if c >= len(world.kinds):
                raise ValueError(f"kinds: {k!r} is not a declared kind; declared: "
                                 f"{', '.join(world.kinds)}")
            codes.append(c)
        ok &= np.isin(world.kind, codes)
    if mask is not None:
        if isinstance(mask, (bool, np.bool_)) or not isinstance(mask, (int, np.integer)):
            raise ValueError(f"mask = {mask!r}: expected an integer of category bits")
        ok &= (world.category & int(mask)) != 0
    return np.flatnonzero(ok).astype(np.int64)


def _box(world):
    """(lo (3,), period (3,)): the periodic box (period 0 on open axes)."""
    mode, lo, hi, _ = world.boundary
    lo3, period = np.zeros(3), np.zeros(3)
    if mode == "periodic":
        lo3[:world.dim] = lo
        period[:world.dim] = hi - lo
    return lo3, period


def _state(world):
    """(pos (n, 3), radius (n,), ids (n,)) contiguous, z = 0 in 2D."""
    pos = np.zeros((world.n, 3))
    pos[:, :world.dim] = world.pos
    return pos, np.ascontiguousarray(world.radius, np.float64), np.ascontiguousarray(world.ids)


def query_radius(world, centers, r, kinds=None, mask=None):
    """Bodies within distance r of each center (their surface: a body of radius R counts
    from |d| <= r + R): a Hits. centers (dim,) or (Q, dim); r >= 0, a number or (Q,)."""
    c = _points("centers", centers, world.dim)
    reach = check.per_body("r", r, c.shape[0], minimum=0.0)
    rows = _candidates(world, kinds, mask)
    pos, radius, ids = _state(world)
    lo, period = _box(world)
    offsets, hits, dist = kq.overlaps(pos, radius, ids, rows, lo, period, c,
                                      np.ascontiguousarray(reach, np.float64),
                                      np.zeros((c.shape[0], 3)), 0)
    return Hits(offsets, ids[hits], dist)


def query_box(world, lo, hi, kinds=None, mask=None):
    """Bodies overlapping each box lo..hi (axis-aligned; (dim,) or (Q, dim) each): a Hits,
    sorted by the distance of their centres from the box's centre."""
    a = _points("lo", lo, world.dim)
    b = _points("hi", hi, world.dim)
    if a.shape != b.shape:
        raise ValueError(f"lo has {a.shape[0]} boxes, hi {b.shape[0]}")
    bad = np.argwhere(a[:, :world.dim] > b[:, :world.dim])
    if bad.size:
        q, c = bad[0]
        raise ValueError(f"box {q}: lo[{c}] = {a[q, c]} is above hi[{c}] = {b[q, c]}")
    rows = _candidates(world, kinds, mask)
    pos, radius, ids = _state(world)
    box_lo, period = _box(world)
    offsets, hits, dist = kq.overlaps(pos, radius, ids, rows, box_lo, period, 0.5 * (a + b),
                                      np.zeros(a.shape[0]), 0.5 * (b - a), 1)
    return Hits(offsets, ids[hits], dist)


def nearest(world, points, k=1, kinds=None, mask=None):
    """The k bodies nearest each point (by the gap to their surface): (ids (Q, k) int64,
    distances (Q, k)); -1 and inf past the bodies there are."""
    p = _points("points", points, world.dim)
    k = check.count("k", k, minimum=1)
    rows = _candidates(world, kinds, mask)
    pos, radius, ids = _state(world)
    lo, period = _box(world)
    hits, dist = kq.nearest(pos, radius, ids, rows, lo, period, p, k)
    out = np.where(hits >= 0, ids[np.maximum(hits, 0)], -1) if ids.size else hits
    return out, dist
