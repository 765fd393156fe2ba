"""The direct pair sums every gravity model shares: the pull of point masses on a point, and
their potential there, with Plummer softening.

The sources s are (4, >= n) rows x, y, z, m (unit-stride rows, so that the loops vectorise);
the sums follow the type of the point (float64 for the direct kernel and the tree's heavy
sources, float32 for the tree's lists, kernels/tree.py). A source at the point itself
(distance 0, with no softening or as its own term) pulls nothing and holds no energy there:
the direction is undefined, and a zero keeps the state finite.
"""
import numba
import numpy as np

from .._jit import kernel


@kernel(fast=True)
def pull(x, y, z, s, n, eps2):
    """Acceleration / G at (x, y, z) from the first n point masses of s: three numbers of
    x's type, a = sum m d / (|d|^2 + eps2)^(3/2)."""
    zero = x - x
    ax = zero
    ay = zero
    az = zero
    for j in range(n):
        dx = s[0, j] - x
        dy = s[1, j] - y
        dz = s[2, j] - z
        r2 = dx * dx + dy * dy + dz * dz + eps2
        d3 = r2 * np.sqrt(r2)
        # a select, not a branch, so the loop still vectorises; d3 == 0 is the coincident case
        w = s[3, j] / d3 if d3 > zero else zero
        ax += w * dx
        ay += w * dy
        az += w * dz
    return ax, ay, az


@kernel(fast=True)
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


# ----------------------------------------------------------------------------- pairs both ways
# Among the massive bodies each pair pulls both ways (Newton's third law), so it is evaluated
# once: half the square roots and divisions of `pull` over every source. The sources are cut
# into `blocks(ns)` blocks; a tile is the pairs between two blocks (or within one). The tiles
# between blocks run in rounds of disjoint block pairs (the circle method of round-robin
# tournaments), so the tiles of a round can run on threads without sharing a body, and every
# body's sum runs in an order fixed by ns alone: the same bits on one thread or many.

TILE = 128          # bodies per block at least; 32 blocks at most (measured here, 1e3..1e4 bodies)
MAX_BLOCKS = 32
# from this many sources on (below, `pull` is as fast: measured equal at 16, 1.2x slower at
# 32, 1.7x at 128); a few-body problem keeps the rounding of `pull`
PAIRS_FROM = 32


@kernel(inline=True)
def blocks(ns):
    """(blocks, bodies per block) for ns sources: an even number of blocks (a round's tiles
    then share the threads evenly; 7 blocks of 143 took 1.4x as long as 8 of 128), of a
    multiple of 8 bodies (whole vectors)."""
    nb = min(MAX_BLOCKS, max(1, ns // TILE))
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
def _row_both_ways(x, y, z, mi, sx, sy, sz, sm, bx, by, bz, eps2):
    """Body i at (x, y, z), mass mi, against the sources sx.. (views starting at 0, so that
    the loop vectorises): their pull on i returned, i's pull on them added to bx, by, bz."""
    ax = 0.0
    ay = 0.0
    az = 0.0
    for j in range(sx.size):
        dx = sx[j] - x
        dy = sy[j] - y
        dz = sz[j] - z
        r2 = dx * dx + dy * dy + dz * dz + eps2
        d3 = r2 * np.sqrt(r2)
        w = 1.0 / d3 if d3 > 0.0 else 0.0      # coincident points: no force (see the module)
        wj = sm[j] * w
        wi = mi * w
        ax += wj * dx
        ay += wj * dy
        az += wj * dz
        bx[j] -= wi * dx
        by[j] -= wi * dy
        bz[j] -= wi * dz
    return ax, ay, az


@kernel(fast=True, lean=True)
def tile(s, sums, I, J, B, ns, eps2):
    """The pairs between blocks I <= J (within block I when I == J) of the sources s (4, >=
    ns): rows x, y, z, m; their pulls / G added into sums (3, >= ns) for both bodies."""
    i1 = min(ns, (I + 1) * B)
    j0 = J * B
    j1 = min(ns, j0 + B)
    for i in range(I * B, i1):
        j = max(j0, i + 1)
        ax, ay, az = _row_both_ways(s[0, i], s[1, i], s[2, i], s[3, i], s[0, j:j1], s[1, j:j1],
                                    s[2, j:j1], s[3, j:j1], sums[0, j:j1], sums[1, j:j1],
                                    sums[2, j:j1], eps2)
        sums[0, i] += ax
        sums[1, i] += ay
        sums[2, i] += az


@kernel(lean=True)
def _zero_sums(sums, ns):
    for r in range(3):
        for a in range(ns):
            sums[r, a] = 0.0


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


@kernel(parallel=True)
def pull_pairs_threaded(s, sums, ns, eps2):
    """pull_pairs with each round's tiles on threads."""
    _zero_sums(sums, ns)
    nb, B = blocks(ns)
    R, T = rounds(nb)
    for b in numba.prange(nb):
        # (a prange index is unsigned: as int64, tile is compiled once for both loops)
        tile(s, sums, np.int64(b), np.int64(b), B, ns, eps2)
    for r in range(R):
        for k in numba.prange(T):
            I, J = round_pair(r, k, nb)
            if I >= 0:
                tile(s, sums, I, J, B, ns, eps2)
