"""The sequence around every step's integration, written once and called by all four families.

    hoist(...)      once before the step loop: the tables' arrays as one tuple ht, which the
                    per-step functions take (compiled without reference counting, _jit lean:
                    an array read or handed on inside the loop costs two atomic updates)
    begin(...)      prev <- pos on the call's last step (render interpolation); the state at
                    the step's start kept (collisions need the lines, undo the state); actors
                    turned and their burns set
    <integration>   the family's own: drifts and kicks, stages, Gauss-Radau substeps, Kepler
    end(...)        fuel booked, collisions found and resolved, fuses and lifetimes; True
                    when bodies died (the call then stops so that World can remove them)
    capture(...)    a recording's frame, when one falls due after this step
    undo(...)       a failed step taken back (Gauss-Radau, Wisdom-Holman)
    status(...)     what the call reports: REMOVED, NONFINITE (the NaN check: one pass)

`rules` (kernels/collide.Rules) and `actors` (kernels/control.Actors) are None when a scene has
no collisions or no ships, missiles and lifetimes: numba then compiles a kernel without that
code at all (its branches are pruned on the argument's type), so a gravity-only scene neither
compiles nor runs it. `frames` is None, or (frame_at, fpos, fvel, fmass): the step counts of
this call after which to copy the state into fpos[k], fvel[k] (F, n, 3) and fmass[k] (F, n).
"""

import numpy as np

from .._jit import kernel
from . import control
from . import state as kstate
from .arrays import copy_into
from .codes import NONFINITE, REMOVED
from .collide import _periods, collide_step
from .control import after_step, begin_step, end_burn, flush, undo_turns


@kernel
def periods(rules):
    """The box lengths of a wrapping boundary per axis (a 3-tuple: no allocation per step),
    zeros without one."""
    if rules is None:
        return 0.0, 0.0, 0.0
    L = _periods(rules)
    return L[0], L[1], L[2]


@kernel(inline=True)
def hoist(state, rules, actors):
    """ht = (the state's arrays (state.StateArrays), the collision table's owners (None
    without actors, empty without collisions: only arming reads them), the actors' arrays (control.ActorArrays; None without actors), whether
    something reads the state at each step's
    start (the collisions' swept lines, a proximity fuse)): read once per kernel call. The
    inlined functions below only hand ht on; reading its arrays here would cost their
    reference counts."""
    sa = kstate.hoist(state)
    starts = rules is not None
    if actors is None:
        return sa, None, None, starts
    owner = np.empty(0, np.int64) if rules is None else rules.owner
    aa = control.hoist(actors)
    for q in range(aa.actors.size):
        starts = starts or aa.fuse[aa.actors[q]] > 0.0
    return sa, owner, aa, starts


@kernel(inline=True)
def begin(state, rules, actors, ht, t0, dt, keep, last):
    """Before a step's integration (see the module). keep: save the start state even without
    collisions or actors (the family may undo the step); last: the call's last step."""
    _keep(ht, keep or ht[3], last)            # the start state: for an undo, or ht[3]
    if actors is not None:
        begin_step(ht, t0, dt, periods(rules))


@kernel(lean=True)
def _keep(ht, keep, last):
    """prev <- pos on the last step; pos0, vel0 <- pos, vel when keep."""
    sa = ht[0]
    if last:
        copy_into(sa.prev, sa.pos)
    if keep:
        copy_into(sa.pos0, sa.pos)
        copy_into(sa.vel0, sa.vel)


@kernel(inline=True)
def end(state, rules, actors, ht, t0, dt):
    """After a step's integration: fuel, collisions, fuses and lifetimes. True when bodies
    died or merged away (state.alive): the kernel returns so that World can catch up."""
    removed = False
    if actors is not None:
        m = end_burn(ht, t0, dt)
        if m:
            flush(state, ht, m, t0)
    if rules is not None:
        removed = collide_step(state, rules, dt, t0) == 2
    if actors is not None:
        died, m = after_step(ht, t0, dt, periods(rules))
        if m:
            flush(state, ht, m, t0)
        removed = removed or died
    return removed


@kernel(lean=True)
def capture(frames, k, done, ht):
    """When frames[0][k] == done (steps done in this call), copy the state into frame k.
    Returns the index of the next frame to take."""
    if frames is None:
        return k
    frame_at, fpos, fvel, fmass = frames
    if k < frame_at.size and frame_at[k] == done:
        sa = ht[0]
        pos, vel, mass = sa.pos, sa.vel, sa.mass
        for i in range(mass.size):
            for c in range(3):
                fpos[k, i, c] = pos[i, c]
                fvel[k, i, c] = vel[i, c]
            fmass[k, i] = mass[i]
        return k + 1
    return k


@kernel
def next_frame(frames, k, nsteps):
    """The step count of this call at which frame k falls due (nsteps if none does)."""
    if frames is None:
        return nsteps
    frame_at = frames[0]
    return frame_at[k] if k < frame_at.size else nsteps


@kernel
def undo(state, actors):
    """Take the step begun last back: the state and the actors' turns as begin found them."""
    copy_into(state.pos, state.pos0)
    copy_into(state.vel, state.vel0)
    if actors is not None:
        undo_turns(actors)


@kernel
def status(state, removed):
    """The call's status bits: REMOVED when bodies died, NONFINITE when any position or
    velocity is NaN or infinite (x * 0 is 0 for finite x, NaN otherwise: one pass)."""
    s = 0.0
    pos, vel = state.pos, state.vel
    for i in range(pos.shape[0]):
        s += (pos[i, 0] * 0.0 + pos[i, 1] * 0.0 + pos[i, 2] * 0.0
              + vel[i, 0] * 0.0 + vel[i, 1] * 0.0 + vel[i, 2] * 0.0)
    return (REMOVED if removed else 0) | (0 if s == 0.0 else NONFINITE)
