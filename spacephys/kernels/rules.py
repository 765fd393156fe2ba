"""The collision pass's table (`Rules`, a numba structref built by spacephys/collisions.py) and
what every part of the pass asks of it: a pair's response (`allowed`), the periodic box
(`periods`, `wrap`). The pass itself is kernels/collide.py.
"""
import math

import numpy as np
from numba.experimental import structref

from .._jit import TableType, kernel
from .codes import IGNORE, PERIODIC


@structref.register
class RulesType(TableType):
    pass


class Rules(structref.StructRefProxy):
    """The collision pass's table (see FIELDS); made by `make`, read by the kernels."""


FIELDS = (
    "kind",          # (n,) int64 kind codes
    "radius",        # (n,) float64, updated by merges
    "category",      # (n,) int64 bits a body is
    "mask",          # (n,) int64 bits a body collides with
    "fixed",         # (n,) bool: immovable (infinite mass)
    "response",      # (K, K) int64, the kind x kind matrix of responses
    "restitution",   # (K, K) float64, for BOUNCE
    "walls",         # (W, 8) float64, see codes.PLANE and SEGMENT
    "boundary",      # int: OPEN | REFLECT | PERIODIC
    "box",           # (2, 3) float64: the boundary's low and high corners
    "box_restitution",  # float
    "cell",          # float > 0: grid cell size [length]
    "dim",           # 2 or 3: merged radii keep area (2D) or volume (3D)
    "owner",         # (n,) int64: the launcher of a missile not yet armed, or one that spares
                     # it (ignored by it), -1
    "group",         # (n,) int64 collision groups (bodies of one group > 0 never meet), or
                     # (0,) when no body has one
    "shapes",        # kernels/shapes.Shapes: the compound hitboxes, or None when every body
                     # is round (the pass then compiles none of their code)
    "giants",        # (G,) int64 rows of bodies far larger than the cell: tested against all
    "gridded",       # (n,) int8: how the broad phase's grid takes each body (codes.py:
                     # OUT_OF_GRID, IN_GRID, FOLLOWS)
    "index",         # (slots,) int64: the World's slot -> row table (ids to rows)
    "touch",         # (cap, 3) int64: the pairs overlapping (sensors) or touching (contacts)
                     # at the end of the last step: ids a < b, 1 for a sensor pair, 0 a contact
    "ntouch",        # (2,) int64: the pairs in touch, and touch's capacity (grown in kernel)
    "found",         # (cap, 2) int64: this step's sensor meetings and bounces, rows i < j...
    "found_t",       # (cap,) float64: ...at their times (fractions of the step)
    "nfound",        # (1,) int64
    # per-body scratch of the pass, reused from step to step
    "A", "B", "D", "lo", "hi",                 # (n, 3) float64: lines, impulses, boxes
    "tb",                                      # (n,) float64: where each line begins
    "ever", "touched", "in_focus", "is_giant",  # (n,) bool
    "merged",                                  # (n,) int64
    "stale",                                   # (n,) bool
    "grid",          # (n, 16) int64: the grid's entries and the sort's, 4 per body (grown
                     # by the pass when the boxes cover more cells, see _entries)
)
structref.define_proxy(Rules, RulesType, list(FIELDS))


@kernel
def _make(*fields):
    return Rules(*fields)


def make(scratch, **fields):
    """A Rules table from the fields named in FIELDS (arrays shared, not copied): index, the
    World's slot -> row table; touch and ntouch, the pairs in touch, the World's; scratch : the
    per-body scratch arrays named in SCRATCH, n rows each. This step's meetings start empty."""
    fields = {**scratch, **fields, "boundary": int(fields["boundary"]),
              "box_restitution": float(fields["box_restitution"]),
              "cell": float(fields["cell"]), "dim": int(fields["dim"]),
              "found": np.empty((16, 2), np.int64), "found_t": np.empty(16),
              "nfound": np.zeros(1, np.int64), "shapes": fields.get("shapes")}
    return _make(*(fields[name] for name in FIELDS))


@kernel
def touch_of(rules):
    """The table's pairs in touch (its array: the kernel may have grown it)."""
    return rules.touch


@kernel
def giants_of(rules):
    """The rows of the giants a Rules table holds (for tests and tools)."""
    return rules.giants


@kernel
def gridded_of(rules):
    """How the grid takes each row (codes.OUT_OF_GRID, IN_GRID, FOLLOWS), for tests and
    tools."""
    return rules.gridded


@kernel
def wrap(d, length):
    """The image of a difference d nearest to zero on a periodic axis of the given length."""
    if length > 0.0:
        return d - length * math.floor(d / length + 0.5)
    return d


@kernel
def periods(rules):
    """Box lengths per axis when wrapping, else zeros."""
    L = np.zeros(3)
    if rules.boundary == PERIODIC:
        for c in range(rules.dim):
            L[c] = rules.box[1, c] - rules.box[0, c]
    return L


@kernel(inline=True)
def allowed(rules, kind, i, j):
    """The response for the pair, IGNORE when the category/mask bits filter it out."""
    if (rules.category[i] & rules.mask[j]) == 0 or (rules.category[j] & rules.mask[i]) == 0:
        return IGNORE
    if rules.owner[i] == j or rules.owner[j] == i:
        return IGNORE                     # a missile and the launcher it spares
    if grouped(rules.group, i, j):
        return IGNORE
    return rules.response[kind[i], kind[j]]


@kernel(inline=True)
def grouped(group, i, j):
    """Whether rows i and j share a collision group (> 0): such bodies never meet."""
    return group.size > 0 and group[i] > 0 and group[i] == group[j]


SCRATCH = {"A": (3, np.float64), "B": (3, np.float64), "D": (3, np.float64),
           "lo": (3, np.float64), "hi": (3, np.float64), "tb": ((), np.float64),
           "ever": ((), np.bool_), "touched": ((), np.bool_), "in_focus": ((), np.bool_),
           "is_giant": ((), np.bool_), "merged": ((), np.int64), "stale": ((), np.bool_),
           "grid": (16, np.int64)}
"""The per-body scratch of the pass: name -> (trailing shape, dtype)."""
