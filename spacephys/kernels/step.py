"""One step, written once: the loop every integrator family runs, and the sequence around
each step's integration.

    run(state, forces, rules, actors, frames, method, dt, nsteps, t0) -> (steps done, status)

is the one step kernel (steppers.Plan calls it). `method` is a family's table, a namedtuple
whose type names the family (integrate.Splitting, integrate.RungeKutta,
gauss_radau.GaussRadau, wisdom_holman.WisdomHolman); the family gives only its integration,
`register`ed here and chosen by numba from that type when it compiles:

    start(method, state, fx, actors) -> carry    its scratch for the call
    span(method, every, frames, frame, done, n)   steps the next round takes (default 1;
                                                  Wisdom-Holman's runs between syncs)
    advance(method, carry, sa, burns, fx, t, dt, k, kicked, played) -> ok
                                                  k steps' integration from t; False: failed
                                                  (sa: the state's arrays, hoist; burns:
                                                  the actors' rows and this step's burns,
                                                  or None without actors)
    finish(method, carry)                         what the family carries to the next call

Around each round run does, for every family:

    hoist(...)      once before the loop: the tables' arrays as one tuple ht, which the
                    per-step functions take (compiled without reference counting, _jit lean:
                    an array read or handed on inside the loop costs two atomic updates)
    begin(...)      prev <- pos on the call's last step (render interpolation); the state at
                    the step's start kept (collisions need the lines, undo the state); actors
                    turned and their burns set
    the tape        a prediction's tape plays the pulling bodies or records them
                    (kernels/tape.py; None elsewhere, and compiled out)
    <advance>       the family's integration
    rails.settle    the bodies on rails where their orbits have them at the round's end
    the NaN check   for a family that undoes a non-finite round (Wisdom-Holman)
    undo(...)       a failed round taken back (Gauss-Radau, Wisdom-Holman)
    tethers.settle  inextensible tethers' drift projected away; tethers pulling past their
                    break force break (kernels/tethers.py)
    end(...)        fuel booked, collisions found and resolved, fuses and lifetimes; True
                    when bodies died (the call then stops so that World can remove them)
    capture(...)    a recording's frame, when one falls due after this step
    status(...)     what the call reports: REMOVED, NONFINITE (the NaN check: one pass)

`rules` (kernels/rules.Rules) and `actors` (kernels/control.Actors) are None when a scene has
no collisions or no ships, missiles and lifetimes: numba then compiles a kernel without that
code at all (its branches are pruned on the argument's type), so a gravity-only scene neither
compiles nor runs it. `frames` is None, or (frame_at, fpos, fvel, fmass): the step counts of
this call after which to copy the state into fpos[k], fvel[k] (F, n, 3) and fmass[k] (F, n).
"""

from collections import namedtuple

import numpy as np
from numba import types

from .._jit import implements, is_table, kernel
from . import control
from . import rails
from . import state as kstate
from . import tape
from . import tethers
from .arrays import copy_into
from .codes import BODIES_GONE, FAILED, NONFINITE, REMOVED
from .forces import hoist as hoist_forces, implements_by_users
from .collide import collide_step
from .shapes import keep_start
from .rules import periods as box_periods
from .control import after_step, begin_step, end_burn, flush, undo_turns


@kernel
def periods(rules):
    """The box lengths of a wrapping boundary per axis (a 3-tuple: no allocation per step),
    zeros without one."""
    if rules is None:
        return 0.0, 0.0, 0.0
    L = box_periods(rules)
    return L[0], L[1], L[2]


# what a step kernel reads of its tables once per call (hoist): the state's arrays
# (state.StateArrays), the collision table's owners (None without actors, empty without
# collisions: only arming reads them), the actors' arrays (control.ActorArrays; None without
# actors), whether something reads the state at each step's start (the collisions' swept
# lines, a proximity fuse)
Hoisted = namedtuple("Hoisted", ("state", "owner", "actors", "starts"))


@kernel(inline=True)
def hoist(state, rules, actors):
    """The tables' arrays as a Hoisted tuple ht, read once per kernel call. The inlined
    functions below only hand ht on; reading its arrays here would cost their reference
    counts."""
    aa = _actor_arrays(actors)
    return Hoisted(kstate.hoist(state), _owners(rules, actors), aa,
                   rules is not None or _fused(aa))


# Each of these has one body for None (the scene has no actors) and one for the table: a
# function with `if x is None: return None` compiled for a table would return an optional
# (numba unifies the two returns), which every later use unwraps at run time.
def _actor_arrays(actors):
    """The actors' arrays (control.ActorArrays), or None without actors."""


def _owners(rules, actors):
    """The collision table's owners, empty without collisions; None without actors."""


def _burns(aa):
    """(the actors' rows, their burns (control.begin_step)), or None without actors: what
    the families' integration reads of the actors (handed on, a tuple of two arrays costs
    less than all of the actors' arrays)."""


def _none(*args):
    return None


def _when_none(t, *rest):
    return isinstance(t, types.NoneType)


def _when_not_none(t, *rest):
    return not isinstance(t, types.NoneType)


# inlined: a function returning the actors' arrays would count each one's references once more
implements(_actor_arrays, _none, _when_none)
implements(_actor_arrays, lambda actors: control.hoist(actors), _when_not_none, inline=True)
implements(_owners, _none, lambda rules, actors: isinstance(actors, types.NoneType))
implements(_owners, lambda rules, actors: np.empty(0, np.int64),
           lambda rules, actors: isinstance(rules, types.NoneType)
           and not isinstance(actors, types.NoneType), inline=True)
implements(_owners, lambda rules, actors: rules.owner,
           lambda rules, actors: not isinstance(rules, types.NoneType)
           and not isinstance(actors, types.NoneType), inline=True)
implements(_burns, _none, _when_none)
implements(_burns, lambda aa: (aa.actors, aa.burn), _when_not_none, inline=True)


@kernel(lean=True)
def _fused(aa):
    """Whether an actor has a proximity fuse (it reads the step's start state)."""
    if aa is None:
        return False
    for q in range(aa.actors.size):
        if aa.fuse[aa.actors[q]] > 0.0:
            return True
    return False


@kernel(inline=True)
def begin(state, rules, actors, ht, t0, dt, keep, last):
    """Before a step's integration (see the module). keep: save the start state even without
    collisions or actors (the family may undo the step); last: the call's last step."""
    _keep(ht, keep or ht.starts, last)       # the start state: for an undo, or ht.starts
    if actors is not None:
        _keep_orientations(rules)
        begin_step(state, ht.owner, actors, t0, dt, periods(rules))


@kernel
def _keep_orientations(rules):
    """The compound bodies' orientations at the step's start (kernels/shapes.py)."""
    if rules is None:
        return
    keep_start(rules.shapes)


@kernel(lean=True)
def _keep(ht, keep, last):
    """prev <- pos on the last step; pos0, vel0 <- pos, vel when keep."""
    sa = ht.state
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
        removed = collide_step(state, rules, dt, t0) == BODIES_GONE
    if actors is not None:
        died, m = after_step(state, actors, t0, dt, periods(rules))
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
        sa = ht.state
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
    velocity is NaN or infinite."""
    return (REMOVED if removed else 0) | (0 if finite(state.pos, state.vel) else NONFINITE)


@kernel(lean=True)
def finite(pos, vel):
    """Whether every position and velocity is finite (x * 0 is 0 for finite x, NaN
    otherwise: one pass)."""
    s = 0.0
    for i in range(pos.shape[0]):
        s += (pos[i, 0] * 0.0 + pos[i, 1] * 0.0 + pos[i, 2] * 0.0
              + vel[i, 0] * 0.0 + vel[i, 1] * 0.0 + vel[i, 2] * 0.0)
    return s == 0.0


# ----------------------------------------------------------------------------- the families

def start(method, state, fx, actors):
    """The family's scratch for one call (see the module)."""


def span(method, every, frames, frame, done, nsteps):
    """Steps the next round takes (see the module)."""


def advance(method, carry, sa, burns, fx, t, dt, k, kicked, played):
    """k steps' integration from time t; False when it failed (see the module)."""


def finish(method, carry):
    """What the family carries from this call to the next, written back."""


def keeps(method):
    """Whether begin keeps each round's start state, for an undo."""


def undoes_nonfinite(method):
    """Whether a round that leaves a position or velocity NaN or infinite fails (undone)."""


def _one(method, every, frames, frame, done, nsteps):
    return 1


def _nothing(method, carry):
    pass


def register(table, *, start_, advance_, span_=_one, finish_=_nothing, keep=False,
             nonfinite_fails=False, **options):
    """An integrator family: its table's namedtuple type and its functions (plain Python
    functions with the protocol's arguments); advance_ is compiled with _jit.kernel's
    options (lean: without reference counts, but with them for a force table with user
    forces, see forces.implements_by_users), the others as the step kernel is."""
    def mine(t, *rest):
        return is_table(t, table)
    implements(start, start_, mine)
    if options.get("lean"):
        implements_by_users(advance, advance_, mine, 4, **options)
    else:
        implements(advance, advance_, mine, **options)
    implements(span, span_, mine, lean=True)
    implements(finish, finish_, mine, lean=True)
    implements(keeps, (lambda method: True) if keep else (lambda method: False), mine)
    implements(undoes_nonfinite, (lambda method: True) if nonfinite_fails else
               (lambda method: False), mine)


@kernel(parallel=True)
def run(state, forces, rules, actors, frames, method, dt, nsteps, t0):
    """The step kernel: nsteps steps of dt from t0 with the family of `method` (see the
    module). Returns (steps taken, status): fewer than nsteps when a collision, a
    detonation or an expiry removed or merged bodies (REMOVED), or when the family failed
    (FAILED: the state is that after the steps reported)."""
    fx = hoist_forces(forces)
    ht = hoist(state, rules, actors)
    sa, burns = ht.state, _burns(ht.actors)
    carry = start(method, state, fx, actors)
    keep = keeps(method)
    checked = undoes_nonfinite(method)
    every = rules is not None or actors is not None
    # a variable, not the expression in the call: with `rules is not None` written into the
    # tape.collided call, the compiled kernel entered the force loop's parallel region (no
    # work) on every call of a 3-body scene (seen in gdb; tests/test_jit.py guards it)
    collisions = rules is not None
    everyone, passive, src = fx.everyone, fx.passive, fx.src
    pos, vel, mass = state.pos, state.vel, state.mass
    kicked, was = everyone, False
    frame = 0
    done = 0
    removed = False
    while done < nsteps:
        k = span(method, every, frames, frame, done, nsteps)
        t = rails.now(fx.rails, t0, done, dt)
        begin(state, rules, actors, ht, t, dt, keep, done + k == nsteps)
        played = tape.playing(fx.tape)       # a prediction's tape (kernels/tape.py)
        if played != was:           # rebound only when it changes: a rebinding costs refcounts
            kicked, was = (passive if played else everyone), played
        ok = advance(method, carry, sa, burns, fx, t, dt, k, kicked, played)
        if checked and ok:
            ok = finite(pos, vel)
        if not ok:
            # the failed round taken back: the state is that after `done` steps, as the
            # actors' fuel and the collisions already booked say
            undo(state, actors)
            finish(method, carry)
            return done, status(state, False) | FAILED
        rails.settle(fx.rails, done + k, dt, pos, vel)  # the bodies on rails, exact
        tape.integrated(fx.tape, src, pos, vel, mass, played)
        tethers.settle(fx.tethers, state, t, dt)
        removed = end(state, rules, actors, ht, t, dt)
        tape.collided(fx.tape, src, pos, vel, mass, played, collisions)
        done += k
        frame = capture(frames, frame, done, ht)
        if removed:
            break
    finish(method, carry)
    return done, status(state, removed)
