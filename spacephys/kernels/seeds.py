"""The seeds of explosions' generators, many at once (blast_generators).

Each blast draws from numpy's PCG64 seeded by SeedSequence([world seed, id & 0xFFFFFFFF,
id >> 32]) (actors.spawn_debris). Building that SeedSequence and generator costs ~20 us a
blast, most of a step's debris when 17 ships and missiles blow up at once. seed_words computes
the same SeedSequence state for every blast in one call, from the published algorithm (M.
O'Neill's seed_seq_fe hashing, as numpy documents SeedSequence); tests/test_actors.py holds it
to numpy's bit for bit.
"""
import numpy as np

from .._jit import kernel

_M = np.uint64(0xFFFFFFFF)
_INIT_A, _MULT_A = np.uint64(0x43B0D7E5), np.uint64(0x931E8875)
_INIT_B, _MULT_B = np.uint64(0x8B51F9DD), np.uint64(0x58F38DED)
_MIX_L, _MIX_R = np.uint64(0xCA01F9DD), np.uint64(0x4973F715)
_SHIFT, _HIGH = np.uint64(16), np.uint64(32)


@kernel(inline=True)
def _hashmix(value, h):
    """(value hashed, the next hash constant): 32-bit arithmetic in uint64."""
    value = value ^ h
    h = (h * _MULT_A) & _M
    value = (value * h) & _M
    return value ^ (value >> _SHIFT), h


@kernel(inline=True)
def _mix(x, y):
    r = ((_MIX_L * x) - (_MIX_R * y)) & _M     # (uint64 wraps mod 2^64: mod 2^32 after)
    return r ^ (r >> _SHIFT)


@kernel
def seed_words(entropy_head, ids):
    """(k, 4) uint64: SeedSequence(words).generate_state(4, np.uint64) for each row's words =
    entropy_head (the seed's 32-bit words, low first, as uint64) + [ids[q] & 0xFFFFFFFF,
    ids[q] >> 32]; ids (k,) int64 >= 0."""
    head = entropy_head.size
    size = head + 2
    entropy = np.empty(size, np.uint64)
    pool = np.empty(4, np.uint64)
    words = np.empty(8, np.uint64)
    out = np.empty((ids.size, 4), np.uint64)
    for w in range(head):
        entropy[w] = entropy_head[w]
    for q in range(ids.size):
        entropy[head] = np.uint64(ids[q]) & _M
        entropy[head + 1] = np.uint64(ids[q]) >> _HIGH
        h = _INIT_A
        for i in range(4):                         # the pool: the first words, hashed
            pool[i], h = _hashmix(entropy[i] if i < size else np.uint64(0), h)
        for s in range(4):                         # mixed with each other
            for d in range(4):
                if s != d:
                    v, h = _hashmix(pool[s], h)
                    pool[d] = _mix(pool[d], v)
        for s in range(4, size):                   # and with the words past the pool
            for d in range(4):
                v, h = _hashmix(entropy[s], h)
                pool[d] = _mix(pool[d], v)
        hb = _INIT_B
        for i in range(8):                         # the state: 8 words out of the pool
            v = pool[i % 4] ^ hb
            hb = (hb * _MULT_B) & _M
            v = (v * hb) & _M
            words[i] = v ^ (v >> _SHIFT)
        for j in range(4):                         # uint64 words, low half first
            out[q, j] = words[2 * j] | (words[2 * j + 1] << _HIGH)
    return out


_PCG_MULT = 0x2360ED051FC65DA44385DF649FCCF645      # PCG64's 128-bit multiplier
_M128 = (1 << 128) - 1


def blast_generators(seed, ids):
    """For each body id in turn, a numpy Generator that draws exactly as
    np.random.default_rng([seed, id & 0xFFFFFFFF, id >> 32]) would (an explosion is the
    same every run): one generator re-seeded in place (a fresh one costs 20 us a blast).
    seed : int >= 0; ids : the blasts' body ids. Use each before taking the next."""
    head = [seed & 0xFFFFFFFF]                       # the seed's 32-bit words, low first
    seed >>= 32
    while seed:
        head.append(seed & 0xFFFFFFFF)
        seed >>= 32
    words = seed_words(np.array(head, np.uint64), np.array(ids, np.int64)).tolist()
    bits = np.random.PCG64(0)
    generator = np.random.Generator(bits)
    for s0, s1, i0, i1 in words:
        # PCG64 seeded by those words (its published seeding): an odd increment from the
        # second pair, the state stepped twice around the first
        inc = ((((i0 << 64) | i1) << 1) | 1) & _M128
        state = ((inc + ((s0 << 64) | s1)) * _PCG_MULT + inc) & _M128
        bits.state = {"bit_generator": "PCG64", "state": {"state": state, "inc": inc},
                      "has_uint32": 0, "uinteger": 0}
        yield generator
