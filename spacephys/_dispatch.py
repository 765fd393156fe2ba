"""Calling the step kernels without numba's per-call type resolution.

A numba dispatcher types every argument on each call; for the namedtuples of arrays the step
kernels take (collide.Setup, control.Control, arrays.Work: some 60 arrays) that costs about
120 us, twelve times the call itself, and a game calls step(1) every frame. fast_call keeps
the compiled entry point per argument signature, keyed by what decides an array's numba type
(dtype, ndim, contiguity, writeability, alignment), so that a repeated call with arguments of
the same types goes straight to the machine code.
"""
import numpy as np
from numba import typed


_ARRAY_FLAGS = 0x1 | 0x2 | 0x100 | 0x400     # C and F contiguous, aligned, writeable


def _key(value):
    """A hashable stand-in for value's numba type (None where it cannot tell)."""
    t = type(value)
    if t is np.ndarray:
        return value.dtype, value.ndim, value.flags.num & _ARRAY_FLAGS
    if t is float or t is int or t is bool or value is None:
        return t
    if isinstance(value, tuple):
        keys = tuple(map(_key, value))
        return None if None in keys else (t, keys)
    if t is typed.List:
        return value._numba_type_
    return None


def fast_call(dispatcher):
    """dispatcher(*args), through its cached entry point when args' types were seen."""
    entries = {}

    def call(*args):
        key = _key(args)
        entry = entries.get(key) if key is not None else None
        if entry is not None:
            return entry(*args)
        result = dispatcher(*args)          # types, compiles or loads as usual
        if key is not None:
            sig = tuple(dispatcher.typeof_pyval(a) for a in args)
            compiled = dispatcher.overloads.get(sig)
            if compiled is not None:
                entries[key] = compiled.entry_point
        return result

    call.dispatcher = dispatcher
    return call
