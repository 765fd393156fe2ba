"""Spatial queries between steps: which bodies lie within a distance of a point, inside a box,
nearest to a point. A uniform grid of the candidate bodies' centres is built for each call
(a counting sort: linear in the bodies); bodies larger than a cell ("giants") are tested
against every query directly.

A body is a disc (2D) or a sphere (3D) of its radius: its distance from a point is the gap
max(|p - c| - radius, 0) (0 when the point is inside it), and it overlaps a box when the box
is within its radius. With a periodic boundary every difference is taken to its nearest image
(the box's period per axis, 0 for none). Each query's hits are sorted by distance, then id.
"""
import math

import numba
import numpy as np

from .._jit import kernel
from . import arrays

MIN_PARALLEL = 256          # fewest queries answered on threads


@kernel(inline=True)
def _image(d, period):
    """d taken to its nearest periodic image (period 0: none)."""
    if period > 0.0:
        d -= period * math.floor(d / period + 0.5)
    return d


@kernel
def grid(pos, radius, rows, lo, period, hint):
    """The grid of the bodies `rows`: (origin (3,), cell (3,) side per axis, ncell (3,),
    start (C + 1,), items (k,) rows by cell, giants (g,) rows, rmax: the largest radius of a
    gridded body, gpos (k, 3) and grad (k,): the items' centres and radii in their order).
    lo, period (3,): a periodic box's corner and sides (0: open axis); hint: the smallest
    cell side wanted (the queries' reach: a cell about as wide as a query visits few
    cells), 0 for none."""
    m = rows.size
    origin = np.empty(3)
    hi = np.empty(3)
    for c in range(3):
        origin[c] = lo[c] if period[c] > 0.0 else np.inf
        hi[c] = lo[c] + period[c] if period[c] > 0.0 else -np.inf
    if m:
        for a in range(m):
            i = rows[a]
            for c in range(3):
                if period[c] == 0.0:
                    origin[c] = min(origin[c], pos[i, c])
                    hi[c] = max(hi[c], pos[i, c])
    else:
        for c in range(3):
            origin[c] = 0.0
            hi[c] = 0.0
    # about one body per cell: the side of the volume per body over the spread axes
    spread = 0
    volume = 1.0
    for c in range(3):
        if hi[c] > origin[c]:
            spread += 1
            volume *= hi[c] - origin[c]
    h = (volume / max(m, 1)) ** (1.0 / spread) if spread else 1.0
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
    side = 0.0
    for c in range(3):
        if ncell[c] > 1:
            side = max(side, cell[c]) if side == 0.0 else min(side, cell[c])
    # giants: bodies wider than a cell are tested directly
    ng = 0
    rmax = 0.0
    for a in range(m):
        if side > 0.0 and radius[rows[a]] > side:
            ng += 1
        else:
            rmax = max(rmax, radius[rows[a]])
    giants = np.empty(ng, np.int64)
    count = np.zeros(total + 1, np.int64)
    key = np.empty(m, np.int64)
    g = 0
    for a in range(m):
        i = rows[a]
        if side > 0.0 and radius[i] > side:
            giants[g] = i
            g += 1
            key[a] = -1
            continue
        k = 0
        for c in range(3):
            q = int(math.floor((pos[i, c] - origin[c]) / cell[c]))
            if period[c] > 0.0:
                q %= ncell[c]
            q = min(max(q, 0), ncell[c] - 1)
            k = k * ncell[c] + q
        key[a] = k
        count[k + 1] += 1
    for k in range(total):
        count[k + 1] += count[k]
    start = count.copy()
    items = np.empty(m - ng, np.int64)
    for a in range(m):
        if key[a] >= 0:
            items[count[key[a]]] = rows[a]
            count[key[a]] += 1
    # the gridded bodies' centres and radii in cell order: a cell's bodies side by side
    gpos = np.empty((items.size, 3))
    grad = np.empty(items.size)
    for e in range(items.size):
        for c in range(3):
            gpos[e, c] = pos[items[e], c]
        grad[e] = radius[items[e]]
    return origin, cell, ncell, start, items, giants, rmax, gpos, grad


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
    a = int(math.floor((x - reach - origin) / cell))
    b = int(math.floor((x + reach - origin) / cell))
    if period > 0.0:
        if b - a + 1 >= ncell:
            return 0, ncell - 1
        return a, b
    return min(max(a, 0), ncell - 1), min(max(b, 0), ncell - 1)


@kernel(lean=True)
def _visit(pos, radius, g, q, centres, reach, half, period, kind_of_query, ids_out, dist_out,
           base):
    """Count (ids_out empty) or write the hits of query q: the gridded bodies within reach of
    its cells, then the giants. Lean (no reference counts: it allocates nothing): called
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
    n = 0
    for cx in range(x0, x1 + 1):
        ix = cx % ncell[0] if period[0] > 0.0 else cx
        for cy in range(y0, y1 + 1):
            iy = cy % ncell[1] if period[1] > 0.0 else cy
            row = (ix * ncell[1] + iy) * ncell[2]
            for cz in range(z0, z1 + 1):
                k = row + (cz % ncell[2] if period[2] > 0.0 else cz)
                for e in range(start[k], start[k + 1]):
                    n = _test(gpos, grad, e, items[e], q, centres, r, half, period,
                              kind_of_query, ids_out, dist_out, base, n)
    for e in range(giants.size):
        n = _test(pos, radius, giants[e], giants[e], q, centres, r, half, period,
                  kind_of_query, ids_out, dist_out, base, n)
    return n


@kernel(inline=True)
def _test(pos, radius, i, row, q, centres, r, half, period, kind_of_query, ids_out, dist_out,
          base, n):
    """Body i of pos, radius (row `row` of the World) against query q: written at base + n
    when it is a hit and ids_out is not empty; returns the hits so far."""
    if kind_of_query == 0:
        d = _gap(pos, radius, i, centres[q, 0], centres[q, 1], centres[q, 2], period)
        hit = d <= r
    else:
        gap, d = _box_gap(pos, radius, i, centres, half, q, period)
        hit = gap <= 0.0
    if hit:
        if ids_out.size:
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


@kernel(parallel=True)
def overlaps(pos, radius, ident, rows, lo, period, centres, reach, half, kind_of_query):
    """Every query's hits among the bodies `rows`: (offsets (Q + 1,), hits (H,) rows, dist
    (H,)), hits[offsets[q]:offsets[q+1]] sorted by distance then id (ident (n,): the body
    ids). kind_of_query 0: bodies within reach[q] of centres[q]; 1: bodies overlapping the
    box centres[q] +- half[q] (dist: from the box's centre)."""
    hint = 0.0
    for q in range(centres.shape[0]):
        hint += reach[q] if kind_of_query == 0 else half[q, 0] + half[q, 1] + half[q, 2]
    g = grid(pos, radius, rows, lo, period, hint / max(centres.shape[0], 1))
    nq = centres.shape[0]
    order = _by_cell(g, centres, period)
    counts = np.empty(nq, np.int64)
    none_i = np.empty(0, np.int64)
    none_d = np.empty(0)
    if nq >= MIN_PARALLEL:
        for a in numba.prange(nq):
            q = order[a]
            counts[q] = _visit(pos, radius, g, q, centres, reach, half, period, kind_of_query,
                               none_i, none_d, 0)
    else:
        for a in range(nq):
            q = order[a]
            counts[q] = _visit(pos, radius, g, q, centres, reach, half, period, kind_of_query,
                               none_i, none_d, 0)
    offsets = np.empty(nq + 1, np.int64)
    offsets[0] = 0
    for q in range(nq):
        offsets[q + 1] = offsets[q] + counts[q]
    hits = np.empty(offsets[nq], np.int64)
    dist = np.empty(offsets[nq])
    if nq >= MIN_PARALLEL:
        for a in numba.prange(nq):
            q = order[a]
            _visit(pos, radius, g, q, centres, reach, half, period, kind_of_query, hits, dist,
                   offsets[q])
            _sort_hits(hits, dist, offsets[q], offsets[q + 1], ident)
    else:
        for a in range(nq):
            q = order[a]
            _visit(pos, radius, g, q, centres, reach, half, period, kind_of_query, hits, dist,
                   offsets[q])
            _sort_hits(hits, dist, offsets[q], offsets[q + 1], ident)
    return offsets, hits, dist


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
def _nearest_one(pos, radius, ident, g, x, y, z, k, period, best_i, best_d):
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
    while True:
        filled = 0
        for e in range(giants.size):
            i = giants[e]
            filled = _offer(best_i, best_d, k, filled, i,
                            _gap(pos, radius, i, x, y, z, period), ident)
        x0, x1 = _range(x, r + rmax, origin[0], cell[0], ncell[0], period[0])
        y0, y1 = _range(y, r + rmax, origin[1], cell[1], ncell[1], period[1])
        z0, z1 = _range(z, r + rmax, origin[2], cell[2], ncell[2], period[2])
        for cx in range(x0, x1 + 1):
            for cy in range(y0, y1 + 1):
                for cz in range(z0, z1 + 1):
                    key = ((cx % ncell[0]) * ncell[1] + cy % ncell[1]) * ncell[2] + \
                        cz % ncell[2]
                    for e in range(start[key], start[key + 1]):
                        filled = _offer(best_i, best_d, k, filled, items[e],
                                        _gap(gpos, grad, e, x, y, z, period), ident)
        seen_all = (x1 - x0 + 1 >= ncell[0] and y1 - y0 + 1 >= ncell[1]
                    and z1 - z0 + 1 >= ncell[2])
        if seen_all or (filled == k and best_d[k - 1] <= r):
            return filled
        r *= 2.0


@kernel(parallel=True)
def nearest(pos, radius, ident, rows, lo, period, points, k):
    """The k nearest of the bodies `rows` to each point: (hits (Q, k) rows, -1 past the
    bodies there are; dist (Q, k), inf there), sorted by distance then id."""
    g = grid(pos, radius, rows, lo, period, 0.0)
    nq = points.shape[0]
    order = _by_cell(g, points, period)
    hits = np.empty((nq, k), np.int64)
    dist = np.empty((nq, k))
    if nq >= MIN_PARALLEL:
        for a in numba.prange(nq):
            _nearest_row(pos, radius, ident, g, points, order[a], k, period, hits, dist)
    else:
        for q in order:
            _nearest_row(pos, radius, ident, g, points, q, k, period, hits, dist)
    return hits, dist


@kernel
def _nearest_row(pos, radius, ident, g, points, q, k, period, hits, dist):
    best_i = np.empty(k, np.int64)
    best_d = np.empty(k)
    filled = _nearest_one(pos, radius, ident, g, points[q, 0], points[q, 1], points[q, 2], k,
                          period, best_i, best_d)
    for j in range(k):
        hits[q, j] = best_i[j] if j < filled else -1
        dist[q, j] = best_d[j] if j < filled else np.inf
