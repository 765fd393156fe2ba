"""Array helpers written as plain loops.

numba's generic slice assignment and sorting compile slowly (measured here: 4.6 s for one
`a[:m] = b[:m]` on 2D int arrays, 3 s for a structured one, 1.6 s for a merge-sort argsort,
against well under a second for these loops), and every cached kernel that uses them pays
again. These do the same work at loop speed.
"""
import numpy as np
from numba import types

from .._jit import implements, kernel

@kernel(inline=True)
def zeroed(a):
    """a, filled with zeros in a loop. In a parallel kernel numba turns np.zeros into a
    parallel region of its own, whatever its size (a 'zeros function' parfor, despite
    _jit.PRANGE_ONLY): the thread pool woken on every call of a 3-body scene, and a process
    forked after one dies in the child (GNU OpenMP). The step kernels use np.empty and
    this."""
    flat = a.reshape(a.size)
    for i in range(flat.size):
        flat[i] = 0
    return a


@kernel(lean=True)
def copy_into(dst, src):
    """dst[:] = src for (n, 3) float64 arrays (lean: the per-step copies hand it arrays)."""
    for i in range(src.shape[0]):
        dst[i, 0] = src[i, 0]
        dst[i, 1] = src[i, 1]
        dst[i, 2] = src[i, 2]


@kernel
def grown_pairs(pairs, m):
    """A (2m, 2) int64 array holding pairs[:m]."""
    grown = np.empty((2 * m, 2), np.int64)
    for q in range(m):
        grown[q, 0] = pairs[q, 0]
        grown[q, 1] = pairs[q, 1]
    return grown


@kernel
def largest(values, k):
    """(min(k, n),) int64: the rows of the k largest values, largest first, ties in row order;
    one pass through a small sorted buffer (tens of planets among 1e5 debris: one comparison
    each for the debris)."""
    k = min(k, values.size)
    rows = np.empty(k, np.int64)
    m = 0
    least = -np.inf          # the k-th largest so far, kept in a local (not re-read through
    for i in range(values.size):    # rows each time: 3x faster at 6e4 debris)
        v = values[i]
        if m == k:
            if not v > least:
                continue
            p = k - 1
        else:
            p = m
            m += 1
        while p > 0 and v > values[rows[p - 1]]:
            rows[p] = rows[p - 1]
            p -= 1
        rows[p] = i
        if m == k:
            least = values[rows[k - 1]]
    return rows


@kernel
def contact_order(t, i, j, k):
    """(k,) int64: the order sorting the contacts (t, i, j)[:k] by time, then i, then j (a
    merge sort; i, j the bodies' ids). Contacts at one time (bodies overlapping at the start
    of a step) are resolved in the order of their ids, whatever order the broad phase found
    them in and whatever rows the bodies hold."""
    return stable_order((t, i, j), k)


def _before(keys, y, x):
    """Whether row y sorts before row x: keys an array, or a tuple (t, i, j) compared in
    that order."""


implements(_before, lambda keys, y, x: keys[y] < keys[x],
           lambda keys, y, x: isinstance(keys, types.Array), inline=True)
implements(_before, lambda keys, y, x: keys[0][y] < keys[0][x] or (
    keys[0][y] == keys[0][x] and (keys[1][y] < keys[1][x] or (
        keys[1][y] == keys[1][x] and keys[2][y] < keys[2][x]))),
    lambda keys, y, x: isinstance(keys, types.BaseTuple), inline=True)


@kernel
def stable_order(keys, k):
    """(k,) int64: the stable order sorting keys[:k] ascending (a merge sort; numbers, no
    NaN), keys an array or a tuple of three compared in turn (_before):
    np.argsort(keys[:k], kind="mergesort"), which compiles 2.5 s slower."""
    buf = np.empty((2, k), np.int64)                   # two halves, in turn source and result
    for q in range(k):
        buf[0, q] = q
    src = 0
    width = 1
    while width < k:
        dst = 1 - src
        for lo in range(0, k, 2 * width):
            mid = min(lo + width, k)
            hi = min(lo + 2 * width, k)
            a, b, out = lo, mid, lo
            while a < mid and b < hi:
                x, y = buf[src, a], buf[src, b]
                if _before(keys, y, x):
                    buf[dst, out] = y
                    b += 1
                else:
                    buf[dst, out] = x
                    a += 1
                out += 1
            while a < mid:
                buf[dst, out] = buf[src, a]
                a += 1
                out += 1
            while b < hi:
                buf[dst, out] = buf[src, b]
                b += 1
                out += 1
        src = dst
        width *= 2
    order = np.empty(k, np.int64)
    for q in range(k):
        order[q] = buf[src, q]
    return order


@kernel
def sort_in_place(a, k):
    """a[:k] sorted ascending, in place (int64)."""
    order = stable_order(a, k)
    tmp = np.empty(k, np.int64)
    for q in range(k):
        tmp[q] = a[order[q]]
    for q in range(k):
        a[q] = tmp[q]


SMALL_SORT = 32         # below this many entries radix_order and radix_sort sort by insertion


@kernel
def radix_order(keys):
    """(k,) int64: the stable order sorting the non-negative keys ascending (LSD radix sort,
    11-bit digits; digits on which all keys agree are skipped). Fewer than SMALL_SORT keys:
    by insertion, the same order without each pass's 2 048 counts (a frame's batch of 10
    queries: 1.7 us a call less)."""
    k = keys.size
    order = np.empty(k, np.int64)
    for i in range(k):
        order[i] = i
    if k < SMALL_SORT:
        for e in range(1, k):
            key = keys[e]
            p = e
            while p > 0 and keys[order[p - 1]] > key:
                order[p] = order[p - 1]
                p -= 1
            order[p] = e
        return order
    tmp = np.empty(k, np.int64)
    a = np.empty(k, np.int64)
    b = np.empty(k, np.int64)
    for i in range(k):
        a[i] = keys[i]
    count = np.empty(2049, np.int64)
    for shift in range(0, 66, 11):
        for d in range(2049):
            count[d] = 0
        for i in range(k):
            count[((a[i] >> shift) & 2047) + 1] += 1
        if count[((a[0] >> shift) & 2047) + 1] == k:
            continue                    # every key has this digit
        for d in range(2048):
            count[d + 1] += count[d]
        for i in range(k):
            d = (a[i] >> shift) & 2047
            p = count[d]
            count[d] = p + 1
            b[p] = a[i]
            tmp[p] = order[i]
        a, b = b, a
        order, tmp = tmp, order
    return order


@kernel
def _passes(src_k, src_v, dst_k, dst_v, low, bits, width, count):
    """radix_sort's LSD passes over the digits of bits low..bits, `width` bits each (the
    last one the bits left), between the two pairs of arrays: the pair they end in. Every
    digit's counts come from one read of the keys (the grid of a dense field of 1e5
    circles, 2.7e5 entries: 12.2 -> 8.7 ns each); count: (passes, 2^width) scratch, left
    holding where each digit's entries end in each pass."""
    passes = (bits - low + width - 1) // width
    size = 1 << width
    for p in range(passes):
        for d in range(size):
            count[p, d] = 0
    n = src_k.size
    # the last digit's mask: the bits left below `bits` (none above it, nor the sign's copies)
    last = (np.int64(1) << (bits - low - width * (passes - 1))) - 1
    for e in range(n):
        k = src_k[e] >> low
        for p in range(passes - 1):
            count[p, k & (size - 1)] += 1
            k >>= width
        count[passes - 1, k & last] += 1
    for p in range(passes):
        total = 0
        for d in range(size):
            c = count[p, d]
            count[p, d] = total
            total += c
    for p in range(passes):
        shift = low + width * p
        mask = size - 1 if p < passes - 1 else last
        if mask == 255:          # (as a constant: in cache, 8-bit passes 20 % faster)
            _scatter(src_k, src_v, dst_k, dst_v, count, p, shift, 255)
        else:
            _scatter(src_k, src_v, dst_k, dst_v, count, p, shift, mask)
        src_k, src_v, dst_k, dst_v = dst_k, dst_v, src_k, src_v
    return src_k, src_v


@kernel(inline=True)
def _scatter(src_k, src_v, dst_k, dst_v, count, p, shift, mask):
    """One radix pass: each entry of src to dst at the next place of its digit (key >>
    shift) & mask, from count[p] (left holding the digits' ends)."""
    for e in range(src_k.size):
        d = (src_k[e] >> shift) & mask
        q = count[p, d]
        dst_k[q] = src_k[e]
        dst_v[q] = src_v[e]
        count[p, d] = q + 1


@kernel(inline=True)
def _insertion(keys, values, bits):
    """keys and values in place in a stable order of the keys' low `bits` bits (< 63)."""
    mask = (np.int64(1) << bits) - 1
    for e in range(1, keys.size):
        k, v = keys[e], values[e]
        low = k & mask
        p = e
        while p > 0 and (keys[p - 1] & mask) > low:
            keys[p] = keys[p - 1]
            values[p] = values[p - 1]
            p -= 1
        keys[p] = k
        values[p] = v


# from this many entries radix_sort's digits are up to WIDE_DIGIT bits (fewer passes of more
# counts; below it the counts cost more than a pass: 8 bits), and the top one goes first;
# measured on the dense field's grids (24 bits, 2.7 entries a circle: 6.8e4 entries 7.2 ->
# 6.3 ns each, 2.7e5 9.2 -> 7.0, 2.2e6 20.5 -> 11.6)
WIDE_SORT = 1 << 16
WIDE_DIGIT = 12


@kernel(inline=True)
def digits(n, bits):
    """(passes, width): how radix_sort sorts n entries by `bits` bits, the fewest passes of
    digits `width` bits wide (at most 8 below WIDE_SORT entries, else at most WIDE_DIGIT;
    the last digit holds the bits left)."""
    widest = 8 if n < WIDE_SORT else WIDE_DIGIT
    passes = (bits + widest - 1) // widest
    return passes, (bits + passes - 1) // passes


@kernel
def radix_sort(keys, values, keys_out, values_out, bits):
    """Sort (keys, values) by the low `bits` bits of keys (radix: linear; each pass streams
    the arrays once and scatters them by one digit; digits of up to 8 bits, or of up to
    WIDE_DIGIT from WIDE_SORT entries: digits()). Entries of one cell end up adjacent (with
    cells whose keys share those bits, over spans wider than _sort_bits covers: the scan
    compares full keys). Returns the sorted arrays (keys and values, or keys_out and
    values_out). Fewer than SMALL_SORT entries are sorted in place by insertion, stable by
    the same bits: the same order, without each pass's counts (a duel's grid holds two
    entries). Below WIDE_SORT the passes go from the lowest digit up (LSD); from it the top
    digit goes first, into groups, and each group is then sorted by the digits below on its
    own, its passes in cache: the same stable order."""
    n = keys.size
    if n < SMALL_SORT and bits < 63:
        _insertion(keys, values, bits)
        return keys, values
    passes, width = digits(n, bits)
    count = np.empty((passes, 1 << width), np.int64)
    if n < WIDE_SORT or passes == 1:
        return _passes(keys, values, keys_out, values_out, 0, bits, width, count)
    top = bits - width
    _passes(keys, values, keys_out, values_out, top, bits, width, count)
    ends = count[0].copy()              # where each group (top digit) ends
    odd = (passes - 1) % 2 == 1         # (the groups' passes then end in keys, values)
    start = 0
    for d in range(ends.size):
        end = ends[d]
        if end - start < SMALL_SORT:
            _insertion(keys_out[start:end], values_out[start:end], top)
            if odd:
                for e in range(start, end):
                    keys[e] = keys_out[e]
                    values[e] = values_out[e]
        else:
            _passes(keys_out[start:end], values_out[start:end], keys[start:end],
                    values[start:end], 0, top, width, count)
        start = end
    return (keys, values) if odd else (keys_out, values_out)
