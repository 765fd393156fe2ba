"""Plain-numpy references the numba kernels are checked against (slow, obvious, O(N^2) memory)."""
import numpy as np


def direct_accelerations(pos, mass, pulls, G, eps2):
    """a_i = G sum_j m_j d_ij / (|d_ij|^2 + eps2)^(3/2) over pulling j; coincident pairs skipped."""
    d = pos[None, pulls, :] - pos[:, None, :]            # (n, ns, 3): from i to source j
    r2 = (d ** 2).sum(axis=2) + eps2
    with np.errstate(divide="ignore", invalid="ignore"):
        w = np.where(r2 > 0, mass[pulls][None, :] / (r2 * np.sqrt(r2)), 0.0)
    return G * (w[:, :, None] * d).sum(axis=1)


def direct_potential(pos, mass, pulls, G, eps2):
    """-G sum m_i m_j / sqrt(r^2 + eps2) over pulling pairs and (non-pulling, pulling) pairs."""
    n = len(mass)
    total = 0.0
    for i in range(n):
        for j in range(n):
            if i == j or not pulls[j] or (pulls[i] and j < i):
                continue
            r2 = ((pos[i] - pos[j]) ** 2).sum() + eps2
            if r2 > 0:
                total -= mass[i] * mass[j] / np.sqrt(r2)
    return G * total
