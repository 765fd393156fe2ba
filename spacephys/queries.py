"""Spatial queries a game asks between steps (World.query_radius, query_box, nearest, raycast,
shapecast): checked input, the candidate bodies (kinds, category mask, a Filter, ids left
out), the periodic box, the grid they share, and the answer in body ids. The grid and the
searches are kernels/queries.py.

The grid holds every live body and serves every query until a body moves, is added or
removed, or changes its radius, or the boundary changes (`_grid`: kept by the World's driver,
which drops it at the next step, and checked against the columns it was built from): the
queries a game asks between two steps share one. A query's candidates are a mask the
searches skip by, not a grid of their own. The next grid is built in the memory of those
dropped before it (`_Memory`, the driver's grid_memory).

A body is a disc (2D) or sphere (3D) of its radius; a distance is the gap between a point
and its surface (0 inside it). Each query's answers are sorted by distance, then id.

A compound body (World.add_body(..., shape=sp.Circles(...))) is its circles, not its bounding
circle: when the World has any, each query hands the kernels every compound candidate's
circles as entries of their own (the body's id, where they are now) in its place, and maps
the answers back to bodies (`_Circles`). A World without one runs the kernels on its own
columns, as it always did.
"""
import math
from dataclasses import dataclass

import numpy as np

from . import _validate as check
from . import editing
from .kernels import queries as kq

_INT64 = np.iinfo(np.int64)
_ALL = np.zeros(0, np.bool_)       # the searches' mask when every body of the grid is wanted
_NO_HALF = np.zeros((0, 3))        # the searches' box sizes for radius queries (never read)
_OPEN = (np.zeros(3), np.zeros(3))  # _box() without a periodic boundary
_NO_BATCH = {}                     # (never written: _batch's look-up with none kept)
_BATCH_HANDLES = 16                # the most radii whose batches _batch keeps a handle for


def _mean(values):
    """The mean of values (the grid's hint: the queries' reach), 0 for none."""
    values = np.asarray(values, np.float64)
    return float(np.add.reduce(values, axis=None)) / values.size if values.size else 0.0


@dataclass(frozen=True)
class Filter:
    """The collision rule applied to a query, as if it were a body with these bits: it finds
    a body whose category shares a bit with `mask` and whose own mask shares a bit with
    `category` (World.add_body's category and mask). Filter(category=PLAYER_SHOTS,
    mask=ENEMIES) finds the enemies that let player shots hit them."""
    category: int = 1
    mask: int = -1

    def __post_init__(self):
        for name in ("category", "mask"):
            v = getattr(self, name)
            if isinstance(v, (bool, np.bool_)) or not isinstance(v, (int, np.integer)) \
                    or not _INT64.min <= v <= _INT64.max:
                raise ValueError(f"filter {name} = {v!r}: expected an integer of category "
                                 f"bits (int64)")


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
    arr = value
    if not isinstance(value, np.ndarray):
        try:
            arr = np.asarray(value)
        except ValueError:
            arr = np.empty(0, object)                  # ragged: check.floats names it
        # numbers as they are; text, booleans and the rest refused by check.floats, naming
        # the field (numpy would convert booleans, or say only what it could not convert)
        arr = arr.astype(np.float64, copy=False) if arr.dtype.kind in "iuf" else \
            check.floats(name, value)
    if arr.ndim == 1:
        arr = arr[None, :]
    # floats of the right shape (a frame's many small batches) are checked and copied by
    # one kernel; anything else, or a point that is not finite, goes through check.floats,
    # which names what is wrong
    if arr.dtype == np.float64 and arr.ndim == 2 and arr.shape[1] == dim:
        out = kq.points(arr)
        if out.shape[0] == arr.shape[0]:
            return out
    arr = check.floats(name, arr, (None, dim))
    out = np.zeros((arr.shape[0], 3))
    out[:, :dim] = arr
    return out


def _filter(value):
    """A Filter from filter= (a Filter or (category, mask)), or None."""
    if value is None or isinstance(value, Filter):
        return value
    if isinstance(value, tuple) and len(value) == 2:
        return Filter(*value)
    raise ValueError(f"filter = {value!r}: expected sp.Filter(category, mask) or a pair "
                     f"(category, mask)")


def _candidates(world, kinds, mask, ignore=None, filter=None):
    """int64 rows of the bodies a query may find (None: every body, the common case, asked
    many times a frame): of one of the kind codes `kinds` (None: every kind; World checks
    them), whose category shares a bit with `mask` (None: every body), that pass `filter` (a
    Filter or (category, mask)) and are not among the ids `ignore` (an id or ids of live
    bodies)."""
    filter = _filter(filter)
    if ignore is not None:
        ignore = editing.index_of(world, ignore, "ignore")
    if kinds is None and mask is None and filter is None and ignore is None:
        return None
    ok = np.ones(world.n, bool)
    if ignore is not None:
        ok[ignore] = False
    if filter is not None:
        ok &= ((world.category & filter.mask) != 0) & ((world.mask & filter.category) != 0)
    if kinds is not None:                  # a table by code: np.isin sorts, 10x the time
        wanted = np.zeros(len(world.kinds), bool)
        wanted[np.asarray(kinds, dtype=np.int64)] = True
        ok &= wanted[world.kind]
    if mask is not None:
        if isinstance(mask, (bool, np.bool_)) or not isinstance(mask, (int, np.integer)):
            raise ValueError(f"mask = {mask!r}: expected an integer of category bits")
        ok &= (world.category & int(mask)) != 0
    return np.flatnonzero(ok).astype(np.int64)


def _wanted(world, rows):
    """The searches' mask of the candidate rows (kernels/queries): empty when every body is
    a candidate (rows None, or all n of them: they are unique), else (n,) bool."""
    if rows is None or rows.size == world.n:
        return _ALL
    wanted = np.zeros(world.n, np.bool_)
    wanted[rows] = True
    return wanted


class _Memory:
    """The memory of the grids a World's queries keep (its driver's grid_memory): the
    buffers of the basis (the columns the grids were built from), of the rows 0..n-1, and of
    the grids themselves (kernels/queries.grid's), reused once the grids they held are
    dropped. A grid and basis of 10^5 bodies in new memory spent more on the pages' first
    touch than on their build. Grown, never shrunk: sized for the most bodies the World has
    held (a copy starts with none)."""

    def __init__(self):
        self.basis = (np.empty((0, 3)), np.empty(0))
        self.all_rows = np.empty(0, np.int64)
        self.lent = []           # the memory of the grids in driver.grids
        self.spare = []          # memory no grid uses

    def drop(self):
        """Every grid is gone (driver.grids cleared): their memory is spare."""
        self.spare += self.lent
        self.lent = []

    def bases(self, n):
        """The basis buffers' first n rows ((n, 3), (n,); grown when short), for kq.grid to
        copy pos and radius into."""
        if self.basis[0].shape[0] < n:
            self.basis = (np.empty((n, 3)), np.empty(n))
        return self.basis[0][:n], self.basis[1][:n]

    def rows(self, n):
        """(n,) int64: 0 .. n - 1."""
        if self.all_rows.size < n:
            self.all_rows = np.arange(n, dtype=np.int64)
        return self.all_rows[:n]

    def grid(self, pos, radius, rows, lo, period, hint, bpos, bradius):
        """kq.grid in spare memory, the memory then lent to it."""
        g, held = kq.grid(pos, radius, rows, lo, period, hint,
                          self.spare.pop() if self.spare else kq.NO_MEMORY, bpos, bradius)
        self.lent.append(held)
        return g


def _basis(world, lo, period):
    """(bpos, bradius, box key): what the kept grids were built from, when it was this box,
    else None (no grid kept, or one of another box)."""
    basis = world.driver.grids.get("basis")
    return basis if basis is not None and basis[2] == _box_key(lo, period) else None


def _box_key(lo, period):
    """What a kept grid's box is known by: its corner's and period's bytes (None without a
    periodic boundary: _box's _OPEN)."""
    return None if lo is _OPEN[0] else lo.tobytes() + period.tobytes()


def _key(hint):
    """The kept grids' key of a query's reach: one grid per factor of 2 (inf: a key too)."""
    return None if not hint > 0.0 else math.inf if hint == math.inf else \
        math.floor(math.log2(hint))


def _grid(world, hint, pos, radius, lo, period):
    """The grid of every live body (kernels/queries.grid) for queries that reach about
    `hint` (its cells at least that wide; 0: about a body a cell): built when a query first
    needs it, kept by the World's driver while the positions, radii and box it was built from
    hold, one per factor of 2 in hint; built in the memory of the grids dropped before
    (_Memory). pos, radius: _state(world); lo, period: _box(world). The ids are not part of
    it: a grid holds rows, which each search names by the ids of the moment."""
    kept = world.driver.grids
    basis = _basis(world, lo, period)
    if world.driver.grid_memory is None:
        world.driver.grid_memory = _Memory()
    memory = world.driver.grid_memory
    fresh = basis is None or not kq.unchanged(pos, radius, *basis[:2])
    if fresh:
        kept.clear()
        memory.drop()
    key = _key(hint)
    g = kept.get(key)
    if g is None:            # a fresh basis: this grid's build copies pos and radius into it
        bases = memory.bases(world.n) if fresh else kq.NO_BASIS
        g = kept[key] = memory.grid(pos, radius, memory.rows(world.n), lo, period,
                                    float(hint), *bases)
        if fresh:
            kept["basis"] = bases + (_box_key(lo, period),)
    return g


def _grid_once(pos, radius, rows, lo, period, hint):
    """kq.grid in new memory, for a grid one call uses and drops (a compound body's
    circles)."""
    return kq.grid(pos, radius, rows, lo, period, hint, kq.NO_MEMORY, *kq.NO_BASIS)[0]


def _box(world):
    """(lo (3,), period (3,)): the periodic box (period 0 on open axes); without a periodic
    boundary, _OPEN (this module's own: read by the kernels, never handed out)."""
    return world.driver.periodic_box() if world.driver.periodic() else _OPEN


def _state(world):
    """(pos (n, 3), radius (n,), ids (n,)): the World's own columns (z = 0 in 2D), not
    copies (read only here)."""
    return world.driver.view("pos", "radius", "ids")


@dataclass(frozen=True)
class _Circles:
    """The entries the kernels search when compound bodies are among the candidates: the
    World's n rows as they are (a round body is its own entry, row i), then one entry per
    circle of a compound body (entry n + c: circle c of w.circles()); a compound body's own
    row is never a candidate, its circles are."""
    pos: np.ndarray            # (n + C, 3) centres
    radius: np.ndarray         # (n + C,)
    ident: np.ndarray          # (n + C,) the body's id (a circle: its body's)
    rows: np.ndarray           # (m,) int64 the candidate entries, ascending
    body: np.ndarray           # (n + C,) int64 the body's row of each entry
    circle: np.ndarray         # (n + C,) int64 the circle's index in its body, -1 for a row
    compound: np.ndarray       # (n,) bool: the rows that are compound bodies
    most: int                  # the most circles of a candidate body (1 with none)


def _compound(world):
    """w.circles() (ids, circle index, centres, radii), or None when no body is compound (a
    World that never had one has no shape column: not even the call)."""
    if not world.driver.has(editing.SHAPE):
        return None
    got = world.circles()
    return got if got[0].size else None


def _circles(world, rows):
    """A _Circles of the candidate rows `rows` (None: every row), or None when the World has
    no compound body (the queries then run on its own columns, as before there were any)."""
    got = _compound(world)
    if got is None:
        return None
    cid, k, centres, cr = got
    pos, radius, ids = _state(world)
    n, dim = world.n, world.dim
    if rows is None:
        rows = np.arange(n, dtype=np.int64)
    crow = np.asarray(world.index_of(cid), np.int64)
    compound = np.zeros(n, bool)
    compound[crow] = True
    p = np.zeros((n + cid.size, 3))
    p[:n] = pos
    p[n:, :dim] = centres
    wanted = np.zeros(n, bool)
    wanted[rows] = True
    mine = wanted[crow]
    entries = np.r_[rows[~compound[rows]], n + np.flatnonzero(mine)].astype(np.int64)
    per = np.bincount(crow[mine], minlength=n)
    return _Circles(p, np.r_[radius, cr].astype(np.float64),
                    np.r_[ids, cid].astype(np.int64), np.sort(entries),
                    np.r_[np.arange(n), crow].astype(np.int64),
                    np.r_[np.full(n, -1), k].astype(np.int64), compound,
                    max(int(per.max()) if per.size else 1, 1))


def _once(group, body, n):
    """The indices of the first row of each (group, body) pair, in their order: a body met
    through several of its circles kept once, where it was met first (nearest)."""
    _, first = np.unique(group.astype(np.int64) * max(n, 1) + body, return_index=True)
    return np.sort(first)


def _bodies(x, offsets, hits, dist):
    """(query (H,), entry (H,), distance (H,)) of the kernels' hits among a _Circles'
    entries (offsets, hits, dist as kq.overlaps returns them), each body once per query, at
    its first (nearest) entry; in their order."""
    q = np.repeat(np.arange(offsets.size - 1), np.diff(offsets))
    keep = _once(q, x.body[hits], x.compound.size)
    return q[keep], hits[keep], dist[keep]


def _image(d, period):
    """As kernels/queries._image, in numpy, on rows d (H, 3): each difference taken to its
    nearest periodic image (period 0: as it is)."""
    wraps = period > 0.0
    if not wraps.any():
        return d
    size = np.where(wraps, period, 1.0)
    return np.where(wraps, d - size * np.floor(d / size + 0.5), d)


def _batch(world, centers, r, lo, period):
    """A frame's next batch of radius queries, in one kernel call: Hits, or None when it
    must go the checked way (centers not a (Q, dim) float64 array, a compound body, no
    grid kept for this r and box, the bodies changed since, or a point not finite: that way
    names it). r: a Python float; lo, period: _box(world). kq.overlaps checks the points
    and that the bodies hold the bits the grid was built from as it searches."""
    held = world.driver.grids.get("batch", _NO_BATCH).get(r)
    if held is None or type(centers) is not np.ndarray or centers.ndim != 2 or \
            centers.dtype != np.float64 or centers.shape[1] != world.dim or \
            held[3] != _box_key(lo, period) or _compound(world) is not None:
        return None
    g, bpos, bradius, _, reach = held
    if reach.size != centers.shape[0]:
        reach = check.per_body("r", r, centers.shape[0])
        world.driver.grids["batch"][r] = held[:4] + (reach,)
    pos, radius, ids = _state(world)
    status, offsets, named, dist = kq.overlaps(g, pos, radius, ids, _ALL, period, centers,
                                               reach, _NO_HALF, 0, True, True, bpos, bradius)
    return Hits(offsets, named, dist) if status == 0 else None


def query_radius(world, centers, r, kinds=None, mask=None, ignore=None, filter=None):
    """Bodies within distance r of each center (their surface: a body of radius R counts
    from |d| <= r + R): a Hits. centers (dim,) or (Q, dim); r >= 0, a number or (Q,)."""
    lo, period = _box(world)
    # a frame's batches (one r for all, every body a candidate): after the first, which
    # builds the grid, one look-up and one kernel call each (10 queries among 4 000
    # bodies: 14.2 -> 12.6 us a call, against looking the grid and its basis up each time)
    batch = kinds is None and mask is None and ignore is None and filter is None and \
        type(r) is float
    if batch:
        hits = _batch(world, centers, r, lo, period)
        if hits is not None:
            return hits
    c = _points("centers", centers, world.dim)
    reach = check.per_body("r", r, c.shape[0], minimum=0.0)
    hint = r if type(r) is float else _mean(reach)      # (checked: a float is one r for all)
    rows = _candidates(world, kinds, mask, ignore, filter)
    pos, radius, ids = _state(world)
    x = _circles(world, rows)
    if x is not None:            # a compound body: within r of one of its circles
        g = _grid_once(x.pos, x.radius, x.rows, lo, period, hint)
        _, offsets, hits, dist = kq.overlaps(g, x.pos, x.radius, x.ident, _ALL, period, c,
                                             reach, _NO_HALF, 0, False, False, *kq.NO_BASIS)
        q, hits, dist = _bodies(x, offsets, hits, dist)
        return Hits(np.searchsorted(q, np.arange(c.shape[0] + 1)).astype(np.int64),
                    x.ident[hits], dist)
    g = _grid(world, hint, pos, radius, lo, period)
    if batch:                    # the next batches with this r: _batch
        bpos, bradius, box = world.driver.grids["basis"]
        handles = world.driver.grids.setdefault("batch", {})
        if r not in handles and len(handles) >= _BATCH_HANDLES:   # (an r changing often)
            handles.clear()
        handles[r] = (g, bpos, bradius, box, reach)
    return Hits(*kq.overlaps(g, pos, radius, ids, _wanted(world, rows), period, c, reach,
                             _NO_HALF, 0, True, False, *kq.NO_BASIS)[1:])


def query_box(world, lo, hi, kinds=None, mask=None, ignore=None, filter=None):
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
    rows = _candidates(world, kinds, mask, ignore, filter)
    pos, radius, ids = _state(world)
    box_lo, period = _box(world)
    x = _circles(world, rows)
    if x is not None:            # a compound body: when one of its circles overlaps the box
        mid = 0.5 * (a + b)
        g = _grid_once(x.pos, x.radius, x.rows, box_lo, period,
                       _mean((b - a).sum(axis=1) / 2))
        _, offsets, hits, dist = kq.overlaps(g, x.pos, x.radius, x.ident, _ALL, period, mid,
                                             np.zeros(a.shape[0]), 0.5 * (b - a), 1, False,
                                             False, *kq.NO_BASIS)
        q, hits, dist = _bodies(x, offsets, hits, dist)
        # its distance: of its own centre (not the circle's) from the box's centre
        body = x.body[hits]
        shaped = x.compound[body]
        if shaped.any():
            d = _image(pos[body[shaped]] - mid[q[shaped]], period)
            dist = dist.copy()
            dist[shaped] = np.sqrt((d * d).sum(axis=1))
            order = np.lexsort((x.ident[hits], dist, q))
            q, hits, dist = q[order], hits[order], dist[order]
        return Hits(np.searchsorted(q, np.arange(a.shape[0] + 1)).astype(np.int64),
                    x.ident[hits], dist)
    g = _grid(world, _mean((b - a).sum(axis=1) / 2), pos, radius, box_lo, period)
    return Hits(*kq.overlaps(g, pos, radius, ids, _wanted(world, rows), period, 0.5 * (a + b),
                             np.zeros(a.shape[0]), 0.5 * (b - a), 1, True, False,
                             *kq.NO_BASIS)[1:])


def nearest(world, points, k=1, kinds=None, mask=None, ignore=None, filter=None):
    """The k bodies nearest each point (by the gap to their surface): (ids (Q, k) int64,
    distances (Q, k)); -1 and inf past the bodies there are."""
    p = _points("points", points, world.dim)
    k = check.count("k", k, minimum=1)
    rows = _candidates(world, kinds, mask, ignore, filter)
    pos, radius, ids = _state(world)
    lo, period = _box(world)
    x = _circles(world, rows)
    if x is not None:
        return _nearest_bodies(x, lo, period, p, k)
    g = _grid(world, 0.0, pos, radius, lo, period)
    hits, dist = kq.nearest(g, pos, radius, ids, _wanted(world, rows), period, p, k)
    out = np.where(hits >= 0, ids[np.maximum(hits, 0)], -1) if ids.size else hits
    return out, dist


def _nearest_bodies(x, lo, period, p, k):
    """nearest among a _Circles' entries: a compound body at the gap to its nearest circle.
    The k nearest bodies are the first k distinct among the (k - 1) m + 1 nearest entries (m:
    the most circles of a body), a body first where its nearest circle is."""
    K = max(min((k - 1) * x.most + 1, x.rows.size), 1)
    g = _grid_once(x.pos, x.radius, x.rows, lo, period, 0.0)
    hits, dist = kq.nearest(g, x.pos, x.radius, x.ident, _ALL, period, p, K)
    Q = p.shape[0]
    body = np.where(hits >= 0, x.body[np.maximum(hits, 0)], -1)
    q = np.repeat(np.arange(Q), K)
    found = body.reshape(-1) >= 0
    keep = np.zeros(Q * K, bool)
    first = np.flatnonzero(found)[_once(q[found], body.reshape(-1)[found], x.compound.size)]
    keep[first] = True
    keep = keep.reshape(Q, K)
    rank = np.cumsum(keep, axis=1) - 1
    take = keep & (rank < k)
    out = np.full((Q, k), -1, np.int64)
    out_d = np.full((Q, k), np.inf)
    qq, cc = np.nonzero(take)
    out[qq, rank[qq, cc]] = x.ident[hits[qq, cc]]
    out_d[qq, rank[qq, cc]] = dist[qq, cc]
    return out, out_d


@dataclass(frozen=True)
class RayHits:
    """What a batch of Q rays hit: those of ray q are the rows offsets[q]:offsets[q+1] (at
    most one with first=True), nearest first; ray_hits[q] gives them as a RayHits of one
    ray's rows (offsets [0, m]). Per ray, its nearest hit: `hit` (Q,) whether it met
    anything, `body` its id or -1, `wall` its wall index or -1, `circle` the circle of a
    compound body it met or -1, `distance` or inf: a miss is hit False, never a wall."""
    offsets: np.ndarray        # (Q + 1,) int64
    ids: np.ndarray            # (H,) int64 body ids, -1 where a wall was hit
    walls: np.ndarray          # (H,) int64 wall indices (w.walls), -1 where a body was hit
    distances: np.ndarray      # (H,) [length] along the ray
    points: np.ndarray         # (H, dim) where the ray meets the surface
    normals: np.ndarray        # (H, dim) unit, against the ray
    circles: np.ndarray        # (H,) int64 the index of the circle met in its compound
    #                            body's Circles (w.shape(id)); -1 for a round body or a wall

    def __len__(self):
        return self.offsets.size - 1

    def __getitem__(self, q):
        a, b = self.offsets[q], self.offsets[q + 1]
        return RayHits(np.array([0, b - a]), self.ids[a:b], self.walls[a:b],
                       self.distances[a:b], self.points[a:b], self.normals[a:b],
                       self.circles[a:b])

    def counts(self):
        """(Q,) int64: how many hits each ray has."""
        return np.diff(self.offsets)

    # each ray's nearest hit, one row per ray whether it met something or not
    @property
    def hit(self):
        """(Q,) bool: whether each ray met anything, a body or a wall."""
        return self.offsets[1:] > self.offsets[:-1]

    def _first(self, column, missing):
        out = np.full((len(self),) + column.shape[1:], missing, column.dtype)
        hit = self.hit
        out[hit] = column[self.offsets[:-1][hit]]
        return out

    @property
    def body(self):
        """(Q,) int64: the id of the body each ray met first; -1 where its nearest hit is a
        wall, or it met nothing (see hit)."""
        return self._first(self.ids, -1)

    @property
    def wall(self):
        """(Q,) int64: the index (w.walls) of the wall each ray met first; -1 where its
        nearest hit is a body, or it met nothing."""
        return self._first(self.walls, -1)

    @property
    def circle(self):
        """(Q,) int64: the index of the circle (in its body's Circles) of the compound body
        each ray met first; -1 where its nearest hit is a round body or a wall, or it met
        nothing."""
        return self._first(self.circles, -1)

    @property
    def distance(self):
        """(Q,) how far along each ray its nearest hit is [length]; inf where it met
        nothing."""
        return self._first(self.distances, np.inf)


def _ray_circle(o, d, c, r):
    """(t, normal) where o + t d (d unit, rows) first touches the circle or sphere (c, r):
    t = 0 when o is inside, inf when never."""
    w = c - o
    b = (w * d).sum(axis=1)
    cc = (w * w).sum(axis=1) - r * r
    h = w - b[:, None] * d
    disc = r * r - (h * h).sum(axis=1)
    with np.errstate(invalid="ignore", divide="ignore"):
        t = np.where(cc <= 0.0, 0.0, np.where((b > 0.0) & (disc >= 0.0),
                                              cc / (b + np.sqrt(np.maximum(disc, 0.0))),
                                              np.inf))
        rel = o + t[:, None] * d - c
        n = rel / np.linalg.norm(rel, axis=1)[:, None]
    return t, np.where(np.isfinite(n) & (t[:, None] > 0.0), n, -d)


def _wall_hits(world, o, d, tmax, extra):
    """(t (Q, W), normals (Q, W, 3)): where each ray, or each circle of radius extra moving
    along it, first meets each wall (inf: never). Planes from either side; segments in 2D
    (as capsules of the circle's radius; in 3D a segment is a line nothing meets)."""
    walls = world.walls
    Q, W = o.shape[0], walls.shape[0]
    t = np.full((Q, W), np.inf)
    nrm = np.zeros((Q, W, 3))
    with np.errstate(divide="ignore", invalid="ignore"):
        for k in range(W):
            kind, p, v = walls[k, 0], walls[k, 1:4], walls[k, 4:7]
            if kind == 0:                                   # plane through p, normal v
                n = v / np.linalg.norm(v)
                s0 = (o - p) @ n
                side = np.where(s0 >= 0.0, 1.0, -1.0)       # the side the body is on
                gap = np.abs(s0) - extra
                closing = -(d @ n) * side                   # speed toward the plane
                tk = np.where(gap <= 0.0, 0.0, np.where(closing > 0.0, gap / closing, np.inf))
                nk = side[:, None] * n
            elif world.dim == 2:                            # segment p..v, a capsule
                s = v - p
                L = np.hypot(s[0], s[1])
                perp = np.array([-s[1], s[0], 0.0]) / L
                s0 = (o - p) @ perp
                side = np.where(s0 >= 0.0, 1.0, -1.0)
                closing = -(d @ perp) * side
                gap = np.abs(s0) - extra
                tk = np.where(gap <= 0.0, 0.0, np.where(closing > 0.0, gap / closing, np.inf))
                u = ((o + tk[:, None] * d - p) @ s) / (L * L)
                tk = np.where((u >= 0.0) & (u <= 1.0), tk, np.inf)
                nk = side[:, None] * perp
                for end in (p, v):                          # the round ends
                    te, ne = _ray_circle(o, d, end, extra)
                    nearer = te < tk
                    tk = np.where(nearer, te, tk)
                    nk = np.where(nearer[:, None], ne, nk)
            else:
                continue
            ok = np.isfinite(tk) & (tk <= tmax)
            t[ok, k] = tk[ok]
            nrm[ok, k] = nk[ok]
    return t, nrm


def _unit(v):
    """(unit vectors, lengths) of the rows of v (Q, 3), each scaled by its largest component
    first: the squares of a direction like (0, 1e-160) underflow, and its plain norm is off
    by 1e-4. Zero rows: returned as they are, length 0."""
    scale = np.abs(v).max(axis=1)
    u = v / np.where(scale > 0.0, scale, 1.0)[:, None]    # a largest component of 1: norm >= 1
    norm = np.linalg.norm(u, axis=1)
    return u / np.where(norm > 0.0, norm, 1.0)[:, None], norm * scale


def raycast(world, origins, directions, max_distance, kinds=None, mask=None, first=True,
            walls=True, ignore=None, filter=None):
    """Rays from origins along directions ((dim,) or (Q, dim) each; directions non-zero, made
    unit) up to max_distance (> 0, finite; a number or (Q,)): the bodies (of `kinds` /
    `mask`) and walls they meet, as a RayHits: the nearest per ray (first=True) or every
    one, nearest first (ties: bodies by id, then walls by index). A ray that starts inside
    a body meets it at distance 0 with the normal against the ray, unless the body is in
    `ignore`. Periodic boundaries: the ray runs on through the opposite side (bodies); walls
    do not repeat. A compound body is met only at its circles (circles: which), once per
    ray (first=False: at the nearer one)."""
    o = _points("origins", origins, world.dim)
    d = _points("directions", directions, world.dim)
    if d.shape[0] != o.shape[0]:
        raise ValueError(f"directions has {d.shape[0]} rays, origins {o.shape[0]}")
    d, norm = _unit(d)
    if np.any(norm == 0.0):
        q = int(np.flatnonzero(norm == 0.0)[0])
        raise ValueError(f"directions[{q}] = {d[q, :world.dim].tolist()}: a direction must "
                         f"not be zero")
    tmax = check.per_body("max_distance", max_distance, o.shape[0], minimum=0.0)
    tmax = np.ascontiguousarray(tmax, np.float64)
    return _cast(world, o, d, tmax, np.zeros(o.shape[0]), np.full(o.shape[0], -1),
                 _candidates(world, kinds, mask, ignore, filter), first, walls)


def _cast(world, o, d, tmax, extra, skip, rows, first, walls):
    """raycast's work, for rays (extra 0) and moving circles (extra: their radii, skip:
    their own rows) against the candidate rows: o, d (Q, 3), d unit; tmax (Q,)."""
    pos, radius, ids = _state(world)
    lo, period = _box(world)
    x = _circles(world, rows)
    if x is not None:
        body = _cast_circles(x, lo, period, o, d, tmax, extra, skip, first)
    else:
        # cells about as wide as the moving circles: their neighbourhoods stay a few cells
        g = _grid(world, _mean(extra), pos, radius, lo, period)
        offsets, hits, t = kq.raycasts(g, pos, radius, ids, _wanted(world, rows), period, o,
                                       d, tmax, extra, skip, first)
        ray, point, normal = kq.surfaces(pos, period, o, d, offsets, hits, t)
        body = (ray, ids[hits], np.full(hits.size, -1), t, point, normal,
                np.full(hits.size, -1))
    if walls and world.walls.shape[0]:
        wt, wn = _wall_hits(world, o, d, tmax, extra)
        if first:
            k = np.argmin(wt, axis=1)
            best = wt[np.arange(o.shape[0]), k]
            keep = np.isfinite(best)
            wray, wk, wtt = np.flatnonzero(keep), k[keep], best[keep]
        else:
            wray, wk = np.nonzero(np.isfinite(wt))
            wtt = wt[wray, wk]
        wall = (wray, np.full(wray.size, -1), wk, wtt, o[wray] + wtt[:, None] * d[wray],
                wn[wray, wk], np.full(wray.size, -1))
        parts = [np.concatenate([b, w]) for b, w in zip(body, wall)]
        kind = np.r_[np.zeros(body[0].size), np.ones(wray.size)]
        order = np.lexsort((parts[2], parts[1], kind, parts[3], parts[0]))
        parts = [p[order] for p in parts]
        if first:                              # the nearest of body and wall per ray
            keep = np.r_[True, parts[0][1:] != parts[0][:-1]] if parts[0].size else \
                np.zeros(0, bool)
            parts = [p[keep] for p in parts]
        ray, rid, rwall, t, point, normal, circle = parts
    else:
        ray, rid, rwall, t, point, normal, circle = body
    offsets = np.searchsorted(ray, np.arange(o.shape[0] + 1))
    dim = world.dim
    return RayHits(offsets.astype(np.int64), rid.astype(np.int64), rwall.astype(np.int64), t,
                   point[:, :dim], normal[:, :dim], circle.astype(np.int64))


def _cast_circles(x, lo, period, o, d, tmax, extra, skip, first):
    """_cast's body hits among a _Circles' entries: (ray, ids, walls (-1), t, point, normal,
    circle), a body once per ray (where its nearest circle is met), normals from the circle's
    centre. A cast whose skip (its own row) is a compound body cannot leave out its several
    entries in the kernel: those casts take every hit (first=False) and drop their own."""
    multi = np.zeros(o.shape[0], bool)
    own = skip >= 0
    multi[own] = x.compound[skip[own]]
    got = []
    for rays, many in ((np.flatnonzero(~multi), first), (np.flatnonzero(multi), False)):
        if got and not rays.size:
            continue
        oo, dd = o[rays], d[rays]
        sk = np.where(multi[rays], -1, skip[rays]).astype(np.int64)   # a round row: entry i
        ee = np.ascontiguousarray(extra[rays])
        g = _grid_once(x.pos, x.radius, x.rows, lo, period, _mean(ee))
        offsets, hits, t = kq.raycasts(g, x.pos, x.radius, x.ident, _ALL, period, oo, dd,
                                       np.ascontiguousarray(tmax[rays]), ee, sk, many)
        ray, point, normal = kq.surfaces(x.pos, period, oo, dd, offsets, hits, t)
        ray = rays[ray]
        keep = x.body[hits] != skip[ray]
        got.append((ray[keep], hits[keep], t[keep], point[keep], normal[keep]))
    ray, hits, t, point, normal = (np.concatenate(c) for c in zip(*got))
    order = np.lexsort((x.ident[hits], t, ray))            # per ray: by t, then id
    ray, hits, t, point, normal = ray[order], hits[order], t[order], point[order], \
        normal[order]
    keep = _once(ray, x.body[hits], x.compound.size)
    if first:                                              # the nearest per ray
        keep = keep[np.r_[True, ray[keep][1:] != ray[keep][:-1]]] if keep.size else keep
    ray, hits, t, point, normal = ray[keep], hits[keep], t[keep], point[keep], normal[keep]
    return ray, x.ident[hits], np.full(hits.size, -1), t, point, normal, x.circle[hits]


def shapecast(world, shape, displacement, kinds=None, mask=None, walls=True, ignore=None,
              filter=None):
    """The first body or wall a circle (2D) or sphere (3D) meets moving by displacement
    ((dim,) or (Q, dim), not zero): shape is a body id (or (Q,) ids: their own pos and
    radius, the body itself ignored) or (pos (dim,) or (Q, dim), radius >= 0: a number or
    (Q,)). A RayHits of at most one hit per shape: distances along the move (distance /
    |displacement| is the time of impact, 0..1), points the shape's centre at first
    contact, normals from what it meets toward it. A compound body met is met at one of its
    circles (circles: which); a compound body cast casts each of its circles from where it
    is now (not turning on the way), the earliest contact its hit, its point the body's
    centre then."""
    if isinstance(shape, tuple):
        if len(shape) != 2:
            raise ValueError(f"shape = {shape!r}: a body id, ids, or (pos, radius)")
        o = _points("shape pos", shape[0], world.dim)
        extra = check.per_body("shape radius", shape[1], o.shape[0], minimum=0.0)
        skip = np.full(o.shape[0], -1)
    else:
        rows = np.atleast_1d(world.index_of(shape, "shape"))
        o = np.zeros((rows.size, 3))
        o[:, :world.dim] = world.pos[rows]
        extra = world.radius[rows].copy()
        skip = rows
    dvec = _points("displacement", displacement, world.dim)
    if dvec.shape[0] == 1 and o.shape[0] > 1:
        dvec = np.repeat(dvec, o.shape[0], axis=0)
    if dvec.shape[0] != o.shape[0]:
        raise ValueError(f"displacement has {dvec.shape[0]} moves for {o.shape[0]} shapes")
    unit, length = _unit(dvec)
    if np.any(length == 0.0):
        q = int(np.flatnonzero(length == 0.0)[0])
        raise ValueError(f"displacement[{q}] is zero: a shape cast needs a move")
    rows = _candidates(world, kinds, mask, ignore, filter)
    got = None if isinstance(shape, tuple) else _compound(world)
    if got is not None:
        crow = np.asarray(world.index_of(got[0]), np.int64)
        if np.isin(skip, crow).any():          # a compound shape: each of its circles cast
            return _compound_shapecast(world, o, unit, length, extra, skip, rows, walls,
                                       crow, got[2], got[3])
    return _cast(world, o, unit, length, np.ascontiguousarray(extra, float),
                 np.ascontiguousarray(skip, np.int64), rows, True, walls)


def _compound_shapecast(world, o, unit, length, extra, skip, rows, walls, crow, centres,
                        cr):
    """shapecast of bodies (skip: their rows) some of which are compound: each circle of a
    compound shape cast from where it is now (the body not turning on the way), and each
    shape's earliest hit kept (ties as _cast's: bodies by id, then walls by index), its
    point moved back to the body's centre."""
    dim = world.dim
    by = np.argsort(crow, kind="stable")
    crow, centres, cr = crow[by], centres[by], cr[by]
    a = np.searchsorted(crow, skip, "left")
    b = np.searchsorted(crow, skip, "right")
    count = np.where(b > a, b - a, 1)                   # a round shape: one cast, itself
    shape = np.repeat(np.arange(skip.size), count)
    k = np.arange(count.sum()) - np.repeat(np.cumsum(count) - count, count)
    oo = o[shape].copy()
    ee = np.asarray(extra, float)[shape].copy()
    circ = (b > a)[shape]
    c = a[shape][circ] + k[circ]
    oo[circ, :dim] = centres[c]
    ee[circ] = cr[c]
    res = _cast(world, oo, np.ascontiguousarray(unit[shape]),
                np.ascontiguousarray(length[shape]), ee, skip[shape].astype(np.int64), rows,
                True, walls)
    ray = np.repeat(np.arange(len(res)), res.counts())
    q = shape[ray]
    order = np.lexsort((res.walls, res.ids, res.walls >= 0, res.distances, q))
    q, ray = q[order], ray[order]
    first = order[np.r_[True, q[1:] != q[:-1]]] if q.size else order
    ray = np.repeat(np.arange(len(res)), res.counts())[first]
    shift = (o[shape[ray]] - oo[ray])[:, :dim]          # the cast circle -> the body's centre
    return RayHits(np.searchsorted(shape[ray], np.arange(skip.size + 1)).astype(np.int64),
                   res.ids[first], res.walls[first], res.distances[first],
                   res.points[first] + shift, res.normals[first], res.circles[first])
