"""The direct pair sums every gravity model shares: the pull of point masses on a point, and
their potential there, with Plummer softening.

The sources s are (4, >= n) rows x, y, z, m (unit-stride rows, so that the loops vectorise);
the sums follow the type of the point (float64 for the direct kernel and the tree's heavy
sources, float32 for the tree's lists, kernels/tree.py). A source at the point itself
(distance 0, with no softening or as its own term) pulls nothing and holds no energy there:
the direction is undefined, and a zero keeps the state finite.
"""
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
