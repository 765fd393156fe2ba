"""The direct pair sums every gravity model shares: the pull of point masses on points, and
their potential at a point, with Plummer softening.

The sources s are (4, >= n) rows x, y, z, m; the sums follow the type of the points (float64
for the direct kernel and the tree's heavy sources, float32 for the tree's lists,
kernels/tree.py). A source at the point itself (distance 0, with no softening or as its own
term) pulls nothing and holds no energy there: the direction is undefined, and a zero keeps
the state finite.

Every sum runs over the sources in their order, one point per vector lane, so its rounding
is the same at every vector width (SSE2, AVX2, AVX-512) and with or without fused
multiply-add: no kernel is compiled with a value-changing fastmath flag. Each pair of
massive bodies is evaluated twice (once for each body): a sum over both bodies' pairs at
once needs one of them summed across lanes, which splits it by the vector width.
"""
import numpy as np

from .._jit import kernel


# points summed side by side: a chunk's coordinates and sums are rows of this length
CHUNK = 64


@kernel(lean=True)
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
