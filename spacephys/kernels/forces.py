"""The one force contract: every acceleration a body feels besides thrust, from one table.

`Forces` (a numba structref, built once per set of bodies by spacephys/forces.py) holds the
gravity model (kernels/gravity.py), the held per-body forces and accelerations
(World.apply_force, apply_acceleration), the user's jitted forces (World.add_force), drag
toward a wind, and whether the force loops may run on threads. Every integrator family asks
`accelerations` for the accelerations of the bodies it moves, at the positions (and
velocities) of its stage; nothing else computes forces.

What a scene does not have is None in the table (no held forces, no tethers, no user forces,
no drag, no prediction's tape, no threads), and so is its model's type: numba compiles `accelerations` for
the table's types, so a scene compiles the code of what it has and nothing else (a 2D
gravity-only scene never the tree, user forces, drag or the tape). A change that adds one (the
first held force, drag from 0) rebuilds the table (World drops its Plan).

Drag: a = -k (v - wind), drag = [k, wind (3,)]. The splitting methods and Wisdom-Holman apply
it exactly inside their kicks (kick); Runge-Kutta and Gauss-Radau add it at their stages
(`with_drag`). User forces: fn(t, pos, vel, mass, ids, params, out) adds accelerations of every
body to out (n, 3); see USER_FORCE.
"""
import math
from collections import namedtuple

import numpy as np
from numba import typed, types
from numba.experimental import structref

from .._jit import TableType, field_type, implements, kernel, read
from . import gravity
from . import libm
from . import rails as krails
from . import tethers as ktethers

# the signature of a user force: (t [time], pos (n, 3), vel (n, 3), mass (n,), ids (n,) int64,
# params (p,) float64, out (n, 3) accelerations to add to) -> None
USER_FORCE = types.void(types.float64, types.float64[:, ::1], types.float64[:, ::1],
                        types.float64[::1], types.int64[::1], types.float64[::1],
                        types.float64[:, ::1])
USER_FORCE_TYPE = types.FunctionType(USER_FORCE)

# the user forces of a table: fns, a typed List of USER_FORCE_TYPE; params, a typed List of
# (p,) float64, one per force; out (n, 3), the scratch they add into
UserForces = namedtuple("UserForces", ("fns", "params", "out"))


@structref.register
class ForcesType(TableType):
    pass


class Forces(structref.StructRefProxy):
    """The force table (see the module); made by `make`, read only by the kernels."""


FIELDS = (
    "gravity",     # a model of kernels/gravity.py (Direct, Uniform, Central, Tree), or None
    "mass",        # (n,) [mass]
    "ids",         # (n,) int64 body ids, for user forces
    "src",         # (ns,) int64 rows of the bodies that pull (Direct, Tree)
    "passive",     # (np,) int64 rows of the others
    "still",       # (k,) int64 rows of immovable bodies: their acceleration is zero
    "everyone",    # (n,) int64 rows 0..n-1
    "held",        # (n, 6) [force (3,) [mass length/time^2], acceleration (3,)], or None
    "user",        # UserForces, or None
    "drag",        # (4,) [k [1/time], wind (3,) [length/time]], shared with World; or None
    "tape",        # a prediction's tape (kernels/tape.TapeArrays), or None
    "threads",     # (1,) int64: the fewest pair evaluations a force loop runs on threads
                   # (World's ThreadChoice sets it between calls), or None: never (no
                   # threaded loop compiled)
    "tethers",     # kernels/tethers.TetherArrays, or None
    "rails",       # kernels/rails.RailsArrays: the bodies on rails, or None
)
structref.define_proxy(Forces, ForcesType, list(FIELDS))

# the table's fields read once before a step loop (hoist): a read of a structref's array
# field costs two atomic reference-count updates, and so does every array handed to a helper
# compiled with reference counts. The step loops hand this tuple to helpers compiled without
# them (_jit lean): 10 ns the pair here, 43% of a ship's prediction among 10 planets.
ForceArrays = namedtuple("ForceArrays", FIELDS)


@kernel
def _make(*fields):
    return Forces(*fields)


def make(mass, ids, *, gravity, src, passive, still, held=None, user=None, drag=None,
         tape=None, threads=None, tethers=None, rails=None):
    """A Forces table for the bodies mass, ids (n,); arrays are shared, not copied (a change
    to drag or to a held force between steps needs no new table). gravity : a model table
    of kernels/gravity.py or None; held (n, 6), user (UserForces), drag (4,), tape
    (kernels/tape.TapeArrays), threads (1,) int64, tethers (kernels/tethers.TetherArrays),
    rails (kernels/rails.RailsArrays): each None when the scene has none."""
    fields = dict(gravity=gravity, mass=mass, ids=ids, src=src, passive=passive, still=still,
                  everyone=np.arange(mass.shape[0], dtype=np.int64), held=held, user=user,
                  drag=drag, tape=tape, threads=threads, tethers=tethers, rails=rails)
    return _make(*(fields[name] for name in FIELDS))


def no_user_forces():
    """(fns, params): empty typed lists of the user-force types."""
    return typed.List.empty_list(USER_FORCE_TYPE), typed.List.empty_list(types.float64[::1])


@kernel
def hoist(f):
    """The table's fields as a ForceArrays tuple, read once before a step loop."""
    return read(f, ForceArrays)


# ----------------------------------------------------------------------------- the contract

def accelerations(fx, t, pos, vel, out, targets, with_drag):
    """out[k] = the acceleration of body k, for every k in targets (other rows untouched).

    fx : hoist(Forces); t : the time of the stage [time]; pos, vel : (n, 3) at the stage (vel
    is read by drag and user forces only); out : (n, 3) [length / time^2]; targets : int64
    rows (fx.everyone, fx.src, fx.passive or any subset); with_drag : add -k (v - wind) (the
    splittings and Wisdom-Holman apply drag in their kicks instead, see kick). The force
    loops run on threads from fx.threads[0] pair evaluations on (never with threads None):
    the same bits either way. First the bodies on rails are put where their orbits have
    them at t (kernels/rails.py); then gravity, held forces, user forces, drag, in that
    order; zero for immovable bodies; then the tethers: springs, and the inextensible tethers'
    constraint forces, which hold against all of these (kernels/tethers.py: they need every
    row's); last, zero for the bodies on rails. Kernels call it (numba runs _accelerations,
    see below).
    """


def _accelerations(fx, t, pos, vel, out, targets, with_drag):
    krails.place(fx.rails, t, pos, vel)
    gravity.pull(fx.gravity, fx.tape, fx.src, fx.passive, pos, fx.mass, out, targets,
                 fx.threads)
    _add_held(fx.held, fx.mass, out, targets)
    _add_user(fx.user, t, pos, vel, fx.mass, fx.ids, out, targets)
    if with_drag:
        _add_drag(fx.drag, vel, out, targets)
    _hold_still(fx.still, out)
    ktethers.add(fx.tethers, pos, vel, fx.mass, out, targets)
    krails.hold(fx.rails, out)


# A step loop evaluates forces thousands of times a call, so accelerations is compiled
# without reference counts (lean: every array of fx and every argument would otherwise cost
# two atomic updates a call). numba cannot compile a function without them that touches a
# typed List ("NRT required but not enabled"), so a table with user forces takes the same
# body compiled with reference counts (implements_by_users).
def implements_by_users(stub, fn, when, fx_at, **options):
    """implements(stub, fn, ...) twice: compiled lean (options) for a hoisted force table (the
    argument at fx_at) without user forces, with reference counts for one with them; when
    (the argument types) picks the caller's case, as for implements."""
    def user(args):
        return isinstance(field_type(args[fx_at], "user"), types.NoneType)
    lean = dict(options, lean=True)
    counted = dict(options, lean=False, counted=True)
    implements(stub, fn, lambda *args: when(*args) and user(args), **lean)
    implements(stub, fn, lambda *args: when(*args) and not user(args), **counted)


implements_by_users(accelerations, _accelerations, lambda *args: True, 0, parallel=True,
                    forceinline=True)


@kernel
def accelerations_of(f, t, pos, vel, out, targets, with_drag):
    """accelerations from the table itself (for Python: World.gravity_accelerations)."""
    accelerations(hoist(f), t, pos, vel, out, targets, with_drag)


@kernel(lean=True)
def _add_held(held, mass, out, targets):
    """Held forces and accelerations (held: see FIELDS)."""
    if held is None:
        return
    for a in range(targets.size):
        k = targets[a]
        m = mass[k]
        for c in range(3):
            # a held force on a body of mass 0 has no acceleration to give
            out[k, c] += (held[k, c] / m if m > 0.0 else 0.0) + held[k, 3 + c]


@kernel(counted=True)
def _add_user(user, t, pos, vel, mass, ids, out, targets):
    """The user forces (each adds every body's acceleration into user.out)."""
    if user is None:
        return
    extra = user.out
    for i in range(extra.shape[0]):
        extra[i, 0] = 0.0
        extra[i, 1] = 0.0
        extra[i, 2] = 0.0
    for u in range(len(user.fns)):
        fn = user.fns[u]
        fn(t, pos, vel, mass, ids, user.params[u], extra)
    for a in range(targets.size):
        k = targets[a]
        out[k, 0] += extra[k, 0]
        out[k, 1] += extra[k, 1]
        out[k, 2] += extra[k, 2]


@kernel(lean=True)
def _add_drag(drag, vel, out, targets):
    """-k (v - wind) into out's target rows (drag: see FIELDS)."""
    if drag is None:
        return
    if drag[0] > 0.0:
        for a in range(targets.size):
            k = targets[a]
            for c in range(3):
                out[k, c] -= drag[0] * (vel[k, c] - drag[1 + c])


@kernel(lean=True)
def _hold_still(still, vel):
    """Zero rows `still` of vel (or of accelerations)."""
    for a in range(still.size):
        k = still[a]
        vel[k, 0] = 0.0
        vel[k, 1] = 0.0
        vel[k, 2] = 0.0


@kernel
def velocity_dependent(fx):
    """Whether the accelerations read velocities (drag, user forces, inextensible
    tethers)."""
    return dragging(fx.drag) or fx.user is not None or ktethers.constrained(fx.tethers)


@kernel
def dragging(drag):
    """Whether there is drag (drag: see FIELDS)."""
    if drag is None:
        return False
    return drag[0] > 0.0


@kernel(lean=True, forceinline=True)
def kick(drag, still, vel, acc, h, rows):
    """The kick with linear drag toward the wind, dv/dt = a - k (v - wind) with a held, for
    the bodies in rows: exact, v <- v_t + (v - v_t) exp(-k h), v_t = wind + a / k the terminal
    velocity. Without drag (None, or k = 0) the plain kick v += h a. drag, still : the
    table's (hoist). Immovable bodies stay at rest."""
    _kick(drag, vel, acc, h, rows)
    _hold_still(still, vel)


@kernel(lean=True, forceinline=True)
def _kick(drag, vel, acc, h, rows):
    if drag is not None:
        k = drag[0]
        if k > 0.0:
            E = libm.exp(-k * h)
            for a in range(rows.size):
                i = rows[a]
                for c in range(3):
                    vt = drag[1 + c] + acc[i, c] / k
                    vel[i, c] = vt + (vel[i, c] - vt) * E
            return
    for a in range(rows.size):
        i = rows[a]
        vel[i, 0] += h * acc[i, 0]
        vel[i, 1] += h * acc[i, 1]
        vel[i, 2] += h * acc[i, 2]
