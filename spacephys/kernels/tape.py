"""The tape: the pulling bodies' future, recorded by one prediction and played back by the next
(spacephys/tape.py decides when; a prediction's copy only: every other force table has none,
and its kernels compile none of this).

Recording, a step stores the pulling bodies' sources (x, y, z, m) at each of its force
evaluations (`sources`) and their positions, velocities and masses after its integration and
again after its collisions. Playing back, a step kicks only the passive bodies, from the
recorded sources, and puts the pulling bodies where the tape has them before the collisions:
the passive bodies' sums are the ones a full step makes from the same numbers, so the paths
are the full run's, bit for bit, at the cost of the passive bodies alone. When the collisions
leave a pulling body elsewhere than the recording's did (this prediction's bodies hit it, or
missed it, otherwise) the tape stops for the rest of the call.

`TapeArrays` (the copy's force table holds it; spacephys/tape.py makes it, and a new one when
its arrays grow): `tape` (E, 4, ns), `ends` (T, ns, 14): pos, vel, mass after the integration,
then after the collisions; `at` (5,) int64: [on, step (index into the tape), valid (steps
recorded), evaluations per step, evaluation (the next one's index)]. The hooks take it, or
None (no tape), for which they return at once.
"""
from collections import namedtuple

from .._jit import kernel

ON, STEP, VALID, PER_STEP, EVAL = range(5)


FIELDS = ("tape", "ends", "at")
TapeArrays = namedtuple("TapeArrays", FIELDS)


@kernel(lean=True)
def playing(tape):
    """At a step's start: whether the tape plays this step back; points it at the step's first
    evaluation."""
    if tape is None:
        return False
    at = tape.at
    if at[ON] == 0:
        return False
    at[EVAL] = at[STEP] * at[PER_STEP]
    return at[STEP] < at[VALID]


@kernel(lean=True, forceinline=True)
def sources(tape, scratch, src, pos, mass):
    """The pulling bodies' x, y, z, m for a force evaluation into scratch (4, ns): gathered
    from pos, mass (rows src), or, on a played step, copied from the tape; a recorded step
    writes the gathered ones onto the tape."""
    if tape is not None:
        at = tape.at
        if at[ON] != 0:
            e = at[EVAL]
            at[EVAL] = e + 1
            record = tape.tape
            if at[STEP] < at[VALID]:
                for r in range(4):
                    for a in range(src.size):
                        scratch[r, a] = record[e, r, a]
                return
            gather(src, pos, mass, scratch)
            if at[STEP] == at[VALID] and e < record.shape[0]:
                for r in range(4):
                    for a in range(src.size):
                        record[e, r, a] = scratch[r, a]
            return
    gather(src, pos, mass, scratch)


@kernel(lean=True, forceinline=True)
def gather(src, pos, mass, scratch):
    """The pulling bodies' x, y, z, m into scratch's rows 0-3 (separate contiguous rows, so
    that the force loops load them unit-stride)."""
    for a in range(src.size):
        k = src[a]
        scratch[0, a] = pos[k, 0]
        scratch[1, a] = pos[k, 1]
        scratch[2, a] = pos[k, 2]
        scratch[3, a] = mass[k]


@kernel(inline=True)
def _recording(tape, k):
    """Whether step k is being recorded: the next after the recorded ones, with room for it
    and for all its evaluations."""
    at = tape.at
    return at[VALID] == k and k < tape.ends.shape[0] and at[EVAL] <= tape.tape.shape[0]


@kernel(lean=True)
def integrated(tape, src, pos, vel, mass, played):
    """After a step's integration, before its collisions: a played step puts the pulling bodies
    (drifted, never kicked) where the tape has them; a recorded one writes them down."""
    if tape is None:
        return
    if tape.at[ON] == 0:
        return
    k = tape.at[STEP]
    if played:
        _read(tape.ends, k, src, pos, vel)
    elif _recording(tape, k):
        _write(tape.ends, k, 0, src, pos, vel, mass)


@kernel(lean=True)
def collided(tape, src, pos, vel, mass, played, collisions):
    """After the step's collisions (and a periodic box's wrap): a recorded step writes the
    pulling bodies down again; a played one stops the tape if they are not where the
    recording's collisions left them (this prediction's bodies acted otherwise; without
    collisions nothing moves them there). Counts the step."""
    if tape is None:
        return
    at = tape.at
    if at[ON] == 0:
        return
    k = at[STEP]
    if played:
        if collisions and not _same(tape.ends, k, 7, src, pos, vel, mass):
            at[ON] = 0
            return
    elif _recording(tape, k):
        _write(tape.ends, k, 7, src, pos, vel, mass)
        at[VALID] = k + 1
    at[STEP] = k + 1


@kernel(inline=True)
def _write(ends, k, col, src, pos, vel, mass):
    """The pulling bodies' pos, vel, mass into ends[k, :, col:col + 7]."""
    for a in range(src.size):
        i = src[a]
        for c in range(3):
            ends[k, a, col + c] = pos[i, c]
            ends[k, a, col + 3 + c] = vel[i, c]
        ends[k, a, col + 6] = mass[i]


@kernel(inline=True)
def _read(ends, k, src, pos, vel):
    """The pulling bodies' pos, vel from ends[k, :, 0:6]."""
    for a in range(src.size):
        i = src[a]
        for c in range(3):
            pos[i, c] = ends[k, a, c]
            vel[i, c] = ends[k, a, 3 + c]


@kernel(inline=True)
def _same(ends, k, col, src, pos, vel, mass):
    """Whether the pulling bodies' pos, vel, mass are ends[k, :, col:col + 7], bit for bit."""
    for a in range(src.size):
        i = src[a]
        if mass[i] != ends[k, a, col + 6]:
            return False
        for c in range(3):
            if pos[i, c] != ends[k, a, col + c] or vel[i, c] != ends[k, a, col + 3 + c]:
                return False
    return True
