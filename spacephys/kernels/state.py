"""What a step kernel moves and writes: the `State` table (a numba structref).

Positions, velocities and masses of the live bodies, the positions before the last step (for
render interpolation), which bodies are still alive, per-body scratch the step sequence
reuses, and the event buffer every part of the step appends to. spacephys/world.py builds one
per set of bodies; its arrays are views of the World's columns, so a step changes the World in
place and a change made between steps (set_body, control) is seen by the next step.
"""
from collections import namedtuple

import numpy as np
from numba.experimental import structref

from .._jit import TableType, kernel, read


@structref.register
class StateType(TableType):
    pass


class State(structref.StructRefProxy):
    """The step kernels' state table (see the module)."""


FIELDS = (
    "pos", "vel",      # (n, 3) float64 [length], [length/time], updated in place
    "prev",            # (n, 3) positions before the last step of a call (interpolation)
    "mass",            # (n,) float64 [mass]: thrust burns it, merges move it
    "ids",             # (n,) int64 body ids, for the events
    "alive",           # (n,) bool: False once destroyed or merged away (World removes it)
    "acc",             # (n, 3) scratch: accelerations
    "pos0", "vel0",    # (n, 3) the state at the start of the step (collisions, undo)
    "events",          # (E,) spacephys.EVENT_DTYPE: the buffer, grown (replaced) when full
    "count",           # (1,) int64: events written
    "dim",             # 2 or 3
)
structref.define_proxy(State, StateType, list(FIELDS))


# the arrays the per-step functions move, read once before a kernel's step loop (step.hoist);
# not the event buffer, which a kernel may replace when it grows it
StateArrays = namedtuple("StateArrays", ("pos", "vel", "prev", "mass", "alive", "pos0", "vel0",
                                         "acc"))


@kernel(inline=True)
def hoist(state):
    """The State's arrays as a StateArrays tuple."""
    return read(state, StateArrays)


@kernel
def _make(*fields):
    return State(*fields)


def make(**fields):
    """A State over the arrays named as in FIELDS (shared, not copied)."""
    fields["dim"] = int(fields["dim"])
    return _make(*(fields[name] for name in FIELDS))


_SLOT_MASK = (1 << 32) - 1                # an id's slot (state.py: (generation << 32) | slot)


@kernel(inline=True)
def row_of(index, ids, body_id):
    """The row of a body id, -1 if it names no body now (-1 included): index (slots,) the
    World's slot -> row table, ids the id column."""
    slot = body_id & _SLOT_MASK
    if slot >= index.size:
        return -1
    r = index[slot]
    return r if r >= 0 and ids[r] == body_id else -1


@kernel
def events_of(state):
    """The event buffer: a new array once a kernel grew it."""
    return state.events


@kernel
def record(state, kind, a, b, time, t_in_step, point, normal, speed, lost, distance):
    """Append an event (ids a, b; -1 for none) to the buffer, doubling it when full."""
    k = state.count[0]
    buf = state.events
    if k >= buf.shape[0]:
        grown = np.zeros(2 * buf.shape[0] + 16, dtype=buf.dtype)
        for q in range(buf.shape[0]):                  # a loop: compiles 3 s faster
            grown[q] = buf[q]
        state.events = grown
        buf = grown
    ev = buf[k]
    ev.kind = kind
    ev.a = a
    ev.b = b
    ev.time = time
    ev.t_in_step = t_in_step
    ev.x = point[0]
    ev.y = point[1]
    ev.z = point[2]
    ev.nx = normal[0]
    ev.ny = normal[1]
    ev.nz = normal[2]
    ev.speed = speed
    ev.energy_lost = lost
    ev.distance = distance
    ev.circle_a = -1                                   # kernels/shapes.name names them
    ev.circle_b = -1
    state.count[0] = k + 1
