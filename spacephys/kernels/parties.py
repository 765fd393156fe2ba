"""Who an event's two bodies were: their kinds and tags written into the event while the
bodies are still there (the step driver calls it after each kernel call, before the bodies a
collision destroyed or merged away leave)."""
import numpy as np

from .._jit import kernel

_SLOT_BITS = np.int64(32)
_SLOT_MASK = np.int64((1 << 32) - 1)


@kernel(inline=True)
def _row(body, generation, index, slots_used):
    """The row of the generational id `body`, -1 when it names no live body (state.Bodies.
    lookup for one id)."""
    if body < 0:
        return -1
    slot = body & _SLOT_MASK
    if slot >= slots_used or generation[slot] != body >> _SLOT_BITS:
        return -1
    return index[slot]


@kernel
def name_bodies(events, first, count, generation, index, slots_used, kind, tag):
    """events[first:count] (spacephys.EVENT_DTYPE) given kind_a, kind_b (codes, -1 for no
    body) and tag_a, tag_b (0 for none) of their bodies a and b; generation, index : the id
    slots' (state.Bodies); kind (n,) int16, tag (n,) int64, or (0,) when no body has one."""
    for e in range(first, count):
        i = _row(events[e].a, generation, index, slots_used)
        j = _row(events[e].b, generation, index, slots_used)
        events[e].kind_a = kind[i] if i >= 0 else -1
        events[e].kind_b = kind[j] if j >= 0 else -1
        events[e].tag_a = tag[i] if i >= 0 and tag.size else 0
        events[e].tag_b = tag[j] if j >= 0 and tag.size else 0
