"""Swept circle/sphere collisions within a step: broad phase, time of impact, responses, walls.

The seed's steps of analysis, for every pair at once. Over a step each body moves on the
straight line from its start to its end position, p(t) = A + B t, t in [0, 1] of the step.
1. Broad phase: the box each body sweeps goes into every cell of a uniform grid it touches;
   the cells' hashes are grouped by a radix sort (linear in N), and a pair is reported only
   in the cell holding the low corner of the overlap of its two boxes, so never twice. A few
   giants (planets among ships) look up the cells their boxes cover instead of setting a
   huge cell, and bodies whose kinds meet nothing but giants (debris that only hit planets)
   stay out of the grid and look up a grid of the giants. A sparse scene takes cells about
   its span per body (_grid_pairs says when). The hot loops are written out and write into
   arrays they are given: numba's helpers returning tuples, the tables' fields read per
   pair, an array replaced inside a loop, and arrays passed with reference counting to a
   helper called per body (lean=True avoids it) each cost two to ten times the work.
2. Narrow phase: the earliest t with |dA + dB t| = r1 + r2, from squared distances (one square
   root per real contact, none per rejected pair).
3. Contacts are resolved in time order (at one time in row order, so the outcome does not
   depend on the grid): back up to contact, respond, move on along the new line for the rest
   of the step. A body takes one contact per pass; passes repeat until no
   contact is left (each looks only the bodies whose lines changed up in the first pass's
   grid, testing those changed since directly), and a last pass makes sure no pair ends the
   step overlapping and approaching.
Responses work with mass fractions m_j / (m_i + m_j) computed from the ratio of the masses,
so very different masses do not lose the light body's velocity to round-off. Compiled without
fastmath: the time-of-impact roots and the exact velocity swap of equal masses need exact
rounding.
"""
import math

import numpy as np
from numba.experimental import structref

from .._jit import TableType, kernel
from .arrays import contact_order, grown_pairs, sort_in_place, stable_order
from .codes import (BOUNCE, BREAK_A, DESTROY_A, DESTROY_B, DESTROY_BOTH, ELASTIC, EV_BOUNCE,
                    EV_CONTACT_BEGIN, EV_CONTACT_END, EV_DESTROY, EV_MERGE, EV_SENSOR_BEGIN,
                    EV_SENSOR_END, EV_WALL, IGNORE, MERGE, PERIODIC, PLANE, REFLECT, REFLECTING,
                    SENSOR, TOUCH_ENDS)
from .state import record

_SPARSE = 0.5        # a sparse scene's coarse cell: this times the span's length per body
_MAX_PASSES = 32
# bodies in contact (elastic, bounce) are touching while the gap between their surfaces is at
# most this fraction of the sum of their radii: a resting body's gap after its bounce is
# rounding, a settling one's e g dt^2; a visible gap is a separation
CONTACT_SLOP = 1e-4
_SLOT_MASK = (1 << 32) - 1                # an id's slot (state.py: (generation << 32) | slot)
# a grid entry's body carries its kind in its low bits: a pair of kinds that never meet is
# passed over without reading either body (debris among debris, in heaps after explosions)
_KIND_BITS = 16
_KIND_MASK = (1 << _KIND_BITS) - 1
# gridded's mark of a body whose kind meets no kind so marked (debris that hit ships and
# planets but not each other): only a cell that also holds an unmarked body can make its pairs
FOLLOWS = 2


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
    "owner",         # (n,) int64: the launcher of a missile not yet armed (ignored by it), -1
    "giants",        # (G,) int64 rows of bodies far larger than the cell: tested against all
    "gridded",       # (n,) int8: 0 a body left out of the grid (a giant, or of a kind that
                     # meets giants only), 1 entered in every cell its box covers, FOLLOWS
                     # entered only in the cells a body entered with 1 covers (see _entries)
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
def owners_of(rules):
    """The table's owner array (shared): a prediction's copy takes the World's."""
    return rules.owner


@kernel
def _make(kind, radius, category, mask, fixed, response, restitution, walls, boundary, box,
          box_restitution, cell, dim, owner, giants, gridded, index, touch, ntouch, A, B, D,
          lo, hi, tb, ever, touched, in_focus, is_giant, merged, stale, grid):
    return Rules(kind, radius, category, mask, fixed, response, restitution, walls, boundary,
                 box, box_restitution, cell, dim, owner, giants, gridded, index, touch, ntouch,
                 np.empty((16, 2), np.int64), np.empty(16), np.zeros(1, np.int64), A, B, D,
                 lo, hi, tb, ever, touched, in_focus, is_giant, merged, stale, grid)


def make(kind, radius, category, mask, fixed, response, restitution, walls, boundary, box,
         box_restitution, cell, dim, owner, giants, gridded, index, touch, ntouch, scratch):
    """A Rules table (arrays shared, not copied); index : the World's slot -> row table;
    touch, ntouch : the pairs in touch (FIELDS), the World's; scratch : dict of the per-body
    scratch arrays named in FIELDS, n rows each."""
    return _make(kind, radius, category, mask, fixed, response, restitution, walls,
                 int(boundary), box, float(box_restitution), float(cell), int(dim), owner,
                 giants, gridded, index, touch, ntouch,
                 *(scratch[k] for k in ("A", "B", "D", "lo", "hi", "tb", "ever", "touched",
                                        "in_focus", "is_giant", "merged", "stale",
                                        "grid")))


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
    """How the grid enters each row (0, 1, FOLLOWS: see FIELDS), for tests and tools."""
    return rules.gridded


SCRATCH = {"A": (3, np.float64), "B": (3, np.float64), "D": (3, np.float64),
           "lo": (3, np.float64), "hi": (3, np.float64), "tb": ((), np.float64),
           "ever": ((), np.bool_), "touched": ((), np.bool_), "in_focus": ((), np.bool_),
           "is_giant": ((), np.bool_), "merged": ((), np.int64), "stale": ((), np.bool_),
           "grid": (16, np.int64)}
"""The per-body scratch of the pass: name -> (trailing shape, dtype)."""


@kernel
def _wrap(d, length):
    """The image of a difference d nearest to zero on a periodic axis of the given length."""
    if length > 0.0:
        return d - length * math.floor(d / length + 0.5)
    return d


@kernel
def _periods(rules):
    """Box lengths per axis when wrapping, else zeros."""
    L = np.zeros(3)
    if rules.boundary == PERIODIC:
        for c in range(rules.dim):
            L[c] = rules.box[1, c] - rules.box[0, c]
    return L


@kernel(lean=True)
def _pair_time(A, B, i, j, R, t_lo, L, overlap_counts):
    """Earliest t in [t_lo, 1] at which bodies i and j, on p = A + B t, are R apart; -1 if
    they do not touch, or touch only while separating. With overlap_counts (merges, destroys)
    bodies already overlapping at t_lo meet at t_lo whichever way they move. Squared
    distances until a root is certain."""
    d0 = _wrap(A[j, 0] - A[i, 0], L[0])
    d1 = _wrap(A[j, 1] - A[i, 1], L[1])
    d2 = _wrap(A[j, 2] - A[i, 2], L[2])
    e0 = B[j, 0] - B[i, 0]
    e1 = B[j, 1] - B[i, 1]
    e2 = B[j, 2] - B[i, 2]
    # relative position at t_lo, and the quadratic |p + e s|^2 = R^2 in s = t - t_lo
    p0 = d0 + e0 * t_lo
    p1 = d1 + e1 * t_lo
    p2 = d2 + e2 * t_lo
    a = e0 * e0 + e1 * e1 + e2 * e2
    b = p0 * e0 + p1 * e1 + p2 * e2
    c = p0 * p0 + p1 * p1 + p2 * p2 - R * R
    if c <= 0.0 and (b < 0.0 or overlap_counts):
        return t_lo                       # overlapping (and approaching): contact now
    if b >= 0.0:
        return -1.0                       # not approaching: no contact ahead
    disc = b * b - a * c
    if disc < 0.0:
        return -1.0
    s = c / (-b + math.sqrt(disc))        # the smaller root, without cancellation
    if t_lo + s > 1.0:
        return -1.0
    return t_lo + s


@kernel(lean=True)
def _wall_time(A, B, i, r, wall, t_lo):
    """Earliest t in [t_lo, 1] at which body i (radius r) touches the wall row; -1 if never.
    Returns (t, nx, ny, nz) with n the wall's normal toward the body at contact."""
    if wall[0] == PLANE:
        q0, q1, q2 = wall[1], wall[2], wall[3]
        n0, n1, n2 = wall[4], wall[5], wall[6]
        s0 = (A[i, 0] + B[i, 0] * t_lo - q0) * n0 + (A[i, 1] + B[i, 1] * t_lo - q1) * n1 \
            + (A[i, 2] + B[i, 2] * t_lo - q2) * n2 - r
        rate = B[i, 0] * n0 + B[i, 1] * n1 + B[i, 2] * n2
        if rate >= 0.0:
            return -1.0, n0, n1, n2
        if s0 <= 0.0:
            return t_lo, n0, n1, n2
        t = t_lo - s0 / rate
        return (t if t <= 1.0 else -1.0), n0, n1, n2
    # segment: the earliest touch of the capsule of radius r around it, from its side faces
    # (a moving point against a cylinder: a quadratic) or its two end caps (point vs sphere)
    best = -1.0
    bn0 = 0.0
    bn1 = 0.0
    bn2 = 0.0
    u0, u1, u2 = wall[4] - wall[1], wall[5] - wall[2], wall[6] - wall[3]
    uu = u0 * u0 + u1 * u1 + u2 * u2
    for end in range(3):
        if end < 2:
            # end caps: body centre vs a sphere of radius r at the end point
            o = 1 if end == 0 else 4
            d0 = A[i, 0] - wall[o]
            d1 = A[i, 1] - wall[o + 1]
            d2 = A[i, 2] - wall[o + 2]
            e0, e1, e2 = B[i, 0], B[i, 1], B[i, 2]
        else:
            # side: the components perpendicular to the segment
            d0 = A[i, 0] - wall[1]
            d1 = A[i, 1] - wall[2]
            d2 = A[i, 2] - wall[3]
            e0, e1, e2 = B[i, 0], B[i, 1], B[i, 2]
            k = (d0 * u0 + d1 * u1 + d2 * u2) / uu
            d0, d1, d2 = d0 - k * u0, d1 - k * u1, d2 - k * u2
            k = (e0 * u0 + e1 * u1 + e2 * u2) / uu
            e0, e1, e2 = e0 - k * u0, e1 - k * u1, e2 - k * u2
        p0 = d0 + e0 * t_lo
        p1 = d1 + e1 * t_lo
        p2 = d2 + e2 * t_lo
        a = e0 * e0 + e1 * e1 + e2 * e2
        b = p0 * e0 + p1 * e1 + p2 * e2
        c = p0 * p0 + p1 * p1 + p2 * p2 - r * r
        if b >= 0.0:
            continue
        if c <= 0.0:
            s = 0.0
        else:
            disc = b * b - a * c
            if disc < 0.0:
                continue
            s = c / (-b + math.sqrt(disc))
        t = t_lo + s
        if t > 1.0:
            continue
        # where along the segment is the contact? the side only counts between the ends
        x0 = A[i, 0] + B[i, 0] * t - wall[1]
        x1 = A[i, 1] + B[i, 1] * t - wall[2]
        x2 = A[i, 2] + B[i, 2] * t - wall[3]
        k = (x0 * u0 + x1 * u1 + x2 * u2) / uu
        if end == 2 and not (0.0 <= k <= 1.0):
            continue
        if best < 0.0 or t < best:
            k = min(max(k, 0.0), 1.0)
            m0, m1, m2 = x0 - k * u0, x1 - k * u1, x2 - k * u2
            norm = math.sqrt(m0 * m0 + m1 * m1 + m2 * m2)
            if norm > 0.0:
                best = t
                bn0, bn1, bn2 = m0 / norm, m1 / norm, m2 / norm
    return best, bn0, bn1, bn2


@kernel(inline=True)
def _allowed(rules, kind, i, j):
    """The response for the pair, IGNORE when the category/mask bits filter it out."""
    if (rules.category[i] & rules.mask[j]) == 0 or (rules.category[j] & rules.mask[i]) == 0:
        return IGNORE
    if rules.owner[i] == j or rules.owner[j] == i:
        return IGNORE                     # a missile and its launcher, before it is armed
    return rules.response[kind[i], kind[j]]


@kernel
def _bounds(A, B, tb, radius, alive, lo, hi, rows):
    """The box each live body sweeps over [tb, 1] of the step: every body, or only those in
    rows when rows is not empty."""
    for q in range(rows.size if rows.size else A.shape[0]):
        i = rows[q] if rows.size else q
        if not alive[i]:
            continue
        for c in range(3):
            x0 = A[i, c] + B[i, c] * tb[i]
            x1 = A[i, c] + B[i, c]
            lo[i, c] = min(x0, x1) - radius[i]
            hi[i, c] = max(x0, x1) + radius[i]


@kernel(inline=True)
def _cell_key(cx, cy, cz):
    """A 64-bit hash of a cell: entries are grouped by it. Two cells sharing a key (odds
    about 1e-8 for a million cells) would only make a pair be tested twice."""
    h = cx * -7046029254386353131 + cy * -4417276706812531889 + cz * 1609587929392839161
    h ^= (h >> 31) & 0x1FFFFFFFF
    h *= -7723592293110705685
    h ^= (h >> 29) & 0x7FFFFFFFF
    return h


@kernel(inline=True)
def _wrap_index(k, n):
    return k % n if n > 0 else k


@kernel
def _radix_sort(keys, values, keys_out, values_out, bits):
    """Sort (keys, values) by the low `bits` (a multiple of 8) bits of keys, 8 at a time
    (LSD radix: linear; each pass streams the arrays once and scatters into 256 streams,
    which stay in cache: measured twice as fast as 11-bit digits at 3e5 entries). Only a
    grouping is needed: entries of one cell end up adjacent, with a few other cells' entries
    mixed into the same run of low bits (the scan compares full keys). Returns the sorted
    arrays."""
    n = keys.size
    count = np.zeros(257, np.int64)
    src_k, src_v, dst_k, dst_v = keys, values, keys_out, values_out
    for shift in range(0, bits, 8):
        for d in range(257):
            count[d] = 0
        for e in range(n):
            count[((src_k[e] >> shift) & 255) + 1] += 1
        for d in range(256):
            count[d + 1] += count[d]
        for e in range(n):
            d = (src_k[e] >> shift) & 255
            dst_k[count[d]] = src_k[e]
            dst_v[count[d]] = src_v[e]
            count[d] += 1
        src_k, src_v, dst_k, dst_v = dst_k, dst_v, src_k, src_v
    return src_k, src_v


@kernel
def candidate_pairs(A, B, tb, alive, rules, lo, hi):
    """Pairs (i < j) whose swept boxes share a cell and whose response is not IGNORE.

    Returns (pairs (m, 2) int64, entries): each pair once, in a deterministic order.
    """
    pairs, grid = _grid_pairs(A, B, tb, alive, rules, lo, hi)
    return pairs, grid[0].size


@kernel
def _layout(size, low, high, rules, L):
    """A grid of cells `size` over the span low..high (3,): (origin (3,), inverse cell (3,),
    ncell (3,): the whole cells around a period, or 0)."""
    origin = np.zeros(3)
    for c in range(rules.dim):
        if high[c] > low[c]:
            size = max(size, (high[c] - low[c]) * 2.0 ** -40)
            if max(abs(low[c]), abs(high[c])) > size * 2.0 ** 50:
                origin[c] = low[c]
    cell = np.full(3, size)
    ncell = np.zeros(3, np.int64)
    for c in range(3):
        if L[c] > 0.0:
            origin[c] = rules.box[0, c]
            ncell[c] = max(1, int(L[c] // max(size, L[c] * 2.0 ** -40)))
            cell[c] = L[c] / ncell[c]                  # whole cells around the period
    cell = 1.0 / cell                                  # multiplied below: no divisions
    for c in range(rules.dim, 3):
        cell[c] = 0.0                                  # a flat axis: every box in layer 0
    return origin, cell, ncell


@kernel
def _entries(lo, hi, alive, gridded, kind, size, low, high, rules, L):
    """The grid of cells `size` over the boxes' span low..high (3,), its entries (cell key,
    row << _KIND_BITS | kind) grouped by cell: (keys, bodies, single (n,) whether a body's box
    lies in one cell, origin (3,), inverse cell (3,), ncell (3,) cells around a period or 0,
    entries, the sort's mask of low bits, _lead_cells's cells)."""
    n = lo.shape[0]
    origin, cell, ncell = _layout(size, low, high, rules, L)
    # followers (FOLLOWS) only go into the cells the others cover: the 5e4 debris of a fleet
    # battle then cost a look-up each instead of an entry made, sorted and scanned
    lead = _lead_cells(lo, hi, alive, gridded, origin, cell, ncell)
    # the entries (cell, body) in body order, in one pass into the scratch kept from step to
    # step (fresh arrays cost 3 ms of page faults a step at 1e5 bodies): room for 4 a body,
    # grown to what the first pass found when the boxes cover more (a dense field of mixed
    # sizes: 4.1 a body), and kept at that size for the steps to come
    spare = rules.grid.reshape(rules.grid.size)
    room = spare.size // 4
    single = np.empty(n, np.bool_)
    total = _fill(lo, hi, alive, gridded, kind, origin, cell, ncell, spare[:room],
                  spare[room:2 * room], single, lead)
    if total > room:
        rules.grid = np.empty(((total + total // 4) // 4 + 1, 16), np.int64)
        spare = rules.grid.reshape(rules.grid.size)
        room = spare.size // 4
        _fill(lo, hi, alive, gridded, kind, origin, cell, ncell, spare[:room],
              spare[room:2 * room], single, lead)
    # grouped by as many low bits of the hashes as keep other cells out of most runs (a run
    # mixing two cells costs a skipped comparison; a pass of the sort costs a quarter of it)
    bits = 16 if total < 1 << 11 else (24 if total < 1 << 21 else 32)
    keys, bodies = _radix_sort(spare[:total], spare[room:room + total],
                               spare[2 * room:2 * room + total],
                               spare[3 * room:3 * room + total], bits)
    return keys, bodies, single, origin, cell, ncell, total, (1 << bits) - 1, lead


@kernel
def _fill(lo, hi, alive, gridded, kind, origin, cell, ncell, keys, bodies, single, lead):
    """Write the grid's entries (see _entries) into keys, bodies while they fit, and single;
    returns how many there are. lead : _lead_cells's cells (a follower's entries only in
    them). (Hot loops here and below write into arrays they are given and never
    replace one: an array assigned anew inside a loop made the loop 3x slower.)"""
    first = np.empty(3, np.int64)
    last = np.empty(3, np.int64)
    total = 0
    following = _follows(lead)
    lead_set, lead_map, lead_low = lead
    for i in range(lo.shape[0]):
        if not alive[i] or not gridded[i]:
            continue
        # (written out, not a helper returning a tuple: that costs twice the whole loop)
        count = 1
        for c in range(3):                             # the cells box i covers on axis c
            first[c] = int(math.floor((lo[i, c] - origin[c]) * cell[c]))
            last[c] = int(math.floor((hi[i, c] - origin[c]) * cell[c]))
            if ncell[c] > 0 and last[c] - first[c] >= ncell[c]:
                last[c] = first[c] + ncell[c] - 1
            count *= last[c] - first[c] + 1
        single[i] = count == 1
        follower = following and gridded[i] == FOLLOWS
        if not follower and total + count > keys.size:
            total += count
            continue
        for x in range(first[0], last[0] + 1):
            for y in range(first[1], last[1] + 1):
                for z in range(first[2], last[2] + 1):
                    if follower:                       # (_led written out: as a
                        if lead_map.shape[0] > 0:      # helper it took 3x the loop)
                            a = x - lead_low[0]
                            b = y - lead_low[1]
                            d = z - lead_low[2]
                            if a < 0 or b < 0 or d < 0 or a >= lead_map.shape[0] or \
                                    b >= lead_map.shape[1] or d >= lead_map.shape[2] or \
                                    not lead_map[a, b, d]:
                                continue
                        elif not _in_set(lead_set, _cell_key(_wrap_index(x, ncell[0]),
                                                             _wrap_index(y, ncell[1]),
                                                             _wrap_index(z, ncell[2]))):
                            continue
                    key = _cell_key(_wrap_index(x, ncell[0]), _wrap_index(y, ncell[1]),
                                    _wrap_index(z, ncell[2]))
                    if total < keys.size:
                        keys[total] = key
                        bodies[total] = (i << _KIND_BITS) | kind[i]
                    total += 1
    return total


@kernel
def _lead_cells(lo, hi, alive, gridded, origin, cell, ncell):
    """The cells the boxes of the grid's bodies not marked FOLLOWS cover: (set, map, low),
    as _cell_map's dense map where it serves (set empty), otherwise as an open-addressed set
    of their keys ((T, 2) int64: key, 1 where taken, -1 where free; T a power of 2, at least
    twice the entries; map empty); all empty when no live body follows (everyone is entered
    everywhere), or when a box covers more cells than _cell_range allows. _led reads it."""
    n = lo.shape[0]
    first = np.empty(3, np.int64)
    last = np.empty(3, np.int64)
    nothing = (np.empty((0, 2), np.int64), np.zeros((0, 0, 0), np.bool_), first)
    follows = False
    for i in range(n):
        if alive[i] and gridded[i] == FOLLOWS:
            follows = True
            break
    if not follows:
        return nothing
    leaders = _entered(alive, gridded)
    # the map: a byte read where the set took a hash and a probe (5e4 debris following
    # 2e3 ships and missiles: _fill 1.55 -> 0.86 ms)
    occupied, low = _cell_map(leaders, lo, hi, origin, cell, ncell, max(4096.0, 4.0 * n))
    if occupied.shape[0] > 0:
        return np.empty((0, 2), np.int64), occupied, low
    count = 0
    for e in range(leaders.size):
        if not _cell_range(leaders[e], lo, hi, origin, cell, ncell, first, last):
            return nothing
        count += (last[0] - first[0] + 1) * (last[1] - first[1] + 1) * \
            (last[2] - first[2] + 1)
    size = 16
    while size < 2 * count:
        size *= 2
    lead = np.full((size, 2), -1, np.int64)
    for e in range(leaders.size):
        _cell_range(leaders[e], lo, hi, origin, cell, ncell, first, last)
        for x in range(first[0], last[0] + 1):
            for y in range(first[1], last[1] + 1):
                for z in range(first[2], last[2] + 1):
                    key = _cell_key(_wrap_index(x, ncell[0]), _wrap_index(y, ncell[1]),
                                    _wrap_index(z, ncell[2]))
                    h = _slot(lead, key)
                    lead[h, 0] = key
                    lead[h, 1] = 1
    return lead, occupied, low


@kernel
def _entered(alive, gridded):
    """The rows of the live bodies entered in every cell their box covers (gridded 1)."""
    count = 0
    for i in range(alive.size):
        count += 1 if alive[i] and gridded[i] == 1 else 0
    rows = np.empty(count, np.int64)
    k = 0
    for i in range(alive.size):
        if alive[i] and gridded[i] == 1:
            rows[k] = i
            k += 1
    return rows


@kernel(inline=True)
def _follows(lead):
    """Whether _lead_cells found bodies that follow (entered only in the cells it holds)."""
    return lead[0].shape[0] > 0 or lead[1].shape[0] > 0


@kernel(inline=True)
def _led(table, occupied, low, x, y, z, ncell):
    """Whether _lead_cells's cells (its set, map and low cell) hold cell (x, y, z) (ncell:
    the grid's, for the set's key). _fill writes this out: in its loop over 6e4 bodies the
    helper took 3x as long as the same test written there."""
    if occupied.shape[0] > 0:
        a, b, c = x - low[0], y - low[1], z - low[2]
        return 0 <= a < occupied.shape[0] and 0 <= b < occupied.shape[1] and \
            0 <= c < occupied.shape[2] and occupied[a, b, c]
    return _in_set(table, _cell_key(_wrap_index(x, ncell[0]), _wrap_index(y, ncell[1]),
                                    _wrap_index(z, ncell[2])))


@kernel(inline=True)
def _slot(table, key):
    """The slot of key in an open-addressed table ((T, 2) int64 rows of key, value; value -1
    where free; T a power of 2; _lead_cells's set, _key_table's table): where key is, or
    the free slot where it would go."""
    mask = table.shape[0] - 1
    h = key & mask
    while table[h, 1] >= 0 and table[h, 0] != key:
        h = (h + 1) & mask
    return h


@kernel(inline=True)
def _in_set(lead, key):
    """Whether an open-addressed set (_slot's) holds key."""
    return lead[_slot(lead, key), 1] >= 0


@kernel(inline=True)
def _run_end(keys, run, total, low_bits):
    """The end of the run of entries from `run` whose keys share the low bits the sort
    grouped by (one cell's, now and then with another cell hashed alike)."""
    end = run + 1
    while end < total and (keys[end] & low_bits) == (keys[run] & low_bits):
        end += 1
    return end


@kernel
def _crowding(keys, bodies, total, low_bits, response):
    """(pairs, met): the pairs of entries sharing a run of the grid (what the pair scan
    reads), and those of them whose kinds meet (what it tests box against box)."""
    kinds = response.shape[0]
    count = np.zeros(kinds, np.int64)
    pairs = 0
    met = 0
    run = 0
    while run < total:
        end = _run_end(keys, run, total, low_bits)
        if end - run > 1:
            pairs += (end - run) * (end - run - 1) // 2
            for e in range(run, end):
                count[bodies[e] & _KIND_MASK] += 1
            for a in range(kinds):
                if count[a] == 0:
                    continue
                if response[a, a] != IGNORE:
                    met += count[a] * (count[a] - 1) // 2
                for b in range(a + 1, kinds):
                    if response[a, b] != IGNORE:
                        met += count[a] * count[b]
            for e in range(run, end):
                count[bodies[e] & _KIND_MASK] = 0
        run = end
    return pairs, met


@kernel
def _cells_covered(lo, hi, alive, gridded, size, dim):
    """About how many cells of `size` the boxes of the grid's bodies cover (1 + width / size
    along each axis, on average over where the cells fall)."""
    total = 0.0
    for i in range(lo.shape[0]):
        if alive[i] and gridded[i]:
            covered = 1.0
            for c in range(dim):
                covered *= 1.0 + (hi[i, c] - lo[i, c]) / size
            total += covered
    return total


@kernel
def _scan(keys, bodies, total, low_bits, single, wraps, lo, hi, L, origin, cell, ncell,
          category, mask, owner, response, pairs):
    """The pairs (i < j) of each cell of the grid (see _grid_pairs) written into pairs while
    they fit; returns how many there are."""
    # pairs within each run of one cell, reported in the cell that holds the low corner of
    # their boxes' overlap (so once, whatever other cells they share). Written out, with the
    # tables' arrays read once: as helpers (the home cell, the response) it took 3x as long
    first = np.empty(3, np.int64)
    m = 0
    run = 0
    while run < total:
        end = _run_end(keys, run, total, low_bits)
        for eu in range(run, end):
            for ew in range(eu + 1, end):
                if keys[eu] != keys[ew]:
                    continue                           # another cell with the same low bits
                i = min(bodies[eu], bodies[ew]) >> _KIND_BITS
                j = max(bodies[eu], bodies[ew]) >> _KIND_BITS
                if i == j or response[bodies[eu] & _KIND_MASK, bodies[ew] & _KIND_MASK] == \
                        IGNORE:
                    continue                           # (debris among debris: many, in heaps)
                home = True
                if single[i] and single[j] and not wraps:
                    # two boxes of one cell each: this cell is the only one they share
                    for c in range(3):
                        if lo[i, c] > hi[j, c] or lo[j, c] > hi[i, c]:
                            home = False
                else:                                  # the home cell: the overlap's low corner
                    for c in range(3):
                        shift = 0.0
                        if L[c] > 0.0:                 # to j's image nearest i
                            shift = _image_shift(lo, hi, i, j, c, L)
                        if max(lo[i, c], lo[j, c] - shift) > min(hi[i, c], hi[j, c] - shift):
                            home = False               # the boxes do not even overlap
                            break
                        # the cell of the low corner, from the unshifted edge it came from:
                        # the same arithmetic as that body's entries (a shift by a period
                        # would round differently and could miss the cell at a boundary)
                        edge = lo[i, c] if lo[i, c] >= lo[j, c] - shift else lo[j, c]
                        first[c] = _wrap_index(int(math.floor((edge - origin[c]) * cell[c])),
                                               ncell[c])
                    home = home and _cell_key(first[0], first[1], first[2]) == keys[eu]
                # the rest of _allowed last: most pairs sharing a cell fail the box test
                if not home or (category[i] & mask[j]) == 0 or (category[j] & mask[i]) == 0 \
                        or owner[i] == j or owner[j] == i:
                    continue
                if m < pairs.shape[0]:
                    pairs[m, 0] = i
                    pairs[m, 1] = j
                m += 1
        run = end
    return m


@kernel
def _grid_pairs(A, B, tb, alive, rules, lo, hi):
    """candidate_pairs, and the grid it built: (keys (E,), bodies (E,): the entries (cell
    key, row << _KIND_BITS | its kind) grouped by cell, origin (3,), inverse cell (3,),
    ncell (3,), the sort's mask of low bits, the cells followers were entered in
    (_lead_cells's)))."""
    radius, kind = rules.radius, rules.kind
    n = A.shape[0]
    L = _periods(rules)
    _bounds(A, B, tb, radius, alive, lo, hi, rules.giants[:0])
    gridded = rules.gridded
    # A cell too small for the boxes (radii near 0, a long sweep) would make one box cover
    # millions of cells, or cell indices overflow: at most 1024 cells along the widest box,
    # about 4096 in its whole volume (a diagonal sweep would otherwise fill 1024^3), and 2^40
    # across the span of all of them, counted from their low corner when the coordinates
    # are that far from the origin
    size = rules.cell
    low, high = np.full(3, np.inf), np.full(3, -np.inf)
    biggest = 0.0
    members = 0
    spread = 0.0
    for i in range(n):
        if alive[i] and gridded[i]:
            members += 1
            volume = 1.0
            widest = 0.0
            for c in range(rules.dim):
                low[c] = min(low[c], lo[i, c])
                high[c] = max(high[c], hi[i, c])
                size = max(size, (hi[i, c] - lo[i, c]) * (1.0 / 1024.0))
                volume *= hi[i, c] - lo[i, c]
                widest = max(widest, hi[i, c] - lo[i, c])
            biggest = max(biggest, volume)
            spread += widest
    # (the root of the largest volume: the largest root, without a root per body)
    size = max(size, (biggest * (1.0 / 4096.0)) ** (1.0 / rules.dim))
    # and no smaller than the mean box: small bodies swept many radii in a step (debris
    # thrown from a missile) would otherwise each cover a hundred cells of their diameter
    if members > 0:
        size = max(size, spread / members)
    # A sparse scene (debris strewn over a battlefield) first tries cells about as large as
    # its span's share per body: about one entry per body, not one per cell its box covers.
    # A crowd in some of them (a cluster far from the rest) brings back the fine cells when
    # the pairs it makes would cost more than the entries the fine cells would add (costs
    # measured on the benchmarks' scenes: an entry made, sorted and scanned ~25 ns, a pair
    # of kinds that never meet passed over ~1.5 ns, one tested box against box ~8 ns)
    coarse = size
    if members > 1:
        share = 1.0
        for c in range(rules.dim):
            share *= max(high[c] - low[c], size)
        coarse = max(size, _SPARSE * (share / members) ** (1.0 / rules.dim))
    keys, bodies, single, origin, cell, ncell, total, low_bits, lead = _entries(
        lo, hi, alive, gridded, kind, coarse, low, high, rules, L)
    if coarse > size:
        crowd, met = _crowding(keys, bodies, total, low_bits, rules.response)
        fine = _cells_covered(lo, hi, alive, gridded, size, rules.dim)
        if 1.5 * crowd + 8.0 * met > 25.0 * (fine - total):
            keys, bodies, single, origin, cell, ncell, total, low_bits, lead = _entries(
                lo, hi, alive, gridded, kind, size, low, high, rules, L)
    wraps = L[0] > 0.0 or L[1] > 0.0 or L[2] > 0.0
    # the pairs within each cell (written into pairs while they fit: a second scan into
    # an array the size the first found)
    pairs = np.empty((max(16, total // 4), 2), np.int64)
    m = _scan(keys, bodies, total, low_bits, single, wraps, lo, hi, L, origin, cell, ncell,
              rules.category, rules.mask, rules.owner, rules.response, pairs)
    if m > pairs.shape[0]:
        pairs = np.empty((m, 2), np.int64)
        _scan(keys, bodies, total, low_bits, single, wraps, lo, hi, L, origin, cell, ncell,
              rules.category, rules.mask, rules.owner, rules.response, pairs)
    # the giants against everyone: the grid's bodies looked up in the cells a giant's box
    # covers (a test of every body took 16 ms for 70 giants among 6e4 bodies), a pair of
    # giants once, from the lower row, each giant's partners in row order; then the bodies
    # outside the grid (they meet giants only) and the followers that meet a giant (loose)
    # looked up in a grid of the giants
    grid = (keys, bodies, origin, cell, ncell, low_bits, lead)
    giants = rules.giants
    # followers are not looked up by giants (the grid holds them only where others are):
    # those of a kind a giant meets look the giants up themselves, as loose bodies do
    follower = np.zeros(n, np.bool_)
    if _follows(lead) and giants.size > 0:
        for j in range(n):
            follower[j] = gridded[j] == FOLLOWS
    near = np.empty(n, np.int64)                       # a body's partners, each once
    work = np.empty((3, 3), np.int64)
    nothing = np.empty((0, 2), np.int64)               # (no key table: binary searches)
    entered = np.empty(0, np.int64)                    # the grid's bodies, if needed
    listed = False
    for q in range(giants.size):
        g = giants[q]
        if not alive[g]:
            continue
        # (strict=False and followers skipped: those of a kind a giant meets look the
        # giants up themselves, below)
        count = _grid_meets(g, grid, nothing, lo, hi, L, alive, follower, near, work, False)
        if count < 0:                                  # a giant over too many cells: all
            # (the grid's bodies but followers, not all: 64 planets over 5e4 debris that
            # meet only them, and so no grid, took 3.5 ms a step)
            if not listed:
                entered = _entered(alive, gridded)
                listed = True
            count = 0
            for e in range(entered.size):
                j = entered[e]
                if j != g and _boxes_meet(lo, hi, g, j, L):
                    near[count] = j
                    count += 1
        for p in range(q + 1, giants.size):
            j = giants[p]
            if alive[j] and _boxes_meet(lo, hi, g, j, L):
                near[count] = j
                count += 1
        sort_in_place(near, count)
        m, pairs = _append(g, near, count, rules, kind, pairs, m)
    reach = np.zeros(rules.response.shape[0], np.bool_)    # kinds a live giant meets
    for q in range(giants.size):
        if alive[giants[q]]:
            for k in range(reach.size):
                reach[k] = reach[k] or rules.response[k, kind[giants[q]]] != IGNORE or \
                    rules.response[kind[giants[q]], k] != IGNORE
    loose = np.zeros(n, np.bool_)                      # live bodies outside the grid or
    for j in range(n):                                 # following in it, that may meet a
        loose[j] = alive[j] and gridded[j] != 1 and reach[kind[j]]     # giant...
    for q in range(giants.size):                       # ...and are no giants
        loose[giants[q]] = False
    if giants.size == 0 or not loose.any():
        return pairs[:m], grid                         # (a duel's star and ships: no grid)
    m, pairs = _loose_pairs(loose, giants, alive, lo, hi, rules, L, near, work, pairs, m)
    return pairs[:m], grid


@kernel
def _append(i, near, count, rules, kind, pairs, m):
    """Pairs (i, near[p]) of p < count (low row first) whose response is not IGNORE added
    to pairs[:m]: (m, pairs), pairs grown when full."""
    if m + count > pairs.shape[0]:
        more = np.empty((2 * (m + count), 2), np.int64)
        for q in range(m):
            more[q, 0] = pairs[q, 0]
            more[q, 1] = pairs[q, 1]
        pairs = more
    for p in range(count):
        a, b = min(i, near[p]), max(i, near[p])
        if _allowed(rules, kind, a, b) != IGNORE:
            pairs[m, 0] = a
            pairs[m, 1] = b
            m += 1
    return m, pairs


@kernel
def _loose_pairs(loose, giants, alive, lo, hi, rules, L, near, work, pairs, m):
    """The pairs of the loose bodies (loose (n,) bool: outside the grid, or following in
    it, and of a kind a giant meets) with the giants their boxes meet, each body looked up in
    a grid of the giants, added to pairs[:m]: (m, pairs). near (n,) int64, work (3, 3)
    int64: scratch."""
    n = lo.shape[0]
    grid = _giants_grid(giants, alive, lo, hi, rules, L)
    table = _key_table(grid[0])
    # most loose bodies (5e4 debris after the ships of a battle are gone) are nowhere near
    # a giant: their cells looked up in a dense map of the giants' cells first (written out
    # here: a helper called per body cost 34 ns; the hashed look-up of each took 80)
    occupied, low = _cell_map(giants[alive[giants]], lo, hi, grid[2], grid[3], grid[4],
                              max(4096.0, 4.0 * n))
    origin, cell = grid[2], grid[3]
    dense = occupied.size > 0
    first, last = work[0], work[1]
    none = np.zeros(n, np.bool_)
    for j in range(n):
        if not loose[j]:
            continue
        if dense:
            far = False                                # no cell of j's holds a giant
            cells = 1
            for c in range(3):
                # in floats until clipped to the map: a box far out would overflow an int
                # (np.floor: math.floor gives an int64, garbage for NaN or past 2^63)
                f0 = np.floor((lo[j, c] - origin[c]) * cell[c]) - low[c]
                f1 = np.floor((hi[j, c] - origin[c]) * cell[c]) - low[c]
                if not (f0 == f0 and f1 == f1):
                    cells = 1 << 20                    # NaN: the look-up decides
                    break
                if f1 < 0.0 or f0 >= occupied.shape[c]:
                    far = True
                    break
                first[c] = int(max(f0, 0.0))
                last[c] = int(min(f1, occupied.shape[c] - 1.0))
                cells *= last[c] - first[c] + 1
            if not far and cells <= 64:                # (a long box: the look-up)
                far = True
                for x in range(first[0], last[0] + 1):
                    for y in range(first[1], last[1] + 1):
                        for z in range(first[2], last[2] + 1):
                            far = far and not occupied[x, y, z]
            if far:
                continue
        count = _grid_meets(j, grid, table, lo, hi, L, alive, none, near, work, False)
        if count < 0:                                  # a box over too many cells: all
            count = 0
            for p in range(giants.size):
                if alive[giants[p]] and _boxes_meet(lo, hi, min(j, giants[p]),
                                                     max(j, giants[p]), L):
                    near[count] = giants[p]
                    count += 1
        if count:
            m, pairs = _append(j, near, count, rules, rules.kind, pairs, m)
    return m, pairs


@kernel
def _giants_grid(giants, alive, lo, hi, rules, L):
    """A grid of the live giants' boxes, cells the widest of them (so 2^dim entries each at
    most), in _grid_pairs's form (the keys wholly sorted)."""
    size = 0.0
    low, high = np.full(3, np.inf), np.full(3, -np.inf)
    for q in range(giants.size):
        g = giants[q]
        if alive[g]:
            for c in range(rules.dim):
                size = max(size, hi[g, c] - lo[g, c])
                low[c] = min(low[c], lo[g, c])
                high[c] = max(high[c], hi[g, c])
    origin, cell, ncell = _layout(max(size, 1e-300), low, high, rules, L)
    keys = np.empty(0, np.int64)
    bodies = np.empty(0, np.int64)
    f = np.empty(3, np.int64)
    t = np.empty(3, np.int64)
    for sweep in range(2):                             # count, then write
        total = 0
        for q in range(giants.size):
            g = giants[q]
            if not alive[g]:
                continue
            _cell_range(g, lo, hi, origin, cell, ncell, f, t)   # (2 a side at most)
            for x in range(f[0], t[0] + 1):
                for y in range(f[1], t[1] + 1):
                    for z in range(f[2], t[2] + 1):
                        if sweep == 1:
                            keys[total] = _cell_key(_wrap_index(x, ncell[0]),
                                                    _wrap_index(y, ncell[1]),
                                                    _wrap_index(z, ncell[2]))
                            bodies[total] = g << _KIND_BITS
                        total += 1
        if sweep == 0:
            keys = np.empty(total, np.int64)
            bodies = np.empty(total, np.int64)
    order = stable_order(keys, keys.size)
    sorted_keys = np.empty(total, np.int64)
    sorted_bodies = np.empty(total, np.int64)
    for q in range(total):
        sorted_keys[q] = keys[order[q]]
        sorted_bodies[q] = bodies[order[q]]
    return (sorted_keys, sorted_bodies, origin, cell, ncell, np.int64(-1),
            (np.empty((0, 2), np.int64), np.zeros((0, 0, 0), np.bool_), np.zeros(3, np.int64)))


@kernel
def _cell_map(rows, lo, hi, origin, cell, ncell, limit):
    """The cells of a grid (origin, inverse cell, ncell (3,)) the boxes of `rows` cover,
    densely: (occupied (X, Y, Z) bool over the box of those cells, its low cell (3,)); an
    empty map when a period wraps, when a box covers more cells than _cell_range allows, or
    when the box holds more than `limit` cells. No rows: one free cell."""
    first, last = np.empty(3, np.int64), np.empty(3, np.int64)
    low = np.full(3, np.iinfo(np.int64).max)
    high = np.full(3, np.iinfo(np.int64).min)
    if ncell[0] > 0 or ncell[1] > 0 or ncell[2] > 0:
        return np.zeros((0, 0, 0), np.bool_), low
    if rows.size == 0:
        return np.zeros((1, 1, 1), np.bool_), np.zeros(3, np.int64)
    for e in range(rows.size):                         # the box of the cells...
        if not _cell_range(rows[e], lo, hi, origin, cell, ncell, first, last):
            return np.zeros((0, 0, 0), np.bool_), low
        for c in range(3):
            low[c] = min(low[c], first[c])
            high[c] = max(high[c], last[c])
    if (high[0] - low[0] + 1.0) * (high[1] - low[1] + 1.0) * (high[2] - low[2] + 1.0) > limit:
        return np.zeros((0, 0, 0), np.bool_), low
    occupied = np.zeros((high[0] - low[0] + 1, high[1] - low[1] + 1, high[2] - low[2] + 1),
                        np.bool_)
    for e in range(rows.size):                         # ...then the cells
        _cell_range(rows[e], lo, hi, origin, cell, ncell, first, last)
        occupied[first[0] - low[0]:last[0] - low[0] + 1,
                 first[1] - low[1]:last[1] - low[1] + 1,
                 first[2] - low[2]:last[2] - low[2] + 1] = True
    return occupied, low


@kernel
def _key_table(keys):
    """An open-addressed table of the distinct sorted keys (a few hundred): (T, 2) int64 of
    (key, index of its first entry), free slots -1 in the index; T a power of 2, >= 4x."""
    size = 16
    while size < 4 * keys.size:
        size *= 2
    table = np.full((size, 2), -1, np.int64)
    for e in range(keys.size):
        if e > 0 and keys[e] == keys[e - 1]:
            continue
        h = _slot(table, keys[e])
        table[h, 0] = keys[e]
        table[h, 1] = e
    return table


@kernel(inline=True)
def _image_shift(lo, hi, i, j, c, L):
    """How far j's box moves along axis c to its image nearest i's box (0 unless periodic)."""
    if L[c] <= 0.0:
        return 0.0
    ci = 0.5 * (lo[i, c] + hi[i, c])
    cj = 0.5 * (lo[j, c] + hi[j, c])
    return (cj - ci) - _wrap(cj - ci, L[c])


@kernel(lean=True)
def _boxes_meet(lo, hi, i, j, L):
    """Whether the boxes of i and j overlap (j's nearest image when wrapping)."""
    for c in range(3):
        shift = _image_shift(lo, hi, i, j, c, L)
        if max(lo[i, c], lo[j, c] - shift) > min(hi[i, c], hi[j, c] - shift):
            return False
    return True


@kernel
def focused_pairs(A, B, tb, alive, rules, lo, hi, focus, in_focus, stale, changed, grid,
                  is_giant):
    """Pairs with at least one body of `focus` (whose lines changed in the last pass) and
    overlapping boxes, as (pairs, True); (empty, False) when a new grid is cheaper.
    grid : _grid_pairs's, of the boxes when it was built; stale (n,) and changed (rows):
    the bodies whose lines changed since (their entries there are out of date: they are
    tested directly). A focus body that is no giant looks up the grid's cells its box
    covers (a pair reported in the cell of the low corner of the boxes' overlap, so once),
    the changed bodies and the giants; a giant tests every body. The pairs come in the
    order of (focus row, partner row): as a search of every partner in row order."""
    n = A.shape[0]
    _bounds(A, B, tb, rules.radius, alive, lo, hi, focus)
    if focus.size * changed.size > 4 * n + 4096:
        return np.empty((0, 2), np.int64), False
    near = np.empty(n, np.int64)
    found = np.empty(4 * focus.size + 64, np.int64)    # i * n + j: sorted at the end
    m = _focused(alive, rules, lo, hi, focus, in_focus, stale, changed, grid, is_giant, found,
                 near)
    if m > found.size:
        found = np.empty(m, np.int64)
        _focused(alive, rules, lo, hi, focus, in_focus, stale, changed, grid, is_giant, found,
                 near)
    if m < 0:                                          # a box swept far: a new grid
        return np.empty((0, 2), np.int64), False
    sort_in_place(found, m)
    pairs = np.empty((m, 2), np.int64)
    for q in range(m):
        i, j = found[q] // n, found[q] % n
        pairs[q, 0] = min(i, j)
        pairs[q, 1] = max(i, j)
    return pairs, True


@kernel
def _focused(alive, rules, lo, hi, focus, in_focus, stale, changed, grid, is_giant, found,
             near):
    """focused_pairs's search: the pairs as i * n + j written into found while they fit;
    returns how many there are, or -1 when a focus body's box covers too many cells."""
    kind = rules.kind
    category, mask, owner, response = rules.category, rules.mask, rules.owner, rules.response
    gridded = rules.gridded
    n = lo.shape[0]
    L = _periods(rules)
    wraps = L[0] > 0.0 or L[1] > 0.0 or L[2] > 0.0
    giants = rules.giants
    work = np.empty((3, 3), np.int64)
    nothing = np.empty((0, 2), np.int64)               # (no key table: binary searches)
    m = 0
    for q in range(focus.size):
        i = focus[q]
        if not alive[i]:
            continue
        if is_giant[i]:
            x0, x1 = lo[i, 0], hi[i, 0]
            for j in range(n):
                # the cheap test first: most bodies are far along x
                if not wraps and (hi[j, 0] < x0 or lo[j, 0] > x1):
                    continue
                if j != i and alive[j] and not (in_focus[j] and j < i) and \
                        _boxes_meet(lo, hi, min(i, j), max(i, j), L) and \
                        _allowed(rules, kind, min(i, j), max(i, j)) != IGNORE:
                    if m < found.size:
                        found[m] = i * n + j
                    m += 1
            continue
        if gridded[i]:
            count = _grid_meets(i, grid, nothing, lo, hi, L, alive, stale, near, work,
                                gridded[i] == 1)
            if count < 0:
                return -1
            for p in range(count):
                j = near[p]
                a2, b2 = min(i, j), max(i, j)
                if (category[a2] & mask[b2]) == 0 or (category[b2] & mask[a2]) == 0 or \
                        owner[a2] == b2 or owner[b2] == a2 or \
                        response[kind[a2], kind[b2]] == IGNORE:
                    continue
                if m < found.size:
                    found[m] = i * n + j
                m += 1
            for p in range(changed.size):          # the bodies whose entries are stale
                j = changed[p]
                if j == i or not alive[j] or is_giant[j] or not gridded[j] or \
                        (in_focus[j] and j < i):
                    continue
                a2, b2 = min(i, j), max(i, j)
                if _boxes_meet(lo, hi, a2, b2, L) and _allowed(rules, kind, a2, b2) != IGNORE:
                    if m < found.size:
                        found[m] = i * n + j
                    m += 1
        for p in range(giants.size):
            g = giants[p]
            if not alive[g] or (in_focus[g] and g < i):
                continue                               # (a giant in focus below: its pair)
            a2, b2 = min(i, g), max(i, g)
            if _boxes_meet(lo, hi, a2, b2, L) and _allowed(rules, kind, a2, b2) != IGNORE:
                if m < found.size:
                    found[m] = i * n + g
                m += 1
    return m


@kernel(inline=True)
def _cell_range(i, lo, hi, origin, cell, ncell, first, last):
    """The cells of i's box into first, last (3,); False when it covers more than 4096 or
    lies past any cell number an int64 holds (a box far out or swept far: a line a contact
    changed after the grid was sized), in floats first."""
    count = 1.0
    for c in range(3):
        f0 = np.floor((lo[i, c] - origin[c]) * cell[c])    # (a float: NaN fails below;
        f1 = np.floor((hi[i, c] - origin[c]) * cell[c])    # math.floor's int64 would not)
        if not (abs(f0) < 2.0 ** 52 and abs(f1) < 2.0 ** 52):
            return False
        first[c] = int(f0)
        last[c] = int(f1)
        if ncell[c] > 0 and last[c] - first[c] >= ncell[c]:
            last[c] = first[c] + ncell[c] - 1
        count *= last[c] - first[c] + 1
    return count <= 4096.0


@kernel(inline=True)
def _meets_here(i, j, key, lo, hi, L, origin, cell, ncell, corner):
    """Whether the boxes of i and j (j's image nearest i) meet, with the low corner of their
    overlap in the cell of `key` (so a pair sharing several cells is reported once)."""
    for c in range(3):
        shift = _image_shift(lo, hi, i, j, c, L)
        if max(lo[i, c], lo[j, c] - shift) > min(hi[i, c], hi[j, c] - shift):
            return False
        edge = lo[i, c] if lo[i, c] >= lo[j, c] - shift else lo[j, c]
        corner[c] = _wrap_index(int(math.floor((edge - origin[c]) * cell[c])), ncell[c])
    return _cell_key(corner[0], corner[1], corner[2]) == key


@kernel(lean=True)
def _grid_meets(i, grid, table, lo, hi, L, alive, skip, near, work, strict):
    """The live bodies of the grid whose boxes meet body i's box (j's image nearest i when
    wrapping), each once (found in the cell of the low corner of the two boxes' overlap),
    skip[j] left out, written into near (n,) in the grid's order: returns how many, or -1
    when i's box covers more than 4096 cells (search otherwise), or, strict, a cell where
    the grid left its followers out (i may meet them: a new grid). i itself need not be in
    the grid. table : the grid's _key_table (a small grid's: the giants'), or empty (a
    binary search finds a cell). work : (3, 3) int64 scratch (three small arrays a call
    cost more than the look-up of a body that meets nothing)."""
    keys, bodies, origin, cell, ncell, low_bits, lead = grid
    following = _follows(lead)
    lead_set, lead_map, lead_low = lead
    first, last, corner = work[0], work[1], work[2]
    if not _cell_range(i, lo, hi, origin, cell, ncell, first, last):
        return -1
    m = 0
    for x in range(first[0], last[0] + 1):
        for y in range(first[1], last[1] + 1):
            for z in range(first[2], last[2] + 1):
                if strict and following and not _led(lead_set, lead_map, lead_low, x, y, z, ncell):
                    return -1
                key = _cell_key(_wrap_index(x, ncell[0]), _wrap_index(y, ncell[1]),
                                _wrap_index(z, ncell[2]))
                if table.shape[0]:                     # the key's first entry, if any
                    h = _slot(table, key)
                    a = table[h, 1] if table[h, 1] >= 0 else keys.size
                else:                                  # the run of the key's low bits (the
                    a, b = 0, keys.size                # sort's order): binary search
                    while a < b:
                        mid = (a + b) // 2
                        if (keys[mid] & low_bits) < (key & low_bits):
                            a = mid + 1
                        else:
                            b = mid
                for e in range(a, keys.size):
                    if (keys[e] & low_bits) != (key & low_bits):
                        break
                    j = bodies[e] >> _KIND_BITS
                    if keys[e] != key or j == i or skip[j] or not alive[j]:
                        continue
                    if _meets_here(i, j, key, lo, hi, L, origin, cell, ncell, corner):
                        near[m] = j
                        m += 1
    return m


@kernel
def brute_pairs(A, B, tb, alive, rules, lo, hi):
    """Every pair (i < j) whose swept boxes overlap (minimum image when wrapping) and whose
    response is not IGNORE: the O(N^2) reference the grid is tested against."""
    radius, kind = rules.radius, rules.kind
    n = A.shape[0]
    L = _periods(rules)
    _bounds(A, B, tb, radius, alive, lo, hi, rules.giants[:0])
    pairs = np.empty((16, 2), np.int64)
    m = 0
    for i in range(n):
        if not alive[i]:
            continue
        for j in range(i + 1, n):
            if not alive[j] or _allowed(rules, kind, i, j) == IGNORE:
                continue
            if _boxes_meet(lo, hi, i, j, L):
                if m == pairs.shape[0]:
                    pairs = grown_pairs(pairs, m)
                pairs[m, 0] = i
                pairs[m, 1] = j
                m += 1
    return pairs[:m]


@kernel
def _fractions(m_i, m_j, fixed_i, fixed_j):
    """Shares of the exchanged normal velocity taken by i and j: m_j/(m_i+m_j), m_i/(m_i+m_j),
    from the mass ratio so that 1e-12 against 1e12 keeps both; immovable = infinite mass."""
    if fixed_i and fixed_j:
        return 0.0, 0.0
    if fixed_i:
        return 0.0, 1.0
    if fixed_j:
        return 1.0, 0.0
    if m_i == 0.0 and m_j == 0.0:
        return 0.5, 0.5
    if m_i >= m_j:
        q = m_j / m_i
        return q / (1.0 + q), 1.0 / (1.0 + q)
    q = m_i / m_j
    return 1.0 / (1.0 + q), q / (1.0 + q)


@kernel(lean=True)
def _velocity_at(V0, V1, D, k, t, out):
    """Body k's velocity at fraction t of the step: the integrator's, interpolated between the
    step's start and end, plus the impulses of this step's earlier contacts."""
    for c in range(3):
        out[c] = V0[k, c] + t * (V1[k, c] - V0[k, c]) + D[k, c]


@kernel
def _respond(i, j, t, resp, e, A, B, tb, V0, V1, D, mass, radius, alive, ids, rules, dt, t0,
             L, state):
    """Apply response resp to the contact of i and j at time t of the step. Returns 0 when
    nothing changed a trajectory, 1 when velocities changed, 2 when a body was removed or
    merged (the caller must refresh what depends on the set of bodies)."""
    pi = np.empty(3)
    pj = np.empty(3)
    n = np.empty(3)
    for c in range(3):
        pi[c] = A[i, c] + B[i, c] * t
        pj[c] = pi[c] + _wrap(A[j, c] + B[j, c] * t - pi[c], L[c])
        n[c] = pj[c] - pi[c]
    dist = math.sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2])
    if dist > 0.0:
        for c in range(3):
            n[c] /= dist
    else:
        # centres coincide: push along the relative motion, else along x
        rel = np.empty(3)
        for c in range(3):
            rel[c] = B[j, c] - B[i, c]
        rn = math.sqrt(rel[0] * rel[0] + rel[1] * rel[1] + rel[2] * rel[2])
        for c in range(3):
            n[c] = -rel[c] / rn if rn > 0.0 else (1.0 if c == 0 else 0.0)
    point = np.empty(3)
    for c in range(3):
        point[c] = pi[c] + n[c] * radius[i]
    ui = np.empty(3)
    uj = np.empty(3)
    _velocity_at(V0, V1, D, i, t, ui)
    _velocity_at(V0, V1, D, j, t, uj)
    closing = 0.0
    for c in range(3):
        closing += (uj[c] - ui[c]) * n[c]             # < 0 when approaching
    fixed_i = rules.fixed[i]
    fixed_j = rules.fixed[j]
    when = t0 + t * dt
    if resp == SENSOR:
        _meet(rules, i, j, t)            # its begin and end are found at the step's end
        return 0
    if resp in REFLECTING:
        if closing >= 0.0:
            return 0
        fi, fj = _fractions(mass[i], mass[j], fixed_i, fixed_j)
        if resp == ELASTIC:
            e = 1.0
        for c in range(3):
            if resp == ELASTIC and mass[i] == mass[j] and not fixed_i and not fixed_j:
                # equal masses swap their normal velocities exactly (the seed: identical balls
                # swap velocities): u_i - (u_i.n) n + (u_j.n) n, which is u_j itself head-on
                ni = ui[0] * n[0] + ui[1] * n[1] + ui[2] * n[2]
                nj = uj[0] * n[0] + uj[1] * n[1] + uj[2] * n[2]
                di = (ui[c] - ni * n[c] + nj * n[c]) - ui[c]
                dj = (uj[c] - nj * n[c] + ni * n[c]) - uj[c]
            else:
                di = (1.0 + e) * fi * closing * n[c]
                dj = -(1.0 + e) * fj * closing * n[c]
            D[i, c] += di
            D[j, c] += dj
            B[i, c] += di * dt
            B[j, c] += dj * dt
        for c in range(3):
            A[i, c] = pi[c] - B[i, c] * t
            A[j, c] = pj[c] - B[j, c] * t
        tb[i] = t
        tb[j] = t
        if fixed_i or fixed_j:
            reduced = mass[j] if fixed_i else mass[i]
        else:
            reduced = mass[i] * fj          # m_i m_j / (m_i + m_j)
        lost = 0.5 * (1.0 - e * e) * reduced * closing * closing
        record(state, EV_BOUNCE, ids[i], ids[j], when, t * dt, point, n, -closing, lost, dist)
        if resp == ELASTIC or resp == BOUNCE:
            _meet(rules, i, j, t)        # a contact may begin
            return 1
        # a break: the bounce happened (the other body keeps its rebound), then the broken
        # one is destroyed where it stood (the seed's brick)
        k = i if resp == BREAK_A else j
        p = pi if k == i else pj
        for c in range(3):
            A[k, c] = p[c]
            B[k, c] = 0.0
        alive[k] = False
        mass[k] = 0.0
        tb[k] = t                        # when it went (its pairs in touch end then)
        record(state, EV_DESTROY, ids[k], ids[j if k == i else i], when, t * dt, point,
                n, -closing, 0.0, dist)
        return 2
    if resp == MERGE:
        # the heavier (or the immovable) one survives, with the pair's mass and momentum
        s, o = i, j
        if fixed_j and not fixed_i or (fixed_i == fixed_j and mass[j] > mass[i]):
            s, o = j, i
        M = mass[s] + mass[o]
        ws = mass[s] / M if M > 0.0 else 0.5
        wo = 1.0 - ws
        ps = pi if s == i else pj
        po = pj if s == i else pi
        rel2 = 0.0
        for c in range(3):
            rel2 += (uj[c] - ui[c]) ** 2
        if rules.fixed[s]:
            ws, wo = 1.0, 0.0
        for c in range(3):
            centre = ws * ps[c] + wo * po[c]
            # momentum-weighted: every part of the velocity (start, end, impulses) alike
            V0[s, c] = ws * V0[s, c] + wo * V0[o, c]
            V1[s, c] = ws * V1[s, c] + wo * V1[o, c]
            D[s, c] = ws * D[s, c] + wo * D[o, c]
            B[s, c] = ws * B[s, c] + wo * B[o, c]
            A[s, c] = centre - B[s, c] * t
            A[o, c] = po[c] - B[o, c] * t
        tb[s] = t
        if rules.dim == 3:
            radius[s] = (radius[s] ** 3 + radius[o] ** 3) ** (1.0 / 3.0)
        else:
            radius[s] = math.sqrt(radius[s] ** 2 + radius[o] ** 2)
        # the kinetic energy of the relative motion, m_s m_o / M |u_o - u_s|^2 / 2, is lost
        lost = 0.5 * (mass[s] * mass[o] / M if M > 0.0 else 0.0) * rel2
        mass[s] = M
        mass[o] = 0.0
        alive[o] = False
        tb[o] = t
        for c in range(3):
            B[o, c] = 0.0
            A[o, c] = po[c]
        record(state, EV_MERGE, ids[s], ids[o], when, t * dt, point, n, -closing, lost,
                dist)
        return 2
    # destroy one or both: frozen where they met, no mass, out of the game
    lost = 0.0
    for which in range(2):
        k = i if which == 0 else j
        other = j if which == 0 else i
        if (which == 0 and resp in (DESTROY_A, DESTROY_BOTH)) or \
                (which == 1 and resp in (DESTROY_B, DESTROY_BOTH)):
            p = pi if k == i else pj
            u = ui if k == i else uj
            lost = 0.5 * mass[k] * (u[0] * u[0] + u[1] * u[1] + u[2] * u[2])
            for c in range(3):
                A[k, c] = p[c]
                B[k, c] = 0.0
            alive[k] = False
            mass[k] = 0.0
            tb[k] = t
            record(state, EV_DESTROY, ids[k], ids[other], when, t * dt, point, n,
                    -closing, lost, dist)
    return 2


@kernel
def _respond_wall(i, t, n0, n1, n2, e, A, B, tb, V0, V1, D, mass, radius, ids, rules, dt, t0,
                  state):
    """Reflect body i off a wall (immovable) with restitution e: v -= (1 + e) (v . n) n."""
    n = np.array([n0, n1, n2])
    u = np.empty(3)
    _velocity_at(V0, V1, D, i, t, u)
    un = u[0] * n[0] + u[1] * n[1] + u[2] * n[2]
    if un >= 0.0 or rules.fixed[i]:
        return 0
    p = np.empty(3)
    for c in range(3):
        p[c] = A[i, c] + B[i, c] * t
        d = -(1.0 + e) * un * n[c]
        D[i, c] += d
        B[i, c] += d * dt
        A[i, c] = p[c] - B[i, c] * t
    tb[i] = t
    point = np.empty(3)
    normal = np.empty(3)
    for c in range(3):
        point[c] = p[c] - radius[i] * n[c]
        normal[c] = -n[c]
    # the wall does not move: a restitution e takes (1 - e^2) of the normal kinetic energy
    lost = 0.5 * (1.0 - e * e) * mass[i] * un * un
    record(state, EV_WALL, ids[i], -1, t0 + t * dt, t * dt, point, normal, -un, lost,
            radius[i])
    return 1


@kernel
def pair_contacts(A, B, tb, pairs, L, rules):
    """Narrow phase: (times, i, j) of the candidate pairs that touch within the step."""
    radius = rules.radius
    m = pairs.shape[0]
    ct = np.empty(m)
    ci = np.empty(m, np.int64)
    cj = np.empty(m, np.int64)
    k = 0
    for q in range(m):
        i = pairs[q, 0]
        j = pairs[q, 1]
        resp = _allowed(rules, rules.kind, i, j)
        t = _pair_time(A, B, i, j, radius[i] + radius[j], max(tb[i], tb[j]), L,
                       resp in TOUCH_ENDS or resp == SENSOR)
        if t >= 0.0:
            ct[k] = t
            ci[k] = i
            cj[k] = j
            k += 1
    return ct[:k], ci[:k], cj[:k]


@kernel
def collide_step(state, rules, dt, t0):
    """Find and resolve every contact of one step, in time order.

    state : the kernels' State: pos0, vel0 hold the positions and velocities at the start of
    the step (vel0 is used as scratch: merges overwrite it); pos, vel those at its end,
    updated where a contact changed them, left bit for bit as they were elsewhere (a contact
    at fraction t of the step sees the velocity interpolated between the two); mass is
    updated by merges (bodies destroyed or merged away get mass 0 and are marked dead in
    state.alive); events are appended to its buffer. rules : Rules; dt : the step [time];
    t0 : the simulation time at its start.
    Returns 2 if a body was removed or merged, 1 if only velocities changed, 0 if nothing.
    """
    pos0, vel0, pos, vel, mass = state.pos0, state.vel0, state.pos, state.vel, state.mass
    radius, kind, alive, ids = rules.radius, rules.kind, state.alive, state.ids
    n = pos.shape[0]
    L = _periods(rules)
    A, B, D, lo, hi, tb = rules.A, rules.B, rules.D, rules.lo, rules.hi, rules.tb
    ever, touched, in_focus, is_giant = rules.ever, rules.touched, rules.in_focus, rules.is_giant
    merged_into = rules.merged
    # (a loop per array: one loop writing them all took twice as long, 0.45 against 0.23 ms
    # for 6e4 bodies)
    tb[:] = 0.0
    ever[:] = False
    touched[:] = False
    in_focus[:] = False
    is_giant[:] = False
    D[:] = 0.0
    for i in range(n):
        merged_into[i] = i
    for i in range(n):
        for c in range(3):
            A[i, c] = pos0[i, c]
            # where periodic, the start is unwrapped next to the end the integrator reached
            B[i, c] = _wrap(pos[i, c] - pos0[i, c], L[c]) if L[c] > 0.0 else pos[i, c] - pos0[i, c]
    # D: impulses of this step, per body; ever: bodies whose line a contact changed
    V0 = vel0                                          # merges mix these in place
    V1 = vel
    walls = rules.walls
    nbox = 2 * rules.dim if rules.boundary == REFLECT else 0
    box_walls = np.zeros((nbox, 8))
    for c in range(nbox // 2):
        for side in range(2):
            row = box_walls[2 * c + side]
            row[0] = PLANE
            row[1 + c] = rules.box[side, c]
            row[4 + c] = 1.0 if side == 0 else -1.0
            row[7] = rules.box_restitution
    result = 0
    # merged_into: a body merged away hands its remaining contacts of the step to its
    # survivor, so that everything that touched within the step ends up one body (merges
    # chain transitively)
    for q in range(rules.giants.size):
        is_giant[rules.giants[q]] = True
    # stale: the bodies whose lines changed since the grid was built (its entries for them
    # are out of date), listed in changed[:nc]; moved[:nm]: the bodies touched in the pass
    # (lists, not loops over every body: a pass after the first sees a few hundred)
    stale = rules.stale
    changed = np.empty(n, np.int64)
    moved = np.empty(n, np.int64)
    nc = 0
    nm = 0
    focus = moved[:0]
    rules.nfound[0] = 0
    for sweep in range(_MAX_PASSES + 1):
        last = sweep == _MAX_PASSES
        if sweep == 0:
            pairs, grid = _grid_pairs(A, B, tb, alive, rules, lo, hi)
            for i in range(n):
                stale[i] = False
        else:
            # only pairs with a body whose line changed in the last pass can be new: those
            # bodies look the others up in the grid (10^5 bodies: a new grid took 21 ms)
            for q in range(focus.size):
                in_focus[focus[q]] = False
            focus = moved[:nm].copy()
            sort_in_place(focus, nm)
            for q in range(focus.size):
                i = focus[q]
                in_focus[i] = True
                if not stale[i]:
                    stale[i] = True
                    changed[nc] = i
                    nc += 1
            pairs, ok = focused_pairs(A, B, tb, alive, rules, lo, hi, focus, in_focus,
                                      stale, changed[:nc], grid, is_giant)
            if not ok:                                 # too many changed: a new grid
                pairs, grid = _grid_pairs(A, B, tb, alive, rules, lo, hi)
                for q in range(nc):
                    stale[changed[q]] = False
                nc = 0
        pt, pi_, pj_ = pair_contacts(A, B, tb, pairs, L, rules)
        # contacts: (time, i, j) with j < 0 for walls (-1 - row; box walls after the walls);
        # after the first pass only the bodies whose lines changed can meet a wall anew
        k = pt.size
        nw = walls.shape[0] + nbox
        rows = n if sweep == 0 else focus.size
        ct = np.empty(k + rows * nw)
        ci = np.empty(ct.size, np.int64)
        cj = np.empty(ct.size, np.int64)
        cn = np.empty((ct.size, 3))
        for q in range(k):
            ct[q] = pt[q]
            ci[q] = pi_[q]
            cj[q] = pj_[q]
        for q in range(rows if nw else 0):
            i = q if sweep == 0 else focus[q]
            if not alive[i]:
                continue
            for w in range(nw):
                row = walls[w] if w < walls.shape[0] else box_walls[w - walls.shape[0]]
                t, n0, n1, n2 = _wall_time(A, B, i, radius[i], row, tb[i])
                if t >= 0.0:
                    ct[k] = t
                    ci[k] = i
                    cj[k] = -1 - w
                    cn[k, 0] = n0
                    cn[k, 1] = n1
                    cn[k, 2] = n2
                    k += 1
        if k == 0:
            break
        order = contact_order(ct, ci, cj, k)
        for q in range(nm):
            touched[moved[q]] = False
        nm = 0
        for q in range(k):
            c = order[q]
            i = _survivor(merged_into, ci[c])
            j = cj[c] if cj[c] < 0 else _survivor(merged_into, cj[c])
            if i == j or not alive[i] or (j >= 0 and not alive[j]):
                continue
            chained = j >= 0 and _allowed(rules, kind, min(i, j), max(i, j)) == MERGE
            if not chained and (touched[i] or (j >= 0 and touched[j])):
                continue
            if j >= 0 and i > j:
                i, j = j, i
            t = max(ct[c], tb[i], tb[j] if j >= 0 else 0.0)
            if last:
                t = 1.0                  # out of passes: respond at the end, no more lines
            if j < 0:
                w = -1 - j
                row = walls[w] if w < walls.shape[0] else box_walls[w - walls.shape[0]]
                r = _respond_wall(i, t, cn[c, 0], cn[c, 1], cn[c, 2], row[7], A, B, tb, V0, V1,
                                  D, mass, radius, ids, rules, dt, t0, state)
            else:
                resp = _allowed(rules, kind, i, j)
                if resp == SENSOR and sweep > 0 and _met(rules, i, j):
                    continue
                r = _respond(i, j, t, resp, rules.restitution[kind[i], kind[j]], A, B, tb,
                             V0, V1, D, mass, radius, alive, ids, rules, dt, t0, L, state)
                if resp == MERGE:
                    merged_into[i if not alive[i] else j] = j if not alive[i] else i
            if r > 0:
                for body in (i, j):
                    if body >= 0 and not touched[body]:
                        touched[body] = True
                        ever[body] = True
                        moved[nm] = body
                        nm += 1
                result = max(result, r)
        if nm == 0:
            break
    if rules.ntouch[0] or rules.nfound[0]:
        _touches(state, rules, dt, t0, L)
    wraps = L[0] > 0.0 or L[1] > 0.0 or L[2] > 0.0
    for i in range(n):
        if not (ever[i] or wraps):
            continue                                   # untouched: the integrator's state
        for c in range(3):
            x = A[i, c] + B[i, c] if ever[i] else pos[i, c]
            if L[c] > 0.0:
                x = rules.box[0, c] + (x - rules.box[0, c]) % L[c]
            pos[i, c] = x
            if ever[i]:
                vel[i, c] = V1[i, c] + D[i, c]
    return result


@kernel(lean=True)
def _survivor(merged_into, i):
    """The body i has merged into, following chains (with path halving)."""
    while merged_into[i] != i:
        merged_into[i] = merged_into[merged_into[i]]
        i = merged_into[i]
    return i


@kernel
def _meet(rules, i, j, t):
    """Note that rows i and j met at fraction t of the step (a sensor overlap, a bounce)."""
    k = rules.nfound[0]
    if k >= rules.found_t.size:
        grown = np.empty((2 * k + 16, 2), np.int64)
        grown_t = np.empty(2 * k + 16)
        for q in range(k):
            grown[q, 0] = rules.found[q, 0]
            grown[q, 1] = rules.found[q, 1]
            grown_t[q] = rules.found_t[q]
        rules.found = grown
        rules.found_t = grown_t
    rules.found[k, 0] = min(i, j)
    rules.found[k, 1] = max(i, j)
    rules.found_t[k] = t
    rules.nfound[0] = k + 1


@kernel
def _met(rules, i, j):
    """Whether rows i and j met already in this step."""
    a, b = min(i, j), max(i, j)
    for k in range(rules.nfound[0]):
        if rules.found[k, 0] == a and rules.found[k, 1] == b:
            return True
    return False


@kernel(inline=True)
def _row(index, ids, body_id):
    """The row of a body id, -1 if it names no body now."""
    slot = body_id & _SLOT_MASK
    if slot >= index.size:
        return -1
    r = index[slot]
    return r if r >= 0 and ids[r] == body_id else -1


@kernel(lean=True)
def _exit_time(A, B, tb, i, j, R, t_in, L):
    """When rows i and j, on their lines at the step's end, are last within R of each other:
    the later root of |d + e t| = R on [max(tb), 1], not before t_in (the pair's meeting)."""
    t_lo = max(tb[i], tb[j], t_in)
    d0 = _wrap(A[j, 0] + B[j, 0] * t_lo - A[i, 0] - B[i, 0] * t_lo, L[0])
    d1 = _wrap(A[j, 1] + B[j, 1] * t_lo - A[i, 1] - B[i, 1] * t_lo, L[1])
    d2 = _wrap(A[j, 2] + B[j, 2] * t_lo - A[i, 2] - B[i, 2] * t_lo, L[2])
    e0 = B[j, 0] - B[i, 0]
    e1 = B[j, 1] - B[i, 1]
    e2 = B[j, 2] - B[i, 2]
    a = e0 * e0 + e1 * e1 + e2 * e2
    b = d0 * e0 + d1 * e1 + d2 * e2
    c = d0 * d0 + d1 * d1 + d2 * d2 - R * R
    disc = b * b - a * c
    if c > 0.0 or a == 0.0 or disc < 0.0:
        return t_lo                       # apart already (their lines changed), or resting
    root = math.sqrt(disc)
    s = -c / (b + root) if b > 0.0 else (root - b) / a     # the later root, cancellation-free
    return min(t_lo + s, 1.0)


@kernel
def _touch_event(state, rules, kind, i, j, t, dt, t0, L):
    """Record a begin or end event of rows i, j at fraction t of the step, from their lines:
    the contact point on i's surface, the unit normal i -> j, the closing speed, the centre
    distance."""
    A, B = rules.A, rules.B
    pi = np.empty(3)
    n = np.empty(3)
    for c in range(3):
        pi[c] = A[i, c] + B[i, c] * t
        n[c] = _wrap(A[j, c] + B[j, c] * t - pi[c], L[c])
    dist = math.sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2])
    closing = 0.0
    for c in range(3):
        n[c] = n[c] / dist if dist > 0.0 else (1.0 if c == 0 else 0.0)
        closing -= (B[j, c] - B[i, c]) * n[c] / dt
    point = np.empty(3)
    for c in range(3):
        point[c] = pi[c] + n[c] * rules.radius[i]
    record(state, kind, state.ids[i], state.ids[j], t0 + t * dt, t * dt, point, n, closing,
           0.0, dist)


@kernel
def _touches(state, rules, dt, t0, L):
    """The step's begin and end events, and the pairs in touch at its end (rules.touch).

    A sensor pair is in touch while the bodies overlap: sensor_begin when it starts (its
    meeting in the step, or the step's start for one that overlapped without moving in),
    sensor_end when it stops (the later root of the step's last line; when a body went: then)
    -- both in one step for a body that passes through. A contact pair (elastic, bounce) is in
    touch while the gap is within CONTACT_SLOP: contact_begin at the bounce of a step that
    ends touching and would a step later, contact_end at the step that ends apart (a clean bounce
    is a bounce only). Appended after the step's other events, in time order (then by row)."""
    ids, alive, kind = state.ids, state.alive, rules.kind
    A, B, tb, radius = rules.A, rules.B, rules.tb, rules.radius
    P = rules.ntouch[0]
    F = rules.nfound[0]
    m = P + F
    ci = np.empty(m, np.int64)
    cj = np.empty(m, np.int64)
    ct = np.empty(m)
    cwas = np.zeros(m, np.int64)             # 0: met now; 1: a sensor pair in touch; 2: a contact
    keys = np.empty(m, np.int64)
    n = ids.size
    ev_kind = np.empty(2 * m, np.int64)      # the events, sorted by time before recording
    ev_i = np.empty(2 * m, np.int64)
    ev_j = np.empty(2 * m, np.int64)
    ev_t = np.empty(2 * m)
    ne = 0
    k = 0
    for p in range(P):
        i = _row(rules.index, ids, rules.touch[p, 0])
        j = _row(rules.index, ids, rules.touch[p, 1])
        if i < 0 or j < 0:
            # a body removed between steps: its pair ends at this step's start
            point = np.zeros(3)
            record(state, EV_SENSOR_END if rules.touch[p, 2] else EV_CONTACT_END,
                   rules.touch[p, 0], rules.touch[p, 1], t0, 0.0, point, point, 0.0, 0.0, 0.0)
            continue
        ci[k] = min(i, j)
        cj[k] = max(i, j)
        ct[k] = np.inf
        cwas[k] = 1 if rules.touch[p, 2] else 2
        keys[k] = ci[k] * n + cj[k]
        k += 1
    for f in range(F):
        ci[k] = rules.found[f, 0]
        cj[k] = rules.found[f, 1]
        ct[k] = rules.found_t[f]
        keys[k] = ci[k] * n + cj[k]
        k += 1
    order = stable_order(keys, k)
    nt = 0
    q = 0
    while q < k:
        # one pair: its entries side by side
        first = order[q]
        i, j = ci[first], cj[first]
        was = 0
        t_in = np.inf
        while q < k and keys[order[q]] == keys[first]:
            e = order[q]
            was = max(was, cwas[e])
            t_in = min(t_in, ct[e])
            q += 1
        resp = _allowed(rules, kind, i, j)
        sensor = was == 1 if was else resp == SENSOR
        R = radius[i] + radius[j]
        reach = R if sensor else R * (1.0 + CONTACT_SLOP)
        live = alive[i] and alive[j]
        now = False
        if live and (resp == SENSOR if sensor else (resp == ELASTIC or resp == BOUNCE)):
            d2 = 0.0
            ahead = 0.0
            for c in range(3):
                d = _wrap(A[j, c] + B[j, c] - A[i, c] - B[i, c], L[c])
                d2 += d * d
                ahead += (d + B[j, c] - B[i, c]) ** 2
            # a contact begins resting: still touching a step later on its line (not a bounce
            # at the step's very end, parting)
            now = d2 <= reach * reach and (sensor or was > 0 or ahead <= reach * reach)
        if now:
            if nt >= rules.touch.shape[0]:
                grown = np.empty((2 * nt + 16, 3), np.int64)
                for r in range(nt):
                    for c in range(3):
                        grown[r, c] = rules.touch[r, c]
                rules.touch = grown
            a, b = ids[i], ids[j]
            rules.touch[nt, 0] = min(a, b)
            rules.touch[nt, 1] = max(a, b)
            rules.touch[nt, 2] = 1 if sensor else 0
            nt += 1
        begins = not was and (now or sensor)
        if begins:
            ev_kind[ne] = EV_SENSOR_BEGIN if sensor else EV_CONTACT_BEGIN
            ev_i[ne], ev_j[ne] = i, j
            ev_t[ne] = t_in if t_in < np.inf else 0.0
            ne += 1
        if not now and (was or begins):
            if not live:
                t_out = tb[j] if not alive[j] and (alive[i] or tb[j] < tb[i]) else tb[i]
            else:
                t_out = _exit_time(A, B, tb, i, j, reach, t_in if t_in < np.inf else 0.0, L)
            ev_kind[ne] = EV_SENSOR_END if sensor else EV_CONTACT_END
            ev_i[ne], ev_j[ne] = i, j
            ev_t[ne] = t_out
            ne += 1
    rules.ntouch[0] = nt
    rules.ntouch[1] = rules.touch.shape[0]
    rank = stable_order(ev_t, ne)
    for r in range(ne):
        e = rank[r]
        _touch_event(state, rules, ev_kind[e], ev_i[e], ev_j[e], ev_t[e], dt, t0, L)
