"""A 64-bit hash of spans of a byte block (World.digest): integer arithmetic only, so every
CPU gives the same number for the same bytes.

The spans are gathered into one stream of 8-byte words (each span's last word zero-padded),
followed by the numbers that say how long they are. The stream is taken 64 words at a time:
each word is keyed by its place in the block (xor with one of 64 fixed random words) and the
block summed two ways, the products of each keyed word's two 32-bit halves (the NH hash of
UMAC, as XXH3 uses it) and the words themselves (so that a word whose half keys to zero still
counts). Integer sums come out the same in any order, so the compiler may spread them over
vector lanes of any width without changing a bit. Each block's two sums are mixed into the
hash in order with the round of MurmurHash3's 64-bit variant (Appleby, public domain), and
the result goes through the SplitMix64 finaliser (Steele, Lea & Flood 2014), so that one
flipped bit anywhere changes about half the bits of the digest.
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
_ZERO = np.uint64(0)
_LOW = np.uint64(0xFFFFFFFF)
_HALF = np.uint64(32)
BLOCK = 64


def _splitmix64(seed, count):
    """count words of the SplitMix64 generator from seed, as a (count,) uint64 array."""
    out, mask = [], (1 << 64) - 1
    for _ in range(count):
        seed = (seed + 0x9E3779B97F4A7C15) & mask
        z = ((seed ^ (seed >> 30)) * 0xBF58476D1CE4E5B9) & mask
        z = ((z ^ (z >> 27)) * 0x94D049BB133111EB) & mask
        out.append(z ^ (z >> 31))
    return np.array(out, np.uint64)


KEY = _splitmix64(0x5350414345504859, BLOCK)  # the words keying a block's places


@kernel(inline=True)
def _rotl(x, r):
    return (x << np.uint64(r)) | (x >> np.uint64(64 - r))


@kernel(inline=True)
def _mix(h, k):
    k = _rotl(k * _C1, 31) * _C2
    h = h ^ k
    return _rotl(h, 27) * _M + _N


@kernel(inline=True)
def _finish(h):
    """The SplitMix64 finaliser of h (uint64)."""
    h = (h ^ (h >> np.uint64(30))) * _F1
    h = (h ^ (h >> np.uint64(27))) * _F2
    return h ^ (h >> np.uint64(31))


@kernel(inline=True)
def fold(h, stream):
    """h (uint64) with the words of stream ((W,) uint64), block by block, and W mixed in."""
    for b in range(0, stream.shape[0], BLOCK):
        block = stream[b:b + BLOCK]           # a view: its indices are known to be in range
        products = _ZERO
        words = _ZERO
        for j in range(block.shape[0]):
            keyed = block[j] ^ KEY[j]
            products += (keyed & _LOW) * (keyed >> _HALF)
            words += block[j]
        h = _mix(_mix(h, products), words)
    return _mix(h, np.uint64(stream.shape[0]))


@kernel
def rows(seed, words, starts, row_bytes, n, slots, used, added, free):
    """The finished hash of seed (uint64) with the first n rows of each array
    of a block (words: the block as uint64; starts, row_bytes : (S,) int64 bytes), but `used`
    rows of its last `slots` arrays, then the row sizes, n, used, added and free (F,) int64
    (state.Bodies.digest)."""
    spans = row_bytes.shape[0]
    size = spans + 4 + free.shape[0]
    for s in range(spans):
        size += (row_bytes[s] * (used if s >= spans - slots else n) + 7) // 8
    stream = np.empty(size, np.uint64)
    k = 0
    for s in range(spans):
        length = row_bytes[s] * (used if s >= spans - slots else n)
        first = starts[s] // 8
        full = length // 8
        span = words[first:first + full]
        out = stream[k:k + full]
        for j in range(full):
            out[j] = span[j]
        k += full
        tail = length - 8 * full
        if tail:
            stream[k] = words[first + full] & ((_ONE << (np.uint64(tail) * _BYTE)) - _ONE)
            k += 1
    for s in range(spans):
        stream[k + s] = np.uint64(row_bytes[s])
    k += spans
    stream[k] = np.uint64(n)
    stream[k + 1] = np.uint64(used)
    stream[k + 2] = np.uint64(added)
    stream[k + 3] = np.uint64(free.shape[0])
    k += 4
    for c in range(free.shape[0]):
        stream[k + c] = np.uint64(free[c])
    return _finish(fold(seed, stream))
