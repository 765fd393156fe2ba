"""The direct pair sums every gravity model shares: the pull of point masses on points, and
their potential at a point, with Plummer softening.

The sources s are (4, >= n) rows x, y, z, m; the sums follow the type of the points (float64
for the direct kernel and the tree's heavy sources, float32 for the tree's lists,
kernels/tree.py). A source at the point itself (distance 0, with no softening or as its own
term) pulls nothing and holds no energy there: the direction is undefined, and a zero keeps
the state finite.

Every sum runs over the sources in their order, one point per vector lane, so its rounding
is the same at every vector width (SSE2, AVX2, AVX-512) and with or without fused
multiply-add: no kernel is compiled with a value-changing fastmath flag.

From PAIRS_FROM pulling bodies on, their pulls on each other take each pair once
(pull_pairs): half the square roots and divisions. The bodies are cut into blocks; a tile is
the pairs between two blocks, or within one. Its lanes hold bodies of one block, and each
sweep pairs lane l with body l + r (mod the block's size) of the other, r = 0, 1, ... (within
a block, r < size / 2 and half of r = size / 2: sweeps r and size - r pair the same bodies):
both bodies of a lane's pair gain a term in that sweep, one lane each, so no sum runs across
lanes and each body's sum runs in an order fixed by the number of bodies alone (the other
block is held twice in a row, so that a sweep reads and adds into unit-stride rows; a body's
sum there is its two halves added at the end). The tiles run in rounds of disjoint block
pairs (the circle method of round-robin tournaments), so the tiles of a round run on threads
without sharing a body: the same bits on one thread or many. The tiles fuse the
multiply-adds of their distances and sums (_jit.fma: one rounding on every CPU, in the C
library where the CPU has no FMA).
"""
import numba
from numba import types
import numpy as np

from .._jit import fma, kernel, stack_rows


# points summed side by side: a chunk's coordinates and sums are rows of this length
CHUNK = 64
# bodies per block at most (a tile's rows then sit in the first-level cache: 128 took 1.05 ns
# a pair at 4 096 bodies on one thread here, 256 1.69)
TILE = 128
ROWS = 2 * TILE
# lanes whose sums a tile keeps in registers at once: 8, an AVX-512 vector of float64 (two
# AVX2 vectors, four SSE2)
GROUP = 8
# sources whose terms pull_point computes side by side before adding them in order
SOURCES = 32
# from how many pulling bodies the pairs are taken once. The tiles are faster from 16 bodies
# on (one thread: 32 bodies 1.2 against 1.55 us, 128 9.5 against 15.2), but a scene below
# PAIRS_FROM compiles none of them (the force table's sums are None), which keeps the cold
# start of the few-body scenes; from 128 a World's step took 0.70-0.75x its time with the
# one-sided sums (128 to 256 pulling bodies, two threads where they pay)
PAIRS_FROM = 128


@kernel(lean=True, forceinline=True)
def pull_points(xs, ys, zs, nt, s, n, eps2, ax, ay, az):
    """Adds to ax[t], ay[t], az[t] the acceleration / G at the points (xs[t], ys[t], zs[t]),
    t < nt, from the first n point masses of s: a = sum m d / (|d|^2 + eps2)^(3/2), in the
    points' type (eps2's). The loop over the points is the inner one, so a vector's lanes
    hold different points and each point's sum runs in source order: the same bits at
    every vector width (a sum over sources in the lanes would be split into as many partial
    sums as the CPU's vectors hold)."""
    zero = eps2 - eps2
    for j in range(n):
        sx = s[0, j]
        sy = s[1, j]
        sz = s[2, j]
        sm = s[3, j]
        for t in range(nt):
            tx, ty, tz = _term(sx - xs[t], sy - ys[t], sz - zs[t], sm, eps2, zero)
            ax[t] += tx
            ay[t] += ty
            az[t] += tz


@kernel(inline=True)
def _term(dx, dy, dz, sm, eps2, zero):
    """A source's term of a point's sum: w d, w = sm / (|d|^2 + eps2)^(3/2) for the source at
    d from the point, zero (eps2's type) for a coincident one (a select, not a branch, so
    the loops over it still vectorise)."""
    r2 = dx * dx + dy * dy + dz * dz + eps2
    d3 = r2 * np.sqrt(r2)
    w = sm / d3 if d3 > zero else zero
    return w * dx, w * dy, w * dz


@kernel(lean=True, forceinline=True)
def pull_point(x, y, z, s, n, eps2):
    """pull_points for one point (x, y, z), its sums starting from 0: the acceleration / G
    (3 numbers), the same bits. The sources' terms are computed side by side, SOURCES at a
    time (a vector's lanes hold different sources), then added in source order: one point's
    sum alone is a chain of dependent adds, each behind a square root and a division."""
    zero = eps2 - eps2
    terms = stack_rows(eps2, 3, SOURCES)
    gx, gy, gz = zero, zero, zero
    for j0 in range(0, n, SOURCES):
        m = min(SOURCES, n - j0)
        for j in range(m):
            tx, ty, tz = _term(s[0, j0 + j] - x, s[1, j0 + j] - y, s[2, j0 + j] - z,
                               s[3, j0 + j], eps2, zero)
            terms[0, j] = tx
            terms[1, j] = ty
            terms[2, j] = tz
        for j in range(m):
            gx += terms[0, j]
            gy += terms[1, j]
            gz += terms[2, j]
    return gx, gy, gz


@kernel
def potential(x, y, z, s, n, eps2):
    """Potential / G at (x, y, z) (float64) from the first n point masses of s, a source at
    the point itself left out: -sum m / sqrt(|d|^2 + eps2)."""
    phi = 0.0
    for j in range(n):
        dx = s[0, j] - x
        dy = s[1, j] - y
        dz = s[2, j] - z
        d2 = dx * dx + dy * dy + dz * dz
        r2 = d2 + eps2
        phi += -s[3, j] / np.sqrt(r2) if d2 > 0.0 and r2 > 0.0 else 0.0
    return phi


@kernel(inline=True)
def blocks(ns):
    """(blocks, bodies per block) for ns sources: an even number of blocks when more than
    one (a round's tiles then share the threads evenly), of a multiple of 8 bodies, TILE at
    most."""
    nb = (ns + TILE - 1) // TILE
    nb += nb % 2 if nb > 1 else 0
    B = ((ns + nb - 1) // nb + 7) // 8 * 8
    return (ns + B - 1) // B, B


@kernel(inline=True)
def rounds(nb):
    """(rounds, tiles a round) of the nb-block tournament: an even number of seats, one of
    them a bye when nb is odd."""
    seats = nb + nb % 2
    return seats - 1, seats // 2


@kernel(inline=True)
def round_pair(r, k, nb):
    """The blocks (I < J) of tile k in round r of the nb-block tournament (see rounds), or
    (-1, -1) for a bye (odd nb)."""
    m, _ = rounds(nb)                   # rotating seats 0 .. m - 1; seat m stays
    if k == 0:
        p, q = m, r
    else:
        p, q = (r + k) % m, (r - k + m) % m
    if p >= nb or q >= nb:
        return -1, -1
    return min(p, q), max(p, q)


@kernel(inline=True)
def _inverse_cube(dx, dy, dz, eps2):
    """1 / (|d|^2 + eps2)^(3/2), 0 for coincident points (see the module), |d|^2 with fused
    multiply-adds."""
    r2 = fma(dz, dz, fma(dy, dy, dx * dx)) + eps2
    d3 = r2 * np.sqrt(r2)
    return 1.0 / d3 if d3 > 0.0 else 0.0


@kernel(inline=True)
def _both_ways(row, lane, k, l, eps2):
    """The pull / G of row k and lane l on each other added to their sums."""
    dx = row[0, k] - lane[0, l]
    dy = row[1, k] - lane[1, l]
    dz = row[2, k] - lane[2, l]
    inv = _inverse_cube(dx, dy, dz, eps2)
    wj = row[3, k] * inv
    wi = lane[3, l] * inv
    lane[4, l] = fma(wj, dx, lane[4, l])
    lane[5, l] = fma(wj, dy, lane[5, l])
    lane[6, l] = fma(wj, dz, lane[6, l])
    row[4, k] = fma(-wi, dx, row[4, k])
    row[5, k] = fma(-wi, dy, row[5, k])
    row[6, k] = fma(-wi, dz, row[6, k])


@kernel(lean=True)
def _strip(row, lane, l0, l1, first, last, eps2):
    """Lanes l0 .. l1-1 (fewer than a group) over sweeps first .. last-1, in the order of a
    group's: the tile's last lanes, and the half sweep within a block. Compiled once, not
    into the tile twice."""
    for c in range(GROUP):
        for r in range(first + c, last, GROUP):
            for l in range(l0, l1):
                _both_ways(row, lane, np.uint64(l + r), np.uint64(l), eps2)


@kernel(lean=True)
def tile(s, sums, I, J, B, ns, eps2):
    """The pairs between blocks I and J of the sources s (4, >= ns), or within block I when
    I == J, each once, their pulls / G added into sums (3, >= ns): the lanes hold the smaller
    block, the other is held twice in a row (see the module)."""
    if min(B, ns - I * B) > min(B, ns - J * B):
        I, J = J, I
    i0, j0 = I * B, J * B
    p, q = min(B, ns - i0), min(B, ns - j0)
    # the lanes' block (x, y, z, m, then its sums) and the other block twice (see the
    # module), on the stack: unit-stride rows, near each other in the cache
    lane = stack_rows(eps2, 7, TILE)
    row = stack_rows(eps2, 7, ROWS)
    # (unsigned indices, here and below: no wrap-around test, so the loops vectorise with
    # unit-stride loads)
    u0, v0, up, uq = np.uint64(i0), np.uint64(j0), np.uint64(p), np.uint64(q)
    for c in range(4):
        for l in range(up):
            lane[c, l] = s[c, u0 + l]
        for k in range(uq):
            row[c, k] = s[c, v0 + k]
            row[c, uq + k] = s[c, v0 + k]
    for c in range(4, 7):
        for l in range(up):
            lane[c, l] = 0.0
        for k in range(uq + uq):
            row[c, k] = 0.0
    # sweeps first .. last-1: within a block, sweep r and q - r pair the same bodies, so it
    # sweeps r < q / 2, and r = q / 2 (even q) for the first half of the lanes only
    first, last = (1, (q + 1) // 2) if I == J else (0, q)
    # the lanes in groups of GROUP, whose sums stay in registers over the group's sweeps; its
    # sweeps in strides of GROUP (r = c, c + GROUP, ...): sweep r + 1 would add into the rows
    # sweep r has just written, and wait for those stores to reach the cache
    groups = p // GROUP
    for g in range(groups):
        for c in range(GROUP):
            for r in range(first + c, last, GROUP):
                for t in range(GROUP):
                    l = np.uint64(g * GROUP + t)
                    _both_ways(row, lane, l + np.uint64(r), l, eps2)
    _strip(row, lane, groups * GROUP, p, first, last, eps2)
    if I == J and q % 2 == 0:
        _strip(row, lane, 0, q // 2, q // 2, q // 2 + 1, eps2)
    for c in range(3):
        for k in range(uq):
            sums[c, v0 + k] += row[4 + c, k] + row[4 + c, k + uq]
    for c in range(3):
        for l in range(up):
            sums[c, u0 + l] += lane[4 + c, l]


@kernel(lean=True)
def pull_pairs(s, sums, ns, eps2):
    """sums (3, >= ns) = the pull / G of the first ns sources of s (4, >= ns) on each other,
    every pair evaluated once; on the calling thread, bit for bit as pull_pairs_threaded."""
    _zero_sums(sums, ns)
    nb, B = blocks(ns)
    R, T = rounds(nb)
    for b in range(nb):
        tile(s, sums, b, b, B, ns, eps2)
    for r in range(R):
        for k in range(T):
            I, J = round_pair(r, k, nb)
            if I >= 0:
                tile(s, sums, I, J, B, ns, eps2)


@kernel(parallel=True, by_address=True, returns=types.none)
def pull_pairs_threaded(s, sums, ns, eps2):
    """pull_pairs with the blocks' own tiles, then each round's tiles, on threads. Called by
    address (compiled beside the step): it runs only where the work is worth threads."""
    _zero_sums(sums, ns)
    nb, B = blocks(ns)
    R, T = rounds(nb)
    for b in numba.prange(nb):
        # (a prange index is unsigned: as int64, tile is compiled once for both loops)
        tile(s, sums, np.int64(b), np.int64(b), B, ns, eps2)
    for r in range(R):
        for k in numba.prange(T):
            I, J = round_pair(r, np.int64(k), nb)
            if I >= 0:
                tile(s, sums, I, J, B, ns, eps2)


@kernel(lean=True)
def _zero_sums(sums, ns):
    for c in range(3):
        for a in range(ns):
            sums[c, a] = 0.0
