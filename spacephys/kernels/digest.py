"""A 64-bit hash of spans of a byte block (World.digest): integer arithmetic only, so every
CPU gives the same number for the same bytes.

Each 8-byte word (the last of a span zero-padded) is mixed in with the round of MurmurHash3's
64-bit variant (Appleby, public domain), in four lanes (word j into lane j mod 4, as xxHash
does, so the multiplications of the four run side by side), each span's length after its
words, and the result goes through the SplitMix64 finaliser (Steele, Lea & Flood 2014), so
that one flipped bit anywhere changes about half the bits of the digest.
"""
import numpy as np

from .._jit import kernel

_C1 = np.uint64(0x87C37B91114253D5)
_C2 = np.uint64(0x4CF5AD432745937F)
_M = np.uint64(5)
_N = np.uint64(0x52DCE729)
_F1 = np.uint64(0xBF58476D1CE4E5B9)
_F2 = np.uint64(0x94D049BB133111EB)
_BYTE = np.uint64(8)
_ONE = np.uint64(1)


@kernel(inline=True)
def _rotl(x, r):
    return (x << np.uint64(r)) | (x >> np.uint64(64 - r))


@kernel(inline=True)
def _mix(h, k):
    k = _rotl(k * _C1, 31) * _C2
    h = h ^ k
    return _rotl(h, 27) * _M + _N


@kernel(inline=True)
def fold(h, words, starts, lengths):
    """h (uint64) with the bytes [starts[s], starts[s] + lengths[s]) of `words`' bytes mixed
    in, span after span; words : (W,) uint64 (little-endian bytes), starts : (S,) int64
    multiples of 8, lengths : (S,) int64 bytes. Four lanes take every fourth word (four
    chains of multiplications side by side instead of one), joined at the end."""
    h1 = h ^ _C1
    h2 = h ^ _C2
    h3 = h ^ _N
    for s in range(starts.shape[0]):
        first = starts[s] // 8
        full = lengths[s] // 8
        quads = full - full % 4
        for j in range(0, quads, 4):
            h = _mix(h, words[first + j])
            h1 = _mix(h1, words[first + j + 1])
            h2 = _mix(h2, words[first + j + 2])
            h3 = _mix(h3, words[first + j + 3])
        for j in range(quads, full):
            h = _mix(h, words[first + j])
        tail = lengths[s] - 8 * full
        if tail:
            keep = (_ONE << (np.uint64(tail) * _BYTE)) - _ONE
            h = _mix(h, words[first + full] & keep)
        h = _mix(h, np.uint64(lengths[s]))
    return _mix(_mix(_mix(h, h1), h2), h3)


@kernel(inline=True)
def _finish(h):
    """The SplitMix64 finaliser of h (uint64)."""
    h = (h ^ (h >> np.uint64(30))) * _F1
    h = (h ^ (h >> np.uint64(27))) * _F2
    return h ^ (h >> np.uint64(31))


@kernel
def rows(seed, words, starts, row_bytes, n, slots, used, added, free):
    """The finished hash of seed[0] (seed: (1,) uint64) with the first n rows of each array
    of a block (words: the block as uint64; starts, row_bytes : (S,) int64 bytes), but `used`
    rows of its last `slots` arrays, then n, used, added and free (F,) int64 mixed in
    (state.Bodies.digest)."""
    lengths = np.empty_like(row_bytes)
    for s in range(row_bytes.shape[0]):
        lengths[s] = row_bytes[s] * (used if s >= row_bytes.shape[0] - slots else n)
    h = fold(seed[0], words, starts, lengths)
    h = _mix(_mix(_mix(h, np.uint64(n)), np.uint64(used)), np.uint64(added))
    for c in range(free.shape[0]):
        h = _mix(h, np.uint64(free[c]))
    return _finish(_mix(h, np.uint64(free.shape[0])))
