"""The broad phase: the pairs of bodies whose boxes swept over a step overlap, from a uniform
grid. The box each body sweeps goes into every cell of the grid it touches; the cells' keys
(Morton codes, kernels/morton.py: a Z-order through space) are sorted by a radix sort
(linear in N), and a pair is reported only in the cell holding the low corner of the
overlap of its two boxes, so never twice. A few giants (planets among ships) look up the
cells their boxes cover instead of setting a huge cell (or test the grid's bodies, when it
has fewer entries than those cells), and bodies whose kinds meet nothing but giants (debris
that only hit planets) stay out of the grid and look up a grid of the giants. A sparse scene
takes cells about its span per body (grid_pairs says when). Later passes of a step look only
the bodies whose lines changed up in the first pass's grid (focused_pairs). The hot loops
are written out and write into arrays they are given: numba's helpers returning tuples, the
tables' fields read per pair, an array replaced inside a loop, and arrays passed with
reference counting to a helper called per body (lean=True avoids it) each cost two to ten
times the work.
"""
import math

import numpy as np
from numba import types

from .._jit import kernel
from . import libm
from .arrays import grown_pairs, radix_sort, sort_in_place, stable_order
from .codes import FOLLOWS, IGNORE, IN_GRID
from .morton import spread2, spread3
from .rules import allowed, grouped, periods, wrap

_SPARSE = 0.5        # a sparse scene's coarse cell: this times the span's length per body
# the types the kernels called by address return (see _jit.kernel's returns): pairs (m, 2);
# _lead_cells's table, its occupied cells, their rows; the grid (keys, bodies, origin,
# inverse cell, ncell, low bits, the lead cells)
_PAIRS = types.Array(types.int64, 2, "C")
_ROWS = types.Array(types.int64, 1, "C")
_REALS = types.Array(types.float64, 1, "C")
_LEAD = types.Tuple((_PAIRS, types.Array(types.bool_, 3, "C"), _ROWS))
_GRID = types.Tuple((_ROWS, _ROWS, _REALS, _REALS, _ROWS, types.int64, _LEAD))
# _entries's: keys, bodies, single, origin, inverse cell, ncell, entries, low bits, lead cells
_ENTRIES = types.Tuple((_ROWS, _ROWS, types.Array(types.bool_, 1, "C"), _REALS, _REALS, _ROWS,
                        types.int64, types.int64, _LEAD))
# a grid entry's body carries its kind in its low bits: a pair of kinds that never meet is
# passed over without reading either body (debris among debris, in heaps after explosions)
_KIND_BITS = 16
_KIND_MASK = (1 << _KIND_BITS) - 1


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
def _cell_key(x, y, z, ncell, cell):
    """The key of cell (x, y, z) (wrapped around a period by ncell): its Morton code, the
    bits of its indices interleaved (two axes when the grid is flat, cell[2] == 0), so that
    the radix sort's order is a Z-order through space and a run of cells holds bodies near
    each other (with the bodies' rows in space order too, their boxes are read from nearby
    memory). Distinct cells share a key only when their indices agree modulo 2^31 (flat) or
    2^21 on every axis; that would only make a pair be tested twice."""
    x, y, z = _wrap_index(x, ncell[0]), _wrap_index(y, ncell[1]), _wrap_index(z, ncell[2])
    if cell[2] == 0.0:
        return spread2(x) | (spread2(y) << 1)
    return spread3(x) | (spread3(y) << 1) | (spread3(z) << 2)


@kernel(lean=True)
def _key_of(x, y, z, ncell, cell):
    """_cell_key as a call, for the look-ups (a key per cell looked up, not per entry): the
    key inlined into each of them compiled 3 s longer for a scene with collisions, and the
    per-entry loops (_fill, _scan) keep it inlined (a call there cost 5-15 % of a dense
    field's step)."""
    return _cell_key(x, y, z, ncell, cell)


@kernel(inline=True)
def _wrap_index(k, n):
    return k % n if n > 0 else k


@kernel
def candidate_pairs(A, B, tb, alive, rules, lo, hi):
    """Pairs (i < j) whose swept boxes share a cell and whose response is not IGNORE.

    Returns (pairs (m, 2) int64, entries): each pair once, in a deterministic order.
    """
    pairs, grid = grid_pairs(A, B, tb, alive, rules, lo, hi)
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


@kernel(by_address=True, returns=_ENTRIES)
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
    bits = _sort_bits(low, high, origin, cell, ncell)
    keys, bodies = radix_sort(spare[:total], spare[room:room + total],
                               spare[2 * room:2 * room + total],
                               spare[3 * room:3 * room + total], bits)
    return keys, bodies, single, origin, cell, ncell, total, (1 << bits) - 1, lead


@kernel
def _sort_bits(low, high, origin, cell, ncell):
    """How many low bits of the keys (a multiple of 8, 8 to 32) the radix sort groups the
    entries by: enough for the cells across the span low..high (3,) to have runs of their
    own (a key's low 2k or 3k bits hold its indices modulo 2^k), at most 32 (a span wider
    than 2^16 cells (flat) or 2^10 shares runs between cells that far apart, whose keys the
    scan then tells apart)."""
    widest = 1.0
    for c in range(3):
        if ncell[c] > 0:
            widest = max(widest, float(ncell[c]))
        elif cell[c] > 0.0:
            widest = max(widest, math.floor((high[c] - origin[c]) * cell[c]) -
                         math.floor((low[c] - origin[c]) * cell[c]) + 1.0)
    k = 0
    while k < 32 and 2.0 ** k < widest:
        k += 1
    need = k * (2 if cell[2] == 0.0 else 3)
    return min(32, max(8, (need + 7) // 8 * 8))


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
                        elif not _in_set(lead_set, _cell_key(x, y, z, ncell, cell)):
                            continue
                    key = _cell_key(x, y, z, ncell, cell)
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
                    key = _key_of(x, y, z, ncell, cell)
                    h = _slot(lead, key)
                    lead[h, 0] = key
                    lead[h, 1] = 1
    return lead, occupied, low


@kernel
def _entered(alive, gridded):
    """The rows of the live bodies entered in every cell their box covers (IN_GRID)."""
    count = 0
    for i in range(alive.size):
        count += 1 if alive[i] and gridded[i] == IN_GRID else 0
    rows = np.empty(count, np.int64)
    k = 0
    for i in range(alive.size):
        if alive[i] and gridded[i] == IN_GRID:
            rows[k] = i
            k += 1
    return rows


@kernel(inline=True)
def _follows(lead):
    """Whether _lead_cells found bodies that follow (entered only in the cells it holds)."""
    return lead[0].shape[0] > 0 or lead[1].shape[0] > 0


@kernel(inline=True)
def _led(table, occupied, low, x, y, z, ncell, cell):
    """Whether _lead_cells's cells (its set, map and low cell) hold cell (x, y, z) (ncell:
    the grid's, for the set's key). _fill writes this out: in its loop over 6e4 bodies the
    helper took 3x as long as the same test written there."""
    if occupied.shape[0] > 0:
        a, b, c = x - low[0], y - low[1], z - low[2]
        return 0 <= a < occupied.shape[0] and 0 <= b < occupied.shape[1] and \
            0 <= c < occupied.shape[2] and occupied[a, b, c]
    return _in_set(table, _key_of(x, y, z, ncell, cell))


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
    grouped by (one cell's, or those of cells alike in those bits)."""
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
          category, mask, owner, group, response, pairs):
    """The pairs (i < j) of each cell of the grid (see grid_pairs) written into pairs while
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
                        first[c] = int(math.floor((edge - origin[c]) * cell[c]))
                    home = home and _cell_key(first[0], first[1], first[2], ncell, cell) == \
                        keys[eu]
                # the rest of allowed last: most pairs sharing a cell fail the box test
                if not home or (category[i] & mask[j]) == 0 or (category[j] & mask[i]) == 0 \
                        or owner[i] == j or owner[j] == i or grouped(group, i, j):
                    continue
                if m < pairs.shape[0]:
                    pairs[m, 0] = i
                    pairs[m, 1] = j
                m += 1
        run = end
    return m


@kernel(by_address=True, returns=types.Tuple((_PAIRS, _GRID)))
def grid_pairs(A, B, tb, alive, rules, lo, hi):
    """candidate_pairs, and the grid it built: (keys (E,), bodies (E,): the entries (cell
    key, row << _KIND_BITS | its kind) grouped by cell, origin (3,), inverse cell (3,),
    ncell (3,), the sort's mask of low bits, the cells followers were entered in
    (_lead_cells's)))."""
    radius, kind = rules.radius, rules.kind
    n = A.shape[0]
    L = periods(rules)
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
    size = max(size, libm.pow(biggest * (1.0 / 4096.0), 1.0 / rules.dim))
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
        coarse = max(size, _SPARSE * libm.pow(share / members, 1.0 / rules.dim))
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
              rules.category, rules.mask, rules.owner, rules.group, rules.response, pairs)
    if m > pairs.shape[0]:
        pairs = np.empty((m, 2), np.int64)
        _scan(keys, bodies, total, low_bits, single, wraps, lo, hi, L, origin, cell, ncell,
              rules.category, rules.mask, rules.owner, rules.group, rules.response, pairs)
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
        # giants up themselves, below); a giant over more cells than the grid has entries
        # tests the grid's bodies instead (a planet of a dogfight over 10^3 cells of its
        # two ships took 10 us a step looking them up)
        count = -1
        if _cells_of(g, lo, hi, origin, cell, ncell, work[0], work[1]) <= min(4096.0, total):
            count = _grid_meets(g, grid, nothing, lo, hi, L, alive, follower, near, work,
                                False)
        if count < 0:                                  # the grid's bodies: all
            # (but followers, not all: 64 planets over 5e4 debris that meet only them, and
            # so no grid, took 3.5 ms a step)
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
        loose[j] = alive[j] and gridded[j] != IN_GRID and reach[kind[j]]     # giant...
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
        if allowed(rules, kind, a, b) != IGNORE:
            pairs[m, 0] = a
            pairs[m, 1] = b
            m += 1
    return m, pairs


@kernel(by_address=True, returns=types.Tuple((types.int64, _PAIRS)))
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
    most), in grid_pairs's form (the keys wholly sorted)."""
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
                            keys[total] = _key_of(x, y, z, ncell, cell)
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
    return (cj - ci) - wrap(cj - ci, L[c])


@kernel(lean=True)
def _boxes_meet(lo, hi, i, j, L):
    """Whether the boxes of i and j overlap (j's nearest image when wrapping)."""
    for c in range(3):
        shift = _image_shift(lo, hi, i, j, c, L)
        if max(lo[i, c], lo[j, c] - shift) > min(hi[i, c], hi[j, c] - shift):
            return False
    return True


@kernel(by_address=True, returns=types.Tuple((_PAIRS, types.bool_)))
def focused_pairs(A, B, tb, alive, rules, lo, hi, focus, in_focus, stale, changed, grid,
                  is_giant):
    """Pairs with at least one body of `focus` (whose lines changed in the last pass) and
    overlapping boxes, as (pairs, True); (empty, False) when a new grid is cheaper.
    grid : grid_pairs's, of the boxes when it was built; stale (n,) and changed (rows):
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
    group = rules.group
    gridded = rules.gridded
    n = lo.shape[0]
    L = periods(rules)
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
                        allowed(rules, kind, min(i, j), max(i, j)) != IGNORE:
                    if m < found.size:
                        found[m] = i * n + j
                    m += 1
            continue
        if gridded[i]:
            count = _grid_meets(i, grid, nothing, lo, hi, L, alive, stale, near, work,
                                gridded[i] == IN_GRID)
            if count < 0:
                return -1
            for p in range(count):
                j = near[p]
                a2, b2 = min(i, j), max(i, j)
                if (category[a2] & mask[b2]) == 0 or (category[b2] & mask[a2]) == 0 or \
                        owner[a2] == b2 or owner[b2] == a2 or grouped(group, a2, b2) or \
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
                if _boxes_meet(lo, hi, a2, b2, L) and allowed(rules, kind, a2, b2) != IGNORE:
                    if m < found.size:
                        found[m] = i * n + j
                    m += 1
        for p in range(giants.size):
            g = giants[p]
            if not alive[g] or (in_focus[g] and g < i):
                continue                               # (a giant in focus below: its pair)
            a2, b2 = min(i, g), max(i, g)
            if _boxes_meet(lo, hi, a2, b2, L) and allowed(rules, kind, a2, b2) != IGNORE:
                if m < found.size:
                    found[m] = i * n + g
                m += 1
    return m


@kernel(inline=True)
def _cell_range(i, lo, hi, origin, cell, ncell, first, last):
    """The cells of i's box into first, last (3,); False when it covers more than 4096 or
    lies past any cell number an int64 holds (a box far out or swept far: a line a contact
    changed after the grid was sized), in floats first."""
    return _cells_of(i, lo, hi, origin, cell, ncell, first, last) <= 4096.0


@kernel(inline=True)
def _cells_of(i, lo, hi, origin, cell, ncell, first, last):
    """How many cells i's box covers, their range into first, last (3,); inf when it lies
    past any cell number an int64 holds."""
    count = 1.0
    for c in range(3):
        f0 = np.floor((lo[i, c] - origin[c]) * cell[c])    # (a float: NaN fails below;
        f1 = np.floor((hi[i, c] - origin[c]) * cell[c])    # math.floor's int64 would not)
        if not (abs(f0) < 2.0 ** 52 and abs(f1) < 2.0 ** 52):
            return np.inf
        first[c] = int(f0)
        last[c] = int(f1)
        if ncell[c] > 0 and last[c] - first[c] >= ncell[c]:
            last[c] = first[c] + ncell[c] - 1
        count *= last[c] - first[c] + 1
    return count


@kernel(inline=True)
def _meets_here(i, j, key, lo, hi, L, origin, cell, ncell, corner):
    """Whether the boxes of i and j (j's image nearest i) meet, with the low corner of their
    overlap in the cell of `key` (so a pair sharing several cells is reported once)."""
    for c in range(3):
        shift = _image_shift(lo, hi, i, j, c, L)
        if max(lo[i, c], lo[j, c] - shift) > min(hi[i, c], hi[j, c] - shift):
            return False
        edge = lo[i, c] if lo[i, c] >= lo[j, c] - shift else lo[j, c]
        corner[c] = int(math.floor((edge - origin[c]) * cell[c]))
    return _key_of(corner[0], corner[1], corner[2], ncell, cell) == key


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
                if strict and following and not _led(lead_set, lead_map, lead_low, x, y, z, ncell,
                                                             cell):
                    return -1
                key = _key_of(x, y, z, ncell, cell)
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
    L = periods(rules)
    _bounds(A, B, tb, radius, alive, lo, hi, rules.giants[:0])
    pairs = np.empty((16, 2), np.int64)
    m = 0
    for i in range(n):
        if not alive[i]:
            continue
        for j in range(i + 1, n):
            if not alive[j] or allowed(rules, kind, i, j) == IGNORE:
                continue
            if _boxes_meet(lo, hi, i, j, L):
                if m == pairs.shape[0]:
                    pairs = grown_pairs(pairs, m)
                pairs[m, 0] = i
                pairs[m, 1] = j
                m += 1
    return pairs[:m]
