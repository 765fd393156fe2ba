"""Morton codes (Z-order): the bits of integer coordinates interleaved, so that sorting by
the code walks space in a Z, near points mostly near each other. The broad phase keys its
cells by them (kernels/broadphase.py); a large colliding scene puts its rows in this order
(spacephys/space_order.py).
"""
import math

import numpy as np

from .._jit import kernel
from .arrays import radix_sort


@kernel(inline=True)
def spread2(v):
    """The low 31 bits of v, one to every second bit (bits 0, 2, ..., 60)."""
    x = v & 0x7FFFFFFF
    x = (x | (x << 16)) & 0x0000FFFF0000FFFF
    x = (x | (x << 8)) & 0x00FF00FF00FF00FF
    x = (x | (x << 4)) & 0x0F0F0F0F0F0F0F0F
    x = (x | (x << 2)) & 0x3333333333333333
    return (x | (x << 1)) & 0x5555555555555555


@kernel(inline=True)
def spread3(v):
    """The low 21 bits of v, one to every third bit (bits 0, 3, ..., 60)."""
    x = v & 0x1FFFFF
    x = (x | (x << 32)) & 0x1F00000000FFFF
    x = (x | (x << 16)) & 0x1F0000FF0000FF
    x = (x | (x << 8)) & 0x100F00F00F00F00F
    x = (x | (x << 4)) & 0x10C30C30C30C30C3
    return (x | (x << 2)) & 0x1249249249249249


@kernel
def order(pos, ids):
    """(n,) int64: the rows of pos (n, 3) in Morton order, the span of the positions split
    along each axis that spans anything into 2^b steps (b: about 2 bits past one step per
    body), rows of one code by id; empty when a position is not finite. Floor and the four
    operations only: the same order on every CPU."""
    n = pos.shape[0]
    lo = np.full(3, np.inf)
    hi = np.full(3, -np.inf)
    for i in range(n):
        for c in range(3):
            x = pos[i, c]
            if not math.isfinite(x):
                return np.empty(0, np.int64)
            lo[c] = min(lo[c], x)
            hi[c] = max(hi[c], x)
    axes = 0
    for c in range(3):
        axes += 1 if hi[c] > lo[c] else 0
    per = 1
    while per < (21 if axes == 3 else 31) and 2.0 ** (per * max(axes, 1)) < 4.0 * n:
        per += 1
    per = min(per + 2, 21 if axes == 3 else 31)
    top = float(2 ** per - 1)
    keys = np.empty(n, np.int64)
    rows = np.empty(n, np.int64)
    q = np.zeros(3, np.int64)
    for i in range(n):
        a = 0
        for c in range(3):
            if hi[c] > lo[c]:
                q[a] = int(min(math.floor((pos[i, c] - lo[c]) * (top / (hi[c] - lo[c]))), top))
                a += 1
        keys[i] = spread3(q[0]) | (spread3(q[1]) << 1) | (spread3(q[2]) << 2) if axes == 3 \
            else spread2(q[0]) | (spread2(q[1]) << 1)
        rows[i] = i
    bits = (per * max(axes, 1) + 7) // 8 * 8
    keys, rows = radix_sort(keys, rows, np.empty(n, np.int64), np.empty(n, np.int64), bits)
    start = 0                           # the rows of one code (few: ~1 a code) by id
    for e in range(1, n + 1):
        if e == n or keys[e] != keys[start]:
            for k in range(start + 1, e):
                r = rows[k]
                m = k
                while m > start and ids[rows[m - 1]] > ids[r]:
                    rows[m] = rows[m - 1]
                    m -= 1
                rows[m] = r
            start = e
    return rows
