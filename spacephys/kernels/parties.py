"""Who an event's two bodies were: their kinds and tags written into the event while the
bodies are still there (the step driver calls it after each kernel call, before the bodies a
collision destroyed or merged away leave)."""
from .._jit import kernel
from .state import row_of


@kernel
def name_bodies(events, first, count, index, ids, kind, tag):
    """events[first:count] (spacephys.EVENT_DTYPE) given kind_a, kind_b (codes, -1 for no
    body) and tag_a, tag_b (0 for none) of their bodies a and b; index, ids : the World's
    slot -> row table and id column; kind (n,) int16, tag (n,) int64, or (0,) when no body
    has one."""
    for e in range(first, count):
        i = row_of(index, ids, events[e].a)
        j = row_of(index, ids, events[e].b)
        events[e].kind_a = kind[i] if i >= 0 else -1
        events[e].kind_b = kind[j] if j >= 0 else -1
        events[e].tag_a = tag[i] if i >= 0 and tag.size else 0
        events[e].tag_b = tag[j] if j >= 0 and tag.size else 0
