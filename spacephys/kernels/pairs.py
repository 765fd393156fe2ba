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
the pairs between two blocks. Its lanes hold bodies of one block, and each sweep pairs lane
l with body l + r (mod the block's size) of the other, r = 0, 1, ...: both bodies of a lane's
pair gain a term in that sweep, one lane each, so no sum runs across lanes and each body's
sum runs in an order fixed by the number of bodies alone (the other block is held twice in a
row, so that a sweep reads and adds into unit-stride rows; a body's sum there is its two
halves added at the end). The tiles between blocks run in rounds of disjoint block pairs (the
circle method of round-robin tournaments), so the tiles of a round run on threads without
sharing a body: the same bits on one thread or many.
"""
import numba
from numba import types
import numpy as np

from .._jit import kernel, stack_rows


# points summed side by side: a chunk's coordinates and sums are rows of this length
CHUNK = 64
# bodies per block at most (a tile's rows then sit in the first-level cache: 128 took 1.28 ns
# a pair at 4 096 bodies on one thread here, 512 1.7), and from how many pulling bodies the
# pairs are taken once (below it, with two blocks, a round's one tile leaves a thread idle:
# 256 bodies took 0.039 ms on two threads against 0.031 for pull_points)
TILE = 128
ROWS = 2 * TILE
PAIRS_FROM = 384


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
            dx = sx - xs[t]
            dy = sy - ys[t]
            dz = sz - zs[t]
            r2 = dx * dx + dy * dy + dz * dz + eps2
            d3 = r2 * np.sqrt(r2)
            # a select, not a branch, so the loop still vectorises; d3 == 0 is the coincident case
            w = sm / d3 if d3 > zero else zero
            ax[t] += w * dx
            ay[t] += w * dy
            az[t] += w * dz


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
    """1 / (|d|^2 + eps2)^(3/2), 0 for coincident points (see the module)."""
    r2 = dx * dx + dy * dy + dz * dz + eps2
    d3 = r2 * np.sqrt(r2)
    return 1.0 / d3 if d3 > 0.0 else 0.0


@kernel(lean=True)
def tile(s, sums, I, J, B, ns, eps2):
    """The pairs between blocks I and J of the sources s (4, >= ns), each once (within block
    I when I == J: each ordered pair, one-sided), their pulls / G added into sums (3, >= ns):
    the lanes hold the smaller block, the other is held twice in a row (see the module)."""
    if min(B, ns - I * B) > min(B, ns - J * B):
        I, J = J, I
    i0, j0 = I * B, J * B
    p, q = min(B, ns - i0), min(B, ns - j0)
    # the lanes' block (x, y, z, m, then its sums) and the other block twice (see the
    # module), on the stack: unit-stride rows, near each other in the cache
    lane = stack_rows(eps2, 7, TILE)
    row = stack_rows(eps2, 7, ROWS)
    for l in range(p):
        for c in range(4):
            lane[c, l] = s[c, i0 + l]
        for c in range(4, 7):
            lane[c, l] = 0.0
    for k in range(2 * q):
        j = j0 + (k if k < q else k - q)
        for c in range(4):
            row[c, k] = s[c, j]
        for c in range(4, 7):
            row[c, k] = 0.0
    lanes = np.uint64(p)                # unsigned indices: no wrap-around test, so the loops
    if I == J:                          # vectorise with unit-stride loads
        for r in range(1, q):
            for l in range(lanes):
                k = l + np.uint64(r)
                dx = row[0, k] - lane[0, l]
                dy = row[1, k] - lane[1, l]
                dz = row[2, k] - lane[2, l]
                w = row[3, k] * _inverse_cube(dx, dy, dz, eps2)
                lane[4, l] += w * dx
                lane[5, l] += w * dy
                lane[6, l] += w * dz
    else:
        for r in range(q):
            for l in range(lanes):
                k = l + np.uint64(r)
                dx = row[0, k] - lane[0, l]
                dy = row[1, k] - lane[1, l]
                dz = row[2, k] - lane[2, l]
                inv = _inverse_cube(dx, dy, dz, eps2)
                wj = row[3, k] * inv
                wi = lane[3, l] * inv
                lane[4, l] += wj * dx
                lane[5, l] += wj * dy
                lane[6, l] += wj * dz
                row[4, k] -= wi * dx
                row[5, k] -= wi * dy
                row[6, k] -= wi * dz
        for k in range(q):
            for c in range(3):
                sums[c, j0 + k] += row[4 + c, k] + row[4 + c, k + q]
    for l in range(p):
        for c in range(3):
            sums[c, i0 + l] += lane[4 + c, l]


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
