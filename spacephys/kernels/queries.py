"""Spatial queries between steps: which bodies lie within a distance of a point, inside a box,
nearest to a point, along a ray. A uniform grid of the bodies' centres (`grid`: a counting
sort, linear in the bodies) is built by the caller and may serve many calls (World keeps one
while nothing moves, spacephys/queries.py); bodies larger than a cell ("giants") are tested
against every query directly. Each search takes `wanted`: a (n,) bool mask of the rows it may
find, or an empty array for every row of the grid.

A body is a disc (2D) or a sphere (3D) of its radius: its distance from a point is the gap
max(|p - c| - radius, 0) (0 when the point is inside it), and it overlaps a box when the box
is within its radius. With a periodic boundary every difference is taken to its nearest image
(the box's period per axis, 0 for none). Each query's hits are sorted by distance, then id.
"""
import math

import numba
import numpy as np

from .._jit import kernel
from . import libm
from . import arrays

MIN_PARALLEL = 256          # fewest queries answered on threads
MIN_PARALLEL_BODIES = 8192  # fewest bodies whose grid is filled on threads
SEEN = 128                  # a ray walk's memory of the cells it scanned (a power of 2)
SAMPLED = 64                # fewest queries whose buffers are sized from a sample
ROOM = 64                   # hits a query's buffer holds below that
_NEVER = -(1 << 62)         # no walk index
# a grid's memory when there is none to reuse (grid)
NO_MEMORY = (np.empty(0, np.int64), np.empty(0, np.int64), np.empty(0, np.int64),
             np.empty(0, np.int64), np.empty(0, np.int64), np.empty((0, 3)), np.empty(0))
# no copy of the bodies wanted from a grid (grid's bpos, bradius)
NO_BASIS = (np.empty((0, 3)), np.empty(0))


@kernel(inline=True)
def _image(d, period):
    """d taken to its nearest periodic image (period 0: none)."""
    if period > 0.0:
        d -= period * math.floor(d / period + 0.5)
    return d


@kernel(inline=True)
def _wrapped(x, lo, period):
    """x brought into the periodic box [lo, lo + period) (period 0: as it is). A point in
    the box is kept bit for bit: (x - lo) / period may round up to 1 just below the top, and
    moving such a point by a period would put its distances a rounding away from x's."""
    if period > 0.0 and not lo <= x < lo + period:
        x -= period * math.floor((x - lo) / period)
        if x >= lo + period:                 # rounding: x just below lo came back to the top
            x -= period
    return x


@kernel(inline=True)
def _unwanted(wanted, i):
    """Whether row i is left out of a search (wanted: see the module)."""
    return wanted.size != 0 and not wanted[i]


@kernel
def points(arr):
    """(Q, 3) float64 of the (Q, dim) points arr (z = 0 in 2D), or (0, 3) when one is not
    finite (the caller then names it): a query's points checked and copied in one call (the
    numpy calls took 3 of a 20 us query)."""
    q, dim = arr.shape
    out = np.zeros((q, 3))
    for i in range(q):
        for c in range(dim):
            x = arr[i, c]
            if not math.isfinite(x):
                return np.zeros((0, 3))
            out[i, c] = x
    return out


@kernel
def unchanged(pos, radius, bpos, bradius):
    """Whether pos (n, 3) and radius (n,) hold the same bits as bpos, bradius (what a kept
    grid was built from; contiguous arrays)."""
    n = pos.shape[0]
    if n != bpos.shape[0]:
        return False
    return (_same_bits(radius.view(np.int64), bradius.view(np.int64))
            and _same_bits(pos.reshape(3 * n).view(np.int64),
                           bpos.reshape(3 * n).view(np.int64)))


@kernel
def _same_bits(a, b):
    """Whether the int64 arrays a and b (of one size) are equal: an OR of their XORs with no
    early exit, which LLVM vectorises (every query of a frame asks it of every body: 4 000
    bodies 6.0 -> 3.3 us, where a loop that stops at the first difference does not
    vectorise)."""
    d = 0
    for j in range(a.size):
        d |= a[j] ^ b[j]
    return d == 0


@kernel(inline=True)
def _grown(buf, size):
    """buf when it holds size elements, else a new array of size (buf's dtype)."""
    return buf if buf.size >= size else np.empty(size, buf.dtype)


@kernel(inline=True)
def _grown_rows(buf, rows):
    """buf (r, 3) when r >= rows, else a new (rows, 3) array."""
    return buf if buf.shape[0] >= rows else np.empty((rows, 3))


@kernel(parallel=True)
def grid(pos, radius, rows, lo, period, hint, memory, bpos, bradius):
    """(the grid of the bodies `rows`, its memory). The grid: (origin (3,), cell (3,) side
    per axis, ncell (3,), start (C + 1,), items (k,) rows by cell, giants (g,) rows, rmax:
    the largest radius of a gridded body, gpos (k, 3) and grad (k,): the items' centres and
    radii in their order), its arrays the leading parts of its memory: (giants, count,
    key, start, items, gpos, grad) buffers, those of `memory` where large enough (a grid no
    longer used: the new one's arrays may overlap its), else new (NO_MEMORY: all new). A
    grid of 10^5 bodies in new memory spent more on the pages' first touch than on its
    build.
    lo, period (3,): a periodic box's corner and sides (0: open axis); hint: the smallest
    cell side wanted (the queries' reach: a cell about as wide as a query visits few
    cells), 0 for none. bpos (n, 3), bradius (n,): given rows (NO_BASIS: none), the bodies
    `rows`' pos and radius are copied into them at their rows, as the grid reads them (a
    kept grid's basis, queries._grid: 10^5 bodies 0.19 ms on its own)."""
    m = rows.size
    parts = np.empty(6)
    _bounds(pos, rows, parts)
    origin, hi = parts[:3], parts[3:]
    for c in range(3):
        if period[c] > 0.0:
            origin[c] = lo[c]
            hi[c] = lo[c] + period[c]
        elif m == 0:
            origin[c] = hi[c] = 0.0
    # about one body per cell: the side of the volume per body over the spread axes
    spread = 0
    volume = 1.0
    for c in range(3):
        if hi[c] > origin[c]:
            spread += 1
            volume *= hi[c] - origin[c]
    h = libm.pow(volume / max(m, 1), 1.0 / spread) if spread else 1.0
    h = max(h, hint)
    cell = np.empty(3)
    ncell = np.empty(3, np.int64)
    total = 1
    for c in range(3):
        extent = hi[c] - origin[c]
        n = int(extent / h) if extent > 0.0 else 1
        n = min(max(n, 1), 1 << 20)
        ncell[c] = n
        cell[c] = extent / n if extent > 0.0 else 1.0
        total *= n
    while total > 4 * m + 64:                       # at most a few cells per body
        total = 1
        for c in range(3):
            ncell[c] = max(1, ncell[c] // 2)
            cell[c] = (hi[c] - origin[c]) / ncell[c] if hi[c] > origin[c] else 1.0
            total *= ncell[c]
    # the narrowest cell over the axes the bodies spread along (or that wrap): a body wider
    # than it is a giant, tested directly, so that no search looks past the next cell
    side = 0.0
    for c in range(3):
        if hi[c] > origin[c]:
            side = cell[c] if side == 0.0 else min(side, cell[c])
    # giants (bodies wider than a cell: tested directly) aside; the others' cells counted
    giants_buf = _grown(memory[0], m)
    count_buf = _grown(memory[1], total + 1)
    key_buf = _grown(memory[2], m)
    giants = giants_buf[:m]
    count = arrays.zeroed(count_buf[:total + 1])
    key = key_buf[:m]
    copy = bpos.shape[0] != 0
    if m >= MIN_PARALLEL_BODIES:
        for lane in numba.prange(8):
            _keys(pos, radius, rows, lane * m // 8, (lane + 1) * m // 8, side, lo, period,
                  origin, cell, ncell, copy, bpos, bradius, key)
    else:
        _keys(pos, radius, rows, 0, m, side, lo, period, origin, cell, ncell, copy, bpos,
              bradius, key)
    ng = 0
    rmax = 0.0
    for a in range(m):
        k = key[a]
        if k < 0:
            giants[ng] = rows[a]
            ng += 1
        else:
            rmax = max(rmax, radius[rows[a]])
            count[k + 1] += 1
    giants = giants[:ng]
    for k in range(total):
        count[k + 1] += count[k]
    start_buf = _grown(memory[3], total + 1)
    start = start_buf[:total + 1]
    for k in range(total + 1):
        start[k] = count[k]
    items_buf = _grown(memory[4], m - ng)
    items = items_buf[:m - ng]
    for a in range(m):
        if key[a] >= 0:
            items[count[key[a]]] = rows[a]
            count[key[a]] += 1
    # the gridded bodies' centres (in the periodic box, as their cells) and radii in cell
    # order: a cell's bodies side by side. Read from all over pos: on threads when many
    # (10^5 bodies: the grid 1.9 -> 1.3 ms)
    gpos_buf = _grown_rows(memory[5], items.size)
    grad_buf = _grown(memory[6], items.size)
    gpos = gpos_buf[:items.size]
    grad = grad_buf[:items.size]
    if items.size >= MIN_PARALLEL_BODIES:
        for e in numba.prange(items.size):
            _copy_body(pos, radius, lo, period, items, gpos, grad, np.int64(e))
    else:
        for e in range(items.size):
            _copy_body(pos, radius, lo, period, items, gpos, grad, e)
    return ((origin, cell, ncell, start, items, giants, rmax, gpos, grad),
            (giants_buf, count_buf, key_buf, start_buf, items_buf, gpos_buf, grad_buf))


@kernel(inline=True)
def _bounds(pos, rows, out):
    """out (6,) = the smallest coordinate per axis, then the largest, of the bodies
    `rows` (inf and -inf when there are none). A body's three coordinates in one pass,
    into six scalars: six independent chains of min and max (10^5 bodies: 380 -> 145 us,
    against an axis at a time)."""
    x0 = y0 = z0 = np.inf
    x1 = y1 = z1 = -np.inf
    for a in range(rows.size):
        i = rows[a]
        x, y, z = pos[i, 0], pos[i, 1], pos[i, 2]
        x0 = min(x0, x)
        x1 = max(x1, x)
        y0 = min(y0, y)
        y1 = max(y1, y)
        z0 = min(z0, z)
        z1 = max(z1, z)
    out[0], out[1], out[2], out[3], out[4], out[5] = x0, y0, z0, x1, y1, z1


@kernel(lean=True)
def _keys(pos, radius, rows, a0, a1, side, lo, period, origin, cell, ncell, copy, bpos,
          bradius, key):
    """key[a] for a in a0..a1: the grid cell ((ix * n1 + iy) * n2 + iz) of body rows[a], or
    -1 for a giant (wider than side > 0); with copy, its pos and radius copied into bpos,
    bradius at its row. An axis of one cell is cell 0 without the arithmetic (2D's z: 4 000
    bodies 22 -> 14 us for the grid's keys)."""
    # the grid's shape in scalars: read from arrays, LLVM would read them again after every
    # store into key (4 000 bodies: 30 -> 20 us)
    o0, o1, o2 = origin[0], origin[1], origin[2]
    c0, c1, c2 = cell[0], cell[1], cell[2]
    n0, n1, n2 = ncell[0], ncell[1], ncell[2]
    for a in range(a0, a1):
        i = rows[a]
        if copy:
            bpos[i, 0], bpos[i, 1], bpos[i, 2] = pos[i, 0], pos[i, 1], pos[i, 2]
            bradius[i] = radius[i]
        if side > 0.0 and radius[i] > side:
            key[a] = -1
            continue
        k = _cell_of(pos[i, 0], lo[0], period[0], o0, c0, n0) if n0 > 1 else 0
        k = k * n1 + (_cell_of(pos[i, 1], lo[1], period[1], o1, c1, n1) if n1 > 1 else 0)
        key[a] = k * n2 + (_cell_of(pos[i, 2], lo[2], period[2], o2, c2, n2) if n2 > 1
                           else 0)


@kernel(inline=True)
def _cell_of(x, lo, period, origin, cell, n):
    """The grid cell (0 .. n - 1) of coordinate x on one axis: lo, period the box's (period
    0: open), origin, cell, n the grid's."""
    q = int(math.floor((_wrapped(x, lo, period) - origin) / cell))
    return min(max(q, 0), n - 1)


@kernel(inline=True)
def _copy_body(pos, radius, lo, period, items, gpos, grad, e):
    """gpos[e], grad[e] = body items[e]'s centre (wrapped into the box) and radius."""
    i = items[e]
    for c in range(3):
        gpos[e, c] = _wrapped(pos[i, c], lo[c], period[c])
    grad[e] = radius[i]


@kernel(inline=True)
def _gap(pos, radius, i, x, y, z, period):
    """The distance from (x, y, z) to body i's surface, 0 inside it."""
    dx = _image(pos[i, 0] - x, period[0])
    dy = _image(pos[i, 1] - y, period[1])
    dz = _image(pos[i, 2] - z, period[2])
    return max(math.sqrt(dx * dx + dy * dy + dz * dz) - radius[i], 0.0)


@kernel(inline=True)
def _box_gap(pos, radius, i, centres, half, q, period):
    """The distance from body i's surface to the box centres[q] +- half[q] (0: they
    overlap), and the distance of its centre from the box's centre."""
    out = 0.0
    d2 = 0.0
    for c in range(3):
        d = _image(pos[i, c] - centres[q, c], period[c])
        d2 += d * d
        e = max(abs(d) - half[q, c], 0.0)
        out += e * e
    return max(math.sqrt(out) - radius[i], 0.0), math.sqrt(d2)


@kernel(inline=True)
def _range(x, reach, origin, cell, ncell, period):
    """(first, last) cell indices along one axis within reach of x (periodic: may run past
    the ends, wrapped by the caller; open: clamped into the grid, both ends: a body on the
    grid's far edge sits in the last cell, and a range that starts past it may still reach
    it exactly)."""
    # a margin for rounding: a body's image met across a periodic seam at a distance of
    # 1e-15 is at 0 when x - p is rounded (found by the property test: a query at the box's
    # edge with r = 0 missed a body on the opposite edge)
    slack = 1e-12 * (abs(x) + abs(origin) + reach + period)
    a = int(math.floor((x - reach - slack - origin) / cell))
    b = int(math.floor((x + reach + slack - origin) / cell))
    if period > 0.0:
        if b - a + 1 >= ncell:
            return 0, ncell - 1
        return a, b
    return min(max(a, 0), ncell - 1), min(max(b, 0), ncell - 1)


@kernel(lean=True)
def _visit(pos, radius, g, q, centres, reach, half, period, kind_of_query, ids_out, dist_out,
           base, wanted):
    """Count (ids_out empty) or write the hits of query q at base in ids_out, dist_out (which
    hold room for them only, or free room past them: _test): the gridded bodies within reach
    of its cells, then the giants. Lean (no reference counts: it allocates nothing): called
    twice per query, its arrays' counts cost more than its work (11.3 -> 7.5 ms for 10^4
    queries). kind_of_query 0: within radius reach[q]; 1: overlapping the
    box centres[q] +- half[q]. Returns the hit count."""
    origin, cell, ncell, start, items, giants, rmax, gpos, grad = g
    x, y, z = centres[q, 0], centres[q, 1], centres[q, 2]
    r = reach[q]
    box = kind_of_query != 0
    x0, x1 = _range(x, (half[q, 0] if box else r) + rmax, origin[0], cell[0], ncell[0],
                    period[0])
    y0, y1 = _range(y, (half[q, 1] if box else r) + rmax, origin[1], cell[1], ncell[1],
                    period[1])
    z0, z1 = _range(z, (half[q, 2] if box else r) + rmax, origin[2], cell[2], ncell[2],
                    period[2])
    # the box's period and the mask's emptiness in scalars, read once (10^4 queries: a
    # thread's visits 2.75 -> 2.48 ms)
    p0, p1, p2 = period[0], period[1], period[2]
    every = wanted.size == 0
    n = 0
    flat = ncell[2] == 1         # then the cells (ix, y0..y1) lie side by side: one run
    for cx in range(x0, x1 + 1):
        ix = cx % ncell[0] if p0 > 0.0 else cx
        for cy in range(y0, (y0 if flat else y1) + 1):
            if flat:
                row, a, b, nrun, wrap = ix * ncell[1], y0, y1, ncell[1], p1
            else:
                iy = cy % ncell[1] if p1 > 0.0 else cy
                row, a, b, nrun, wrap = (ix * ncell[1] + iy) * ncell[2], z0, z1, ncell[2], p2
            n = _run(gpos, grad, start, items, row, a, b, nrun, wrap, x, y, z, r, p0, p1, p2,
                     q, centres, half, period, kind_of_query, ids_out, dist_out, base, n,
                     every, wanted)
    for e in range(giants.size):
        i = giants[e]
        if every or wanted[i]:
            n = _test(pos, radius, i, i, x, y, z, r, p0, p1, p2, q, centres, half, period,
                      kind_of_query, ids_out, dist_out, base, n)
    return n


@kernel(inline=True)
def _run(gpos, grad, start, items, base, a, b, ncell, wrap, x, y, z, r, p0, p1, p2, q,
         centres, half, period, kind_of_query, ids_out, dist_out, first, n, every, wanted):
    """_test of the bodies of cells base + a .. base + b, which lie side by side in the grid
    (the last axis's cells a..b, wrapped when the axis is periodic: then in two runs across
    the seam, the second empty otherwise): one loop over their bodies, not one per cell,
    whose few bodies each made the loop's end a branch mispredicted. Returns the hit
    count."""
    a1, b1, b2 = a, b, -1                   # the runs a1..b1 and 0..b2
    if wrap > 0.0 and (a < 0 or b >= ncell):
        a1 = a % ncell
        b1 = a1 + (b - a)
        if b1 >= ncell:                     # (b - a < ncell: _range)
            b1, b2 = ncell - 1, b1 - ncell
    for part in range(2):
        lo_e = start[base + (a1 if part == 0 else 0)]
        hi_e = start[base + (b1 if part == 0 else b2) + 1]
        for e in range(lo_e, hi_e):
            if every or wanted[items[e]]:
                n = _test(gpos, grad, e, items[e], x, y, z, r, p0, p1, p2, q, centres, half,
                          period, kind_of_query, ids_out, dist_out, first, n)
    return n


@kernel(inline=True)
def _test(pos, radius, i, row, x, y, z, r, p0, p1, p2, q, centres, half, period,
          kind_of_query, ids_out, dist_out, base, n):
    """Body i of pos, radius (row `row` of the World) against query q (at x, y, z; reach r;
    p0, p1, p2 the box's period): written at base + n when it is a hit and ids_out has room
    there; returns the hits so far. A radius query writes every body it tests there (the
    next overwrites a miss: ids_out must hold only this query's hits and free room past
    them) and counts it without a branch: a third of the bodies tested are hits, and the
    branch mispredicted (10^4 queries: a thread's search 2.47 -> 1.63 ms)."""
    if kind_of_query == 0:
        dx = _image(pos[i, 0] - x, p0)
        dy = _image(pos[i, 1] - y, p1)
        dz = _image(pos[i, 2] - z, p2)
        d2 = dx * dx + dy * dy + dz * dz
        s = r + radius[i]
        d = max(math.sqrt(d2) - radius[i], 0.0)
        # near within a margin for rounding, then within r (as the gap is written)
        hit = (d2 <= s * s * (1.0 + 1e-9)) & (d <= r)
        if base + n < ids_out.size:
            ids_out[base + n] = row
            dist_out[base + n] = d
        return n + hit
    else:
        gap, d = _box_gap(pos, radius, i, centres, half, q, period)
        hit = gap <= 0.0
    if hit:
        if base + n < ids_out.size:        # a lane's room may be short: counted, not written
            ids_out[base + n] = row
            dist_out[base + n] = d
        n += 1
    return n


@kernel(inline=True)
def _sort_hits(ids, dist, a, b, ident):
    """Hits a..b sorted by distance, then id (an insertion sort: a query's hits are few)."""
    for u in range(a + 1, b):
        i, d = ids[u], dist[u]
        v = u - 1
        while v >= a and (dist[v] > d or (dist[v] == d and ident[ids[v]] > ident[i])):
            ids[v + 1] = ids[v]
            dist[v + 1] = dist[v]
            v -= 1
        ids[v + 1] = i
        dist[v + 1] = d


@kernel
def _by_cell(g, points, period):
    """(Q,) int64: the queries in the order of their grid cells, so that consecutive
    queries read the same cells and bodies (from memory once)."""
    origin, cell, ncell, start, items, giants, rmax, gpos, grad = g
    keys = np.empty(points.shape[0], np.int64)
    for q in range(points.shape[0]):
        k = 0
        for c in range(3):
            i = int(math.floor((points[q, c] - origin[c]) / cell[c]))
            i = i % ncell[c] if period[c] > 0.0 else min(max(i, 0), ncell[c] - 1)
            k = k * ncell[c] + i
        keys[q] = k
    return arrays.radix_order(keys)


@kernel(lean=True)
def _lane_overlaps(pos, radius, g, order, a0, a1, centres, reach, half, period,
                   kind_of_query, counts, buf_i, buf_d, ident, wanted):
    """Queries order[a0:a1] in one pass into this lane's buffers: each query's hits sorted,
    counts[q] set; a query that does not fit and those after it get counts -1. Returns the
    room used."""
    used = 0
    full = False
    for a in range(a0, a1):
        q = order[a]
        if full:
            counts[q] = -1
            continue
        n = _visit(pos, radius, g, q, centres, reach, half, period, kind_of_query,
                   buf_i[used:], buf_d[used:], 0, wanted)
        if n > buf_i.size - used:
            full = True
            counts[q] = -1
            continue
        _sort_hits(buf_i, buf_d, used, used + n, ident)
        counts[q] = n
        used += n
    return used


@kernel(parallel=True)
def overlaps(g, pos, radius, ident, wanted, period, points_in, reach, half, kind_of_query,
             named, kept, bpos, bradius):
    """Every query's hits among the bodies of the grid g (of pos, radius) that are wanted
    (see the module): (status, offsets (Q + 1,), hits (H,) rows, or with named their ids,
    dist (H,)), hits[offsets[q]:offsets[q+1]] sorted by distance then id (ident (n,): the
    body ids). The queries' points: points_in (Q, dim), copied and checked as points()
    does. With kept, g is a kept grid and bpos, bradius what it was built from: the search
    runs only while pos and radius hold their bits. status 0: searched; 1: the bodies changed (g
    is stale: nothing searched); 2: a point is not finite. A frame's batch of 10 queries
    made three calls (points, unchanged, overlaps), each 1-2 us of numba's arguments and
    results. kind_of_query 0: bodies within reach[q] of centres[q] (half unread: may be
    empty); 1: bodies overlapping the box centres[q] +- half[q] (dist: from the box's
    centre). One pass: lanes of queries (in
    cell order) write into rooms sized from a sample of SAMPLED queries (fewer than that:
    ROOM hits each); the few that do not fit are counted, then written in place
    (10^4 queries: 6.3 -> 5.0 ms against two passes)."""
    centres = points(points_in)
    if centres.shape[0] != points_in.shape[0]:
        return 2, np.empty(0, np.int64), np.empty(0, np.int64), np.empty(0)
    if kept and not unchanged(pos, radius, bpos, bradius):
        return 1, np.empty(0, np.int64), np.empty(0, np.int64), np.empty(0)
    nq = centres.shape[0]
    order = _by_cell(g, centres, period)
    lanes = 8 if nq >= MIN_PARALLEL else 1
    counts = np.empty(nq, np.int64)
    none_i = np.empty(0, np.int64)
    none_d = np.empty(0)
    if nq < SAMPLED:
        # a few queries: a room of ROOM hits each, not a sample, which would visit every
        # one twice (10 queries of about 10 hits among 4 000 bodies: 9.4 -> 7.0 us a call,
        # the call included); those that do not fit go late, as below
        room = ROOM * nq
    else:
        # each lane's room: from a sample of SAMPLED queries, half as much again
        step = max(1, nq // SAMPLED)
        sample = 0
        for a in range(0, nq, step):
            sample += _visit(pos, radius, g, order[a], centres, reach, half, period,
                             kind_of_query, none_i, none_d, 0, wanted)
        per = nq // lanes + 1
        room = int(1.5 * sample / max((nq + step - 1) // step, 1) * per) + 256
    buf_i = np.empty(lanes * room, np.int64)
    buf_d = np.empty(lanes * room)
    if lanes > 1:
        for lane in numba.prange(lanes):
            _lane_overlaps(pos, radius, g, order, lane * nq // lanes,
                           (lane + 1) * nq // lanes, centres, reach, half, period,
                           kind_of_query, counts, buf_i[lane * room:(lane + 1) * room],
                           buf_d[lane * room:(lane + 1) * room], ident, wanted)
    else:            # a few queries: no parallel region (waking the threads costs more)
        _lane_overlaps(pos, radius, g, order, 0, nq, centres, reach, half, period,
                       kind_of_query, counts, buf_i, buf_d, ident, wanted)
    # the queries that did not fit: counted here, written in place below
    late = np.zeros(nq, np.bool_)
    for q in range(nq):
        if counts[q] < 0:
            late[q] = True
            counts[q] = _visit(pos, radius, g, q, centres, reach, half, period,
                               kind_of_query, none_i, none_d, 0, wanted)
    offsets = np.empty(nq + 1, np.int64)
    offsets[0] = 0
    for q in range(nq):
        offsets[q + 1] = offsets[q] + counts[q]
    hits = np.empty(offsets[nq], np.int64)
    dist = np.empty(offsets[nq])
    if lanes > 1:
        for lane in numba.prange(lanes):
            _gather_lane(pos, radius, g, order, np.int64(lane), lanes, nq, room, centres,
                         reach, half, period, kind_of_query, counts, late, offsets, buf_i,
                         buf_d, hits, dist, ident, wanted, named)
    else:
        _gather_lane(pos, radius, g, order, 0, 1, nq, room, centres, reach, half, period,
                     kind_of_query, counts, late, offsets, buf_i, buf_d, hits, dist, ident,
                     wanted, named)
    return 0, offsets, hits, dist


@kernel(lean=True)
def _gather_lane(pos, radius, g, order, lane, lanes, nq, room, centres, reach, half, period,
                 kind_of_query, counts, late, offsets, buf_i, buf_d, hits, dist, ident,
                 wanted, named):
    """overlaps' second pass for one lane: its queries' hits from its buffer into hits,
    dist at their offsets (with named, the rows' ids); those that did not fit searched again
    in place."""
    u = lane * room
    for a in range(lane * nq // lanes, (lane + 1) * nq // lanes):
        q = order[a]
        o = offsets[q]
        if late[q]:
            _visit(pos, radius, g, q, centres, reach, half, period, kind_of_query,
                   hits[o:o + counts[q]], dist[o:o + counts[q]], 0, wanted)
            _sort_hits(hits, dist, o, o + counts[q], ident)
            if named:
                for e in range(o, o + counts[q]):
                    hits[e] = ident[hits[e]]
            continue
        for e in range(counts[q]):
            hits[o + e] = ident[buf_i[u + e]] if named else buf_i[u + e]
            dist[o + e] = buf_d[u + e]
        u += counts[q]


@kernel(inline=True)
def _offer(best_i, best_d, k, filled, i, d, ident):
    """Keep the k nearest (sorted by distance, then id) in best_*[:filled]: returns filled."""
    if filled == k and (d > best_d[k - 1] or (d == best_d[k - 1]
                                               and ident[i] > ident[best_i[k - 1]])):
        return filled
    v = filled - 1 if filled < k else k - 2
    if filled < k:
        filled += 1
    while v >= 0 and (best_d[v] > d or (best_d[v] == d and ident[best_i[v]] > ident[i])):
        best_i[v + 1] = best_i[v]
        best_d[v + 1] = best_d[v]
        v -= 1
    best_i[v + 1] = i
    best_d[v + 1] = d
    return filled


@kernel(lean=True)
def _nearest_one(pos, radius, ident, g, x, y, z, k, period, best_i, best_d, wanted):
    """The k nearest gridded bodies and giants to (x, y, z) (best_*, sorted): every body in
    the cells within r + rmax is offered, r doubling from the point's distance to the grid
    plus a cell until the k-th nearest is within r (no body outside can be nearer) or every
    cell was seen. Returns how many were found (<= k)."""
    origin, cell, ncell, start, items, giants, rmax, gpos, grad = g
    p = (x, y, z)
    r = 0.0
    side = 0.0
    for c in range(3):
        if period[c] == 0.0:
            out = max(origin[c] - p[c], p[c] - (origin[c] + cell[c] * ncell[c]), 0.0)
            r += out * out
        side = max(side, cell[c] if ncell[c] > 1 else 0.0)
    r = math.sqrt(r) + (side if side > 0.0 else 1.0)
    rounds = 0
    while True:
        rounds += 1
        filled = 0
        for e in range(giants.size):
            i = giants[e]
            if _unwanted(wanted, i):
                continue
            filled = _offer(best_i, best_d, k, filled, i,
                            _gap(pos, radius, i, x, y, z, period), ident)
        x0, x1 = _range(x, r + rmax, origin[0], cell[0], ncell[0], period[0])
        y0, y1 = _range(y, r + rmax, origin[1], cell[1], ncell[1], period[1])
        z0, z1 = _range(z, r + rmax, origin[2], cell[2], ncell[2], period[2])
        if rounds > 60 or not r < 1e300:
            # a bound, whatever the reach's arithmetic does far out: every cell, once
            x0, x1, y0, y1, z0, z1 = 0, ncell[0] - 1, 0, ncell[1] - 1, 0, ncell[2] - 1
        for cx in range(x0, x1 + 1):
            for cy in range(y0, y1 + 1):
                for cz in range(z0, z1 + 1):
                    key = ((cx % ncell[0]) * ncell[1] + cy % ncell[1]) * ncell[2] + \
                        cz % ncell[2]
                    for e in range(start[key], start[key + 1]):
                        if _unwanted(wanted, items[e]):
                            continue
                        filled = _offer(best_i, best_d, k, filled, items[e],
                                        _gap(gpos, grad, e, x, y, z, period), ident)
        seen_all = (x1 - x0 + 1 >= ncell[0] and y1 - y0 + 1 >= ncell[1]
                    and z1 - z0 + 1 >= ncell[2])
        if seen_all or (filled == k and best_d[k - 1] <= r):
            return filled
        r *= 2.0


@kernel(parallel=True)
def nearest(g, pos, radius, ident, wanted, period, points, k):
    """The k nearest wanted bodies of the grid g (see the module) to each point: (hits
    (Q, k) rows, -1 past the bodies there are; dist (Q, k), inf there), sorted by distance
    then id."""
    nq = points.shape[0]
    order = _by_cell(g, points, period)
    hits = np.empty((nq, k), np.int64)
    dist = np.empty((nq, k))
    if nq >= MIN_PARALLEL:
        for a in numba.prange(nq):
            _nearest_row(pos, radius, ident, g, points, order[a], k, period, hits, dist,
                         wanted)
    else:
        for q in order:
            _nearest_row(pos, radius, ident, g, points, q, k, period, hits, dist, wanted)
    return hits, dist


@kernel(lean=True)
def _nearest_row(pos, radius, ident, g, points, q, k, period, hits, dist, wanted):
    """Query q's k nearest into hits[q], dist[q] (-1 and inf past those found). Lean: it
    allocates nothing (10^4 queries, k = 1: 5.0 -> 4.0 ms)."""
    filled = _nearest_one(pos, radius, ident, g, points[q, 0], points[q, 1], points[q, 2], k,
                          period, hits[q], dist[q], wanted)
    for j in range(filled, k):
        hits[q, j] = -1
        dist[q, j] = np.inf


# ----------------------------------------------------------------------------- ray casts

@kernel(inline=True)
def _inside(wx, wy, wz, R):
    """Whether |w| <= R, compared scaled by the largest of them: |w|^2 and R^2 underflow to
    0 for a centre 1e-200 from the ray's origin (a body of radius 0 there was met by every
    ray from it, whatever its direction)."""
    s = max(abs(wx), abs(wy), abs(wz), R)
    if s == 0.0:
        return True
    x, y, z, r = wx / s, wy / s, wz / s, R / s
    return x * x + y * y + z * z <= r * r


@kernel(inline=True)
def ray_sphere(ox, oy, oz, dx, dy, dz, px, py, pz, R):
    """The first t >= 0 at which the ray o + t d (d a unit vector) touches the sphere (p, R):
    0 when o is inside it, -1 when it never does."""
    wx = px - ox
    wy = py - oy
    wz = pz - oz
    b = wx * dx + wy * dy + wz * dz
    c = wx * wx + wy * wy + wz * wz - R * R
    if c <= 0.0 and _inside(wx, wy, wz, R):
        return 0.0
    if b <= 0.0:
        return -1.0                          # outside and moving away
    # R^2 less the squared distance of the centre from the ray's line, from the rejection
    # w - b d (not b^2 - c, which cancels: a point 1e-9 off a ray 1.5 long would count)
    hx = wx - b * dx
    hy = wy - b * dy
    hz = wz - b * dz
    disc = R * R - (hx * hx + hy * hy + hz * hz)
    if disc < 0.0:
        return -1.0
    # the nearer root, without cancellation (c <= 0 here only by underflow: a hit at 0)
    return max(c / (b + math.sqrt(disc)), 0.0)


@kernel(inline=True)
def _near(x, o, shift, period):
    """x + shift (an image of x on one axis) as the image nearest o plus whole periods: the
    same rounding whichever image the walk meets (a body across the seam at a distance of
    1e-15 from the ray's origin is at 0 by its nearest image, as a brute force finds)."""
    p = o + _image(x - o, period)
    if period > 0.0:
        p += round((x + shift - p) / period) * period
    return p


@kernel(inline=True)
def _axis_cell(i, n, period):
    """(cell index in the grid or -1, the image's shift) of walk index i on one axis."""
    if period > 0.0:
        w = i % n
        return w, (i - w) // n * period
    if i < 0 or i >= n:
        return -1, 0.0
    return i, 0.0


@kernel(inline=True)
def _from(cur, reach, n, period):
    """The first walk cell of a neighbourhood on one axis (open axes: within the grid; a body
    on the grid's far edge, geometrically in cell n, is kept in cell n - 1; a reach of the
    whole grid, n, is all of it wherever the walk is: it starts up to the true reach outside)."""
    if period > 0.0:
        return cur - reach
    return 0 if reach >= n else min(max(cur - reach, 0), n - 1)


@kernel(inline=True)
def _to(cur, reach, n, period):
    """The last walk cell of a neighbourhood on one axis (open axes: not past the grid)."""
    if period > 0.0:
        return cur + reach
    return n - 1 if reach >= n else min(cur + reach, n - 1)


@kernel(inline=True)
def _margin(cell, scale):
    """The ray walk's margin for roundings on one axis: a billionth of a cell and 1e-12 of
    scale, the sum of the magnitudes the coordinates compared were computed from."""
    return 1e-9 * cell + 1e-12 * scale


@kernel(inline=True)
def _tight(o, d, ta, tb, rmax, origin, cell, cur, reach, n, period):
    """The walk cells on one axis (first, last) of the neighbourhood cur +- reach (_from,
    _to) whose cells, grown by rmax, the ray's stretch ta..tb meets: a body that touches the
    stretch has its centre within rmax of it (with a margin for the roundings). Where the
    largest radius is much smaller than a cell, a stretch away from a face needs its own
    cell alone (in 3D 1 of 27)."""
    first = _from(cur, reach, n, period)
    last = _to(cur, reach, n, period)
    xa = o + ta * d if d != 0.0 else o
    xb = o + tb * d if d != 0.0 else o
    lo, hi = min(xa, xb), max(xa, xb)
    # (o + t d is rounded to about the size of o and t d, |t d| <= |x| + |o|)
    slack = _margin(cell, abs(lo) + abs(hi) + abs(o) + abs(origin) + rmax)
    a = (lo - rmax - slack - origin) / cell
    b = (hi + rmax + slack - origin) / cell
    if a > first:                 # (false for NaN: the whole neighbourhood)
        first = int(math.floor(min(a, last + 1.0)))
    if b < last:
        last = int(math.floor(max(b, first - 1.0)))
    return first, last


@kernel(lean=True)
def cast(g, ident, period, o, d, tmax, extra, skip, first, stamp, slot, scratch, mark,
         out_rows, out_t, cap, wanted):
    """The gridded bodies the ray o + t d (d unit, 0 <= t <= tmax) touches: a walk through
    the grid's cells along the ray (Amanatides and Woo 1987), each cell's neighbours within
    the largest radius tested too; periodic axes walked through their images. first: the
    nearest only (count 0 or 1, ties to the lower id); otherwise every one, once (stamp
    (k,) holds `mark` where a body was met by this ray and slot (k,) where it was written:
    met again, through another cell or image, the nearer meeting is kept), the first cap
    written. Returns the count of hits (first: written to out_rows[0], out_t[0]). extra: a
    radius added to every body's (a shape cast: the moving circle's); skip: a row left out
    (the moving body's own), -1 for none; wanted: see the module. scratch (a lane's, reused
    by its rays: arrays of a ray's own cost more than its short walk): seen (SEEN, 3), the
    walk cells lately scanned (a cell's neighbourhood shares most of its cells with the last
    one's: 3x fewer bodies tested in 2D, 9x in 3D); walk (3, 3) int64 and times (2, 3), the
    walk's cells and crossing times."""
    seen, walk, times = scratch
    origin, cell, ncell, start, items, giants, rmax, gpos, grad = g
    rmax = rmax + extra
    # clip to the grid's box (open axes), grown by the largest radius and _tight's margin for
    # the roundings (a body kept in the last cell may lie a rounding past the box's edge: at
    # 2e-231 above a top edge computed as 0, a ray from its centre along the face missed it)
    t0 = 0.0
    t1 = tmax
    for c in range(3):
        if period[c] > 0.0:
            continue
        top = origin[c] + ncell[c] * cell[c]
        slack = _margin(cell[c], abs(origin[c]) + abs(top) + rmax)
        lo = origin[c] - rmax - slack
        hi = top + rmax + slack
        if d[c] == 0.0:
            if o[c] < lo or o[c] > hi:
                return 0
        else:
            a = (lo - o[c]) / d[c]
            b = (hi - o[c]) / d[c]
            t0 = max(t0, min(a, b))
            t1 = min(t1, max(a, b))
    if t0 > t1:
        return 0
    cur = walk[0]
    step = walk[1]
    reach = walk[2]
    tnext = times[0]
    tdelta = times[1]
    for c in range(3):
        u = (o[c] + t0 * d[c] - origin[c]) / cell[c]
        cur[c] = int(math.floor(u))          # within reach of the grid: t0 is clipped
        if period[c] == 0.0:                     # on an edge (or a rounding past it), where
            cur[c] = min(max(cur[c], 0), ncell[c] - 1)     # its bodies are kept
        # (a margin: a body on the ray but a rounding into the next cell is still seen; on an
        # open axis no more than the grid: bodies a few ulps apart make cells of 1e-300)
        r = rmax / cell[c] + 1e-9
        reach[c] = ncell[c] if period[c] == 0.0 and r >= ncell[c] else int(math.ceil(r))
        if d[c] > 0.0:
            step[c] = 1
            tnext[c] = (origin[c] + (cur[c] + 1) * cell[c] - o[c]) / d[c]
            tdelta[c] = cell[c] / d[c]
        elif d[c] < 0.0:
            step[c] = -1
            tnext[c] = (origin[c] + cur[c] * cell[c] - o[c]) / d[c]
            tdelta[c] = -cell[c] / d[c]
        else:
            step[c] = 0
            tnext[c] = np.inf
            tdelta[c] = np.inf
    for h in range(SEEN):
        seen[h, 0] = _NEVER
    # the walk in scalars: kept in arrays, LLVM would read them again after every store
    # into seen and the outputs
    o0, o1, o2 = o[0], o[1], o[2]
    d0, d1, d2 = d[0], d[1], d[2]
    p0, p1, p2 = period[0], period[1], period[2]
    n0, n1, n2 = ncell[0], ncell[1], ncell[2]
    c0, c1, c2 = cur[0], cur[1], cur[2]
    r0, r1, r2 = reach[0], reach[1], reach[2]
    s0, s1, s2 = step[0], step[1], step[2]
    u0, u1, u2 = tnext[0], tnext[1], tnext[2]
    e0, e1, e2 = tdelta[0], tdelta[1], tdelta[2]
    g0, g1, g2 = origin[0], origin[1], origin[2]
    w0, w1, w2 = cell[0], cell[1], cell[2]
    n = 0
    best = np.inf
    t_cell = t0
    while t_cell <= t1:
        # a body met at t lies within rmax of the ray's point at t, so in the neighbourhood
        # of the cell that point is in: past the nearest meeting, nothing nearer is left
        if first and n and best < t_cell:
            break
        # the cells near enough to this cell's stretch of the ray, t_cell .. its exit
        t_out = min(min(u0, u1), min(u2, t1))
        a0, b0 = _tight(o0, d0, t_cell, t_out, rmax, g0, w0, c0, r0, n0, p0)
        a1, b1 = _tight(o1, d1, t_cell, t_out, rmax, g1, w1, c1, r1, n1, p1)
        a2, b2 = _tight(o2, d2, t_cell, t_out, rmax, g2, w2, c2, r2, n2, p2)
        for ax in range(a0, b0 + 1):
            ix, sx = _axis_cell(ax, n0, p0)
            if ix < 0:
                continue
            for ay in range(a1, b1 + 1):
                iy, sy = _axis_cell(ay, n1, p1)
                if iy < 0:
                    continue
                for az in range(a2, b2 + 1):
                    iz, sz = _axis_cell(az, n2, p2)
                    if iz < 0:
                        continue
                    # scanned lately (this cell, this image)? a hash of the walk indices
                    h = ((ax * 73856093) ^ (ay * 19349663) ^ (az * 83492791)) & (SEEN - 1)
                    if seen[h, 0] == ax and seen[h, 1] == ay and seen[h, 2] == az:
                        continue
                    seen[h, 0] = ax
                    seen[h, 1] = ay
                    seen[h, 2] = az
                    key = (ix * n1 + iy) * n2 + iz
                    for e in range(start[key], start[key + 1]):
                        if items[e] == skip or _unwanted(wanted, items[e]):
                            continue
                        t = ray_sphere(o0, o1, o2, d0, d1, d2,
                                       _near(gpos[e, 0], o0, sx, p0),
                                       _near(gpos[e, 1], o1, sy, p1),
                                       _near(gpos[e, 2], o2, sz, p2), grad[e] + extra)
                        if t < 0.0 or t > tmax:
                            continue
                        if not first and stamp[e] == mark:
                            # met already (through another cell, or another image: keep
                            # the nearer meeting)
                            k = slot[e]
                            if k < cap and t < out_t[k]:
                                out_t[k] = t
                            continue
                        if not first:
                            stamp[e] = mark
                            slot[e] = n
                        if first:
                            if t < best or (t == best and ident[items[e]] < ident[out_rows[0]]):
                                best = t
                                out_rows[0] = items[e]
                                out_t[0] = t
                                n = 1
                        else:
                            if n < cap:
                                out_rows[n] = items[e]
                                out_t[n] = t
                            n += 1
        # across the nearest face; past the grid and its reach on an open axis nothing is
        # left ahead (and the walk ends even when cells of 1e-300 far from the origin leave
        # tnext where it was)
        c = 0
        tc = u0
        if u1 < tc:
            c = 1
            tc = u1
        if u2 < tc:
            c = 2
            tc = u2
        if tc == np.inf:
            break
        t_cell = tc
        if c == 0:
            c0 += s0
            u0 += e0
            if p0 == 0.0 and (c0 > n0 - 1 + r0 or c0 < -r0):
                break
        elif c == 1:
            c1 += s1
            u1 += e1
            if p1 == 0.0 and (c1 > n1 - 1 + r1 or c1 < -r1):
                break
        else:
            c2 += s2
            u2 += e2
            if p2 == 0.0 and (c2 > n2 - 1 + r2 or c2 < -r2):
                break
    return n


@kernel(inline=True)
def _giant_t(pos, radius, i, o, d, period, extra):
    """ray_sphere for body i: the least t over its image nearest the ray's origin and that
    image's neighbours on periodic axes (a body wider than a cell may reach into the ray
    from any of them), -1 if none."""
    best = -1.0
    c0 = _image(pos[i, 0] - o[0], period[0])
    c1 = _image(pos[i, 1] - o[1], period[1])
    c2 = _image(pos[i, 2] - o[2], period[2])
    for a in range(-1, 2):
        if a and period[0] == 0.0:
            continue
        for b in range(-1, 2):
            if b and period[1] == 0.0:
                continue
            for c in range(-1, 2):
                if c and period[2] == 0.0:
                    continue
                t = ray_sphere(o[0], o[1], o[2], d[0], d[1], d[2],
                               o[0] + c0 + a * period[0], o[1] + c1 + b * period[1],
                               o[2] + c2 + c * period[2], radius[i] + extra)
                if t >= 0.0 and (best < 0.0 or t < best):
                    best = t
    return best


@kernel(lean=True)
def _ray(pos, radius, ident, g, period, origins, dirs, tmax, extra, skip, q, first, stamp,
         slot, scratch, mark, rows_out, t_out, cap, wanted):
    """One ray's hits: the grid's walk, then the giants; returns the count."""
    o = origins[q]
    d = dirs[q]
    n = cast(g, ident, period, o, d, tmax[q], extra[q], skip[q], first, stamp, slot,
             scratch, mark, rows_out, t_out, cap, wanted)
    giants = g[5]
    for e in range(giants.size):
        i = giants[e]
        if i == skip[q] or _unwanted(wanted, i):
            continue
        t = _giant_t(pos, radius, i, o, d, period, extra[q])
        if t < 0.0 or t > tmax[q]:
            continue
        if first:
            if n == 0 or t < t_out[0] or (t == t_out[0] and ident[i] < ident[rows_out[0]]):
                rows_out[0] = i
                t_out[0] = t
                n = 1
        else:
            if n < cap:
                rows_out[n] = i
                t_out[n] = t
            n += 1
    return n


@kernel
def _lane(pos, radius, ident, g, period, origins, dirs, tmax, extra, skip, lane, lanes, first,
          counts, offsets, hits, ts, wanted):
    """The rays lane, lane + lanes, ...: first: the nearest hit into hits[q], ts[q]; else
    counts[q] (offsets empty) or the hits themselves, sorted (offsets given)."""
    stamp = np.empty(0 if first else g[4].size, np.int64)
    slot = np.empty(stamp.size, np.int64)
    scratch = (np.empty((SEEN, 3), np.int64), np.empty((3, 3), np.int64), np.empty((2, 3)))
    for e in range(stamp.size):
        stamp[e] = -1
    for q in range(lane, origins.shape[0], lanes):
        if first:
            counts[q] = _ray(pos, radius, ident, g, period, origins, dirs, tmax, extra, skip,
                             q, True, stamp, slot, scratch, 0, hits[q:q + 1], ts[q:q + 1], 1,
                             wanted)
        elif offsets.size == 0:
            counts[q] = _ray(pos, radius, ident, g, period, origins, dirs, tmax, extra, skip,
                             q, False, stamp, slot, scratch, q, hits[:0], ts[:0], 0,
                             wanted)
        else:
            a, b = offsets[q], offsets[q + 1]
            # a mark of its own for the second pass: the first pass's stamps are stale
            _ray(pos, radius, ident, g, period, origins, dirs, tmax, extra, skip, q, False,
                 stamp, slot, scratch, q + origins.shape[0], hits[a:b], ts[a:b], b - a, wanted)
            _sort_hits(hits, ts, a, b, ident)


@kernel(parallel=True)
def raycasts(g, pos, radius, ident, wanted, period, origins, dirs, tmax, extra, skip, first):
    """Rays origins[q] + t dirs[q] (unit), 0 <= t <= tmax[q], against the wanted bodies of
    the grid g (see the module; its cells best about as wide as the extra radii):
    (offsets (Q + 1,), hits (H,) rows, t (H,)), each ray's hits sorted by t then id; with
    first, at most one per ray (the nearest). extra (Q,): a radius added to every body's
    for ray q (a moving circle's: a shape cast); skip (Q,): a row ray q ignores (-1: none)."""
    nq = origins.shape[0]
    lanes = min(nq, 8) if nq >= MIN_PARALLEL else 1
    counts = np.empty(nq, np.int64)
    offsets = np.empty(nq + 1, np.int64)
    hits = np.empty(nq if first else 0, np.int64)
    ts = np.empty(nq if first else 0)
    none = np.empty(0, np.int64)
    for rnd in range(1 if first else 2):
        marks = none if rnd == 0 else offsets
        if lanes > 1:
            for lane in numba.prange(lanes):
                _lane(pos, radius, ident, g, period, origins, dirs, tmax, extra, skip,
                      np.int64(lane), lanes, first, counts, marks, hits, ts, wanted)
        else:
            _lane(pos, radius, ident, g, period, origins, dirs, tmax, extra, skip, 0, 1, first,
                  counts, marks, hits, ts, wanted)
        if rnd == 0:
            offsets[0] = 0
            for q in range(nq):
                offsets[q + 1] = offsets[q] + (counts[q] if not first else min(counts[q], 1))
            if not first:
                hits = np.empty(offsets[nq], np.int64)
                ts = np.empty(offsets[nq])
    if first:                                   # the rays that hit, in order
        n = 0
        for q in range(nq):
            if counts[q]:
                hits[n] = hits[q]
                ts[n] = ts[q]
                n += 1
        return offsets, hits[:n].copy(), ts[:n].copy()
    return offsets, hits, ts


@kernel
def surfaces(pos, period, origins, dirs, offsets, hits, t):
    """Where the rays' hits lie: (ray (H,) the ray of each hit, point (H, 3) = origin + t dir,
    normal (H, 3) the body's outward unit normal there; a ray from inside (t = 0) or a point
    body meets the surface head on: -dir). offsets (Q + 1,), hits (H,) rows, t (H,) as
    raycasts returns them."""
    h = hits.size
    ray = np.empty(h, np.int64)
    point = np.empty((h, 3))
    normal = np.empty((h, 3))
    for q in range(offsets.size - 1):
        for e in range(offsets[q], offsets[q + 1]):
            ray[e] = q
            for c in range(3):
                point[e, c] = origins[q, c] + t[e] * dirs[q, c]
                normal[e, c] = _image(point[e, c] - pos[hits[e], c], period[c])
            length = math.sqrt(normal[e, 0] * normal[e, 0] + normal[e, 1] * normal[e, 1] +
                               normal[e, 2] * normal[e, 2])
            for c in range(3):
                normal[e, c] = normal[e, c] / length if length > 0.0 and t[e] > 0.0 else \
                    -dirs[q, c]
    return ray, point, normal
