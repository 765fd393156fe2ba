"""Array helpers written as plain loops.

numba's generic slice assignment and sorting compile slowly (measured here: 4.6 s for one
`a[:m] = b[:m]` on 2D int arrays, 3 s for a structured one, 1.6 s for a merge-sort argsort,
against well under a second for these loops), and every cached kernel that uses them pays
again. These do the same work at loop speed.
"""
from collections import namedtuple

import numpy as np

from .._jit import kernel

Work = namedtuple("Work", [
    "acc", "pos0", "vel0",          # (n, 3) float64: the step loops' accelerations and start
    "A", "B", "D", "lo", "hi",      # (n, 3) float64: the collision pass's lines and boxes
    "tb",                           # (n,) float64
    "ever", "touched", "in_focus", "is_giant",   # (n,) bool
    "merged", "partners",           # (n,) int64
])
"""Per-body scratch the kernels reuse from step to step and call to call (World keeps it at
its capacity): fresh arrays of this size every step cost more in page faults than the work
done in them (measured: a 55 000-body collision pass took 5.2 ms allocating, 2.0 ms not)."""


@kernel
def copy_into(dst, src):
    """dst[:] = src for (n, 3) float64 arrays."""
    for i in range(src.shape[0]):
        dst[i, 0] = src[i, 0]
        dst[i, 1] = src[i, 1]
        dst[i, 2] = src[i, 2]


@kernel
def capture(frame_at, k, done, fpos, fvel, fmass, pos, vel, mass):
    """A recording's frame taken inside a step loop: when frame_at[k] == done (steps done in
    this call), copy pos, vel (n, 3) and mass (n,) into fpos[k], fvel[k], fmass[k]. Returns
    the index of the next frame to take."""
    if k < frame_at.size and frame_at[k] == done:
        copy_into(fpos[k], pos)
        copy_into(fvel[k], vel)
        for i in range(mass.size):
            fmass[k, i] = mass[i]
        return k + 1
    return k


@kernel
def grown_pairs(pairs, m):
    """A (2m, 2) int64 array holding pairs[:m]."""
    grown = np.empty((2 * m, 2), np.int64)
    for q in range(m):
        grown[q, 0] = pairs[q, 0]
        grown[q, 1] = pairs[q, 1]
    return grown


@kernel
def stable_argsort(keys, k):
    """Indices sorting keys[:k] ascending; equal keys keep their order (a merge sort)."""
    order = np.arange(k)
    tmp = np.empty(k, np.int64)
    width = 1
    while width < k:
        for lo in range(0, k, 2 * width):
            mid = min(lo + width, k)
            hi = min(lo + 2 * width, k)
            a, b, out = lo, mid, lo
            while a < mid and b < hi:
                if keys[order[b]] < keys[order[a]]:
                    tmp[out] = order[b]
                    b += 1
                else:
                    tmp[out] = order[a]
                    a += 1
                out += 1
            while a < mid:
                tmp[out] = order[a]
                a += 1
                out += 1
            while b < hi:
                tmp[out] = order[b]
                b += 1
                out += 1
        order, tmp = tmp, order
        width *= 2
    return order
