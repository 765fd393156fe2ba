"""The World's collision rules, one component: the kind x kind response matrix, walls, the
boundary and the broad phase's cell; it validates them and builds the collision pass's table
(kernels/rules.Rules). Adding a collision response touches kernels/codes.py (its code and
name) and kernels/responses.py (what it does at contact)."""
import numpy as np

from . import _validate as check
from .entities import Circles
from .kernels import rules as krules
from .kernels import shapes as kshapes
from .kernels.arrays import largest
from .kernels.codes import (BOUNCE, BOUNDARIES, BREAK_A, BREAK_B, FOLLOWS, IGNORE, IN_GRID,
                            MIRRORED, OPEN, OUT_OF_GRID, PLANE, RESPONSES, SEGMENT)
from . import portable


def _restitution(value):
    value = check.scalar("restitution", value, minimum=0.0)
    if value > 1.0:
        raise ValueError(f"restitution = {value}: must be <= 1")
    return value


class CollisionRules:
    """What happens when bodies meet (see the module). kinds : the number of declared kinds."""

    def __init__(self, kinds):
        self.response = np.zeros((kinds, kinds), dtype=np.int64)   # all "ignore" until set
        self.restitution = np.ones((kinds, kinds))
        self.walls = np.zeros((0, 8))
        self.boundary = OPEN
        self.box = np.zeros((2, 3))
        self.box_restitution = 1.0
        self.cell = None                   # None: chosen from the radii (see giants)
        self.shapes = []                   # the compound shapes (Circles) the column names
        self._touch_set(np.zeros((0, 3), np.int64))

    def _touch_set(self, pairs):
        """The pairs in touch (krules.FIELDS: ids a < b, 1 for a sensor), with room to grow
        without the kernel reallocating (it may: `caught_up` takes its array back)."""
        self.touch = np.zeros((max(16, 2 * len(pairs)), 3), np.int64)
        self.touch[:len(pairs)] = pairs
        self.ntouch = np.array([len(pairs), self.touch.shape[0]], np.int64)

    def touching(self):
        """(P, 3) int64: the pairs overlapping (sensor, 1) or touching (contact, 0) at the end
        of the last step, ids a < b."""
        return self.touch[:self.ntouch[0]].copy()

    def set_touching(self, pairs):
        """Make `pairs` (as touching() gives) the pairs in touch, in the arrays the kernels
        share when they fit; returns False when new arrays were needed (tables to rebuild)."""
        if len(pairs) > self.touch.shape[0]:
            self._touch_set(pairs)
            return False
        self.touch[:len(pairs)] = pairs
        self.ntouch[0] = len(pairs)
        return True

    def motion(self, plan):
        """What moves with the tables kept (worldstate.Motion): the pairs in touch, and the
        launchers the tables' unarmed missiles still ignore (None without a collision
        table)."""
        owners = None if plan is None else plan.owners
        return self.touching(), None if owners is None else owners.copy()

    def set_motion(self, motion, plan):
        """motion()'s into these rules and plan's table; False when the pairs in touch
        outgrew the table's array (the tables must be built again)."""
        touching, owners = motion
        if owners is not None:
            plan.owners[:] = owners
        return self.set_touching(touching)

    def caught_up(self, rules):
        """After a kernel call: the touch array the kernel grew, if it did."""
        if self.ntouch[1] != self.touch.shape[0]:
            self.touch = krules.touch_of(rules)

    def add_kind(self):
        """Room for one more kind (every pair with it ignored)."""
        k = self.response.shape[0] + 1
        response, restitution = np.zeros((k, k), np.int64), np.ones((k, k))
        response[:-1, :-1] = self.response
        restitution[:-1, :-1] = self.restitution
        self.response, self.restitution = response, restitution

    # ------------------------------------------------------------ rules
    def set(self, codes_a, codes_b, response, restitution=None):
        """The response for every pair of kind codes (a, b), either order (see
        World.set_collision); everything is checked before anything changes."""
        if not isinstance(response, str) or response not in RESPONSES:
            raise ValueError(f"response={response!r} is not known; valid: {', '.join(RESPONSES)}")
        code = RESPONSES[response]
        if code in (BREAK_A, BREAK_B) and restitution is None:
            restitution = 1.0
        if code in (BOUNCE, BREAK_A, BREAK_B):
            if restitution is None:
                raise ValueError("response='bounce' needs restitution, in [0, 1]")
            restitution = _restitution(restitution)
        elif restitution is not None:
            raise ValueError(f"restitution = {restitution!r} is only used with response='bounce'")
        for a in codes_a:
            for b in codes_b:
                self.response[a, b] = code
                self.response[b, a] = MIRRORED.get(code, code) if a != b else code
                if restitution is not None:
                    self.restitution[a, b] = self.restitution[b, a] = restitution

    def rule(self, a, b):
        """(response name, restitution) for kind codes a, b."""
        name = next(k for k, v in RESPONSES.items() if v == self.response[a, b])
        return name, float(self.restitution[a, b])

    def add_wall(self, kind, p, q, restitution, dim):
        """A wall row (codes.PLANE through p with unit normal q, or SEGMENT from p to q)."""
        restitution = _restitution(restitution)
        row = np.zeros(8)
        row[0] = kind
        row[1:1 + dim] = p
        row[4:4 + dim] = q
        row[7] = restitution
        self.walls = np.vstack([self.walls, row])
        return len(self.walls) - 1

    def plane(self, point, normal, restitution, dim):
        point = check.floats("point", point, (dim,))
        normal = check.floats("normal", normal, (dim,))
        length = portable.norm(normal)
        if length == 0:
            raise ValueError("normal = 0: a plane needs a direction")
        return self.add_wall(PLANE, point, normal / length, restitution, dim)

    def segment(self, a, b, restitution, dim):
        a = check.floats("a", a, (dim,))
        b = check.floats("b", b, (dim,))
        if np.array_equal(a, b):
            raise ValueError(f"a = b = {a.tolist()}: a segment needs two distinct ends")
        return self.add_wall(SEGMENT, a, b, restitution, dim)

    def set_boundary(self, mode, lo, hi, restitution, dim):
        if not isinstance(mode, str) or mode not in BOUNDARIES:
            raise ValueError(f"boundary={mode!r} is not known; valid: {', '.join(BOUNDARIES)}")
        box = np.zeros((2, 3))
        if mode != "open":
            if lo is None or hi is None:
                raise ValueError(f"boundary={mode!r} needs lo and hi, the box's corners")
            box[0, :dim] = check.floats("lo", lo, (dim,))
            box[1, :dim] = check.floats("hi", hi, (dim,))
            bad = np.flatnonzero(box[1, :dim] <= box[0, :dim])
            if bad.size:
                raise ValueError(f"hi[{bad[0]}] = {box[1, bad[0]]} is not above "
                                 f"lo[{bad[0]}] = {box[0, bad[0]]}")
        restitution = _restitution(restitution)
        self.boundary, self.box, self.box_restitution = BOUNDARIES[mode], box, restitution

    def boundary_of(self, dim):
        """(mode, lo, hi, restitution)."""
        mode = next(k for k, v in BOUNDARIES.items() if v == self.boundary)
        return mode, self.box[0, :dim].copy(), self.box[1, :dim].copy(), self.box_restitution

    def set_cell(self, value):
        self.cell = None if value is None else check.scalar("collision_cell", value,
                                                            positive=True)

    def enabled(self):
        """Whether anything can collide: a response set, a wall, or a boundary."""
        return bool(self.response.any() or len(self.walls) or self.boundary != OPEN)

    def shift(self, delta, dim):
        """The origin moved by delta (dim,): walls and the box with it."""
        if len(self.walls):
            self.walls[:, 1:1 + dim] -= delta
            segments = self.walls[:, 0] == SEGMENT
            self.walls[segments, 4:4 + dim] -= delta
        if self.boundary != OPEN:
            self.box[:, :dim] -= delta

    # ------------------------------------------------------------ compound shapes
    def shape_code(self, circles):
        """The library index of a Circles (added once; equal shapes share an entry)."""
        if circles not in self.shapes:
            self.shapes.append(circles)
        return self.shapes.index(circles)

    def library(self):
        """(rows (S, 2) int64: first circle and count of each shape, circles (C, 4):
        offsets x, y, z and radius, gyration (S,): Circles.gyration)."""
        counts = np.array([len(c.radii) for c in self.shapes], np.int64)
        rows = np.stack([np.cumsum(counts) - counts, counts], axis=1) if counts.size else \
            np.zeros((0, 2), np.int64)
        circles = np.concatenate([c.rows() for c in self.shapes]) if self.shapes else \
            np.zeros((0, 4))
        return rows, circles, np.array([c.gyration() for c in self.shapes], np.float64)

    def world_circles(self, shape, pos, quat, rows=None):
        """Every circle of the compound bodies among `rows` (default all) now: (rows (C,),
        circle index in its body (C,), centres (C, 3), radii (C,)). shape (n,) the shape
        column, pos (n, 3), quat (n, 4) the orientations."""
        rows = np.flatnonzero(shape >= 0) if rows is None else \
            np.asarray(rows)[shape[rows] >= 0]
        if not rows.size:
            return rows, np.zeros(0, np.int64), np.zeros((0, 3)), np.zeros(0)
        table, circles, _ = self.library()
        first, count = table[shape[rows]].T
        body = np.repeat(rows, count)
        k = np.arange(count.sum()) - np.repeat(np.cumsum(count) - count, count)
        c = circles[np.repeat(first, count) + k]
        w, x, y, z = quat[body].T
        o = c[:, :3]
        # R(q) o, row by row
        t = 2.0 * np.cross(np.stack([x, y, z], axis=1), o)
        turned = o + w[:, None] * t + np.cross(np.stack([x, y, z], axis=1), t)
        return body, k, pos[body] + turned, c[:, 3].copy()

    # ------------------------------------------------------------ the table
    def giants(self, radius):
        """(rows of the giants, grid cell). With the default cell: the largest bodies above
        the widest gap (at least 2x in radius) among the 65 largest, at most 64 of them, are
        giants, tested against every body; the cell is the largest diameter of the rest.
        A cell set by the user puts every body in the grid."""
        r = radius
        if self.cell is not None:
            return np.zeros(0, np.int64), self.cell
        if r.size == 0:
            return np.zeros(0, np.int64), 1.0
        rows = largest(r, 65)
        ordered = r[rows]
        giants = 0
        if ordered.size > 1:
            with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
                # a body with a radius above points (or a tiny one): an infinite gap;
                # between points: none
                gaps = np.where(ordered[1:] > 0, ordered[:-1] / ordered[1:],
                                np.where(ordered[:-1] > 0, np.inf, 1.0))
            k = int(np.argmax(gaps))
            if gaps[k] >= 2.0 and k < 64:
                giants = k + 1
        biggest = ordered[giants] if giants < ordered.size else 0.0
        return np.sort(rows[:giants]).astype(np.int64), 2.0 * biggest if biggest > 0 else 1.0

    def table(self, kind, radius, category, mask, group, fixed, owner, dim, index, scratch,
              shape=None, orientation=None):
        """The collision pass's Rules for the bodies (n,) columns given (shared), or None
        when nothing can collide. group : (n,) int64 collision groups, or (0,) when no body
        has one; owner : (n,) int64 launcher rows of the missiles that ignore them;
        index : the bodies' slot -> row table; scratch : name -> (n, ...) arrays for
        krules.SCRATCH; shape : (n,) the shape column (None: every body round), orientation :
        the actors' (quat, omega, inertia) columns, (n, ...) each, when a body has a shape."""
        if not self.enabled():
            return None
        shapes = None
        if shape is not None and (shape >= 0).any():
            shapes = kshapes.make(shape, *self.library(), *orientation)
        giants, cell = self.giants(radius)
        # a kind needs the grid if it can meet a kind with bodies besides giants (itself: two);
        # bodies that meet only giants stay out of it (they look up a grid of the giants)
        K = self.response.shape[0]
        counts = np.bincount(kind, minlength=K) - np.bincount(kind[giants], minlength=K)
        meets = (self.response != IGNORE) & (counts[None, :] > np.eye(K, dtype=np.int64))
        needs = meets.any(axis=1)
        follows = self._followers(counts * needs)
        # how the grid enters each body, by its kind (one gather: this runs after every step
        # that destroys something)
        entered = np.where(needs, np.where(follows, FOLLOWS, IN_GRID), OUT_OF_GRID)
        gridded = entered.astype(np.int8)[kind]
        gridded[giants] = OUT_OF_GRID
        return krules.make(scratch, kind=kind, radius=radius, category=category, mask=mask,
                           group=group, fixed=fixed, response=self.response, restitution=self.restitution,
                           walls=self.walls, boundary=self.boundary, box=self.box,
                           box_restitution=self.box_restitution, cell=cell, dim=dim,
                           owner=owner, giants=giants, gridded=gridded, index=index,
                           touch=self.touch, ntouch=self.ntouch, shapes=shapes)

    def _followers(self, counts):
        """(K,) bool: the kinds whose bodies the grid enters only in cells that hold a body of
        another kind (codes.FOLLOWS). They meet none of their own or of each other (so
        a cell of followers alone holds no pair; those that meet a giant look the giants
        up, as the bodies outside the grid do), and are worth it: at least twice as many as
        the others (the 5e4 debris among 2e3 ships and missiles of a fleet battle: a look-up
        each instead of an entry).
        counts : (K,) the bodies of each kind the grid holds."""
        K = self.response.shape[0]
        meets = (self.response != IGNORE) | (self.response.T != IGNORE)
        follows = np.zeros(K, np.bool_)
        for k in np.argsort(-counts, kind="stable"):
            if counts[k] and not meets[k, follows].any() and not meets[k, k]:
                follows[k] = True
        if counts[follows].sum() < 2 * counts[~follows].sum():
            follows[:] = False
        return follows

    # ------------------------------------------------------------ state
    def state(self):
        return {"response": self.response.copy(), "restitution": self.restitution.copy(),
                "walls": self.walls.copy(), "boundary": int(self.boundary),
                "box": self.box.copy(), "box_restitution": float(self.box_restitution),
                "cell": -1.0 if self.cell is None else float(self.cell),
                "touching": self.touching(),
                "shape_rows": self.library()[0], "shape_circles": self.library()[1],
                "shape_dims": np.array([c.dim for c in self.shapes], np.int64)}

    @classmethod
    def from_state(cls, s):
        r = cls.__new__(cls)
        r.response = np.array(s["response"], np.int64)
        r.restitution = np.array(s["restitution"], np.float64)
        r.walls = np.array(s["walls"], np.float64).reshape(-1, 8)
        r.boundary = int(s["boundary"])
        r.box = np.array(s["box"], np.float64)
        r.box_restitution = float(s["box_restitution"])
        r.cell = None if float(s["cell"]) < 0 else float(s["cell"])
        r._touch_set(np.array(s.get("touching", np.zeros((0, 3))), np.int64).reshape(-1, 3))
        rows = np.array(s.get("shape_rows", np.zeros((0, 2))), np.int64).reshape(-1, 2)
        circles = np.array(s.get("shape_circles", np.zeros((0, 4))), np.float64).reshape(-1, 4)
        dims = np.array(s.get("shape_dims", np.zeros(0)), np.int64).reshape(-1)
        r.shapes = [Circles(circles[a:a + k, :d], circles[a:a + k, 3])
                    for (a, k), d in zip(rows, dims)]
        return r
