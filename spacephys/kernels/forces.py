"""The one force contract: every acceleration a body feels besides thrust, from one table.

`Forces` (a numba structref, built once per set of bodies by spacephys/forces.py) holds the
gravity model and its parameters, drag toward a wind, the held per-body forces and
accelerations (World.apply_force, apply_acceleration) and the user's jitted forces
(World.add_force). Every integrator family asks `accelerations` for the accelerations of the
bodies it moves, at the positions (and velocities) of its stage; nothing else computes forces.

Gravity models (`model`, spacephys.kernels.codes):
  NONE     no gravity;
  DIRECT   direct summation F = G m1 m2 / D^2: the bodies listed in `src` (active, massive) pull
           every body; the bodies in `passive` (test particles, ships, debris) feel but never pull;
  UNIFORM  a constant field `field` (the seed's `y += gravity` near a planet's surface);
  CENTRAL  a fixed body of mass `field_mass` at `field` pulls every body; bodies ignore each other;
  TREE     as DIRECT, the sum approximated by a Barnes-Hut tree (kernels/tree.py) with the
           opening angle `theta`, monopole or (`quadrupole`) quadrupole moments.
Softening is Plummer's: a = G m d / (|d|^2 + eps2)^(3/2). Two bodies at exactly the same point
(|d|^2 + eps2 == 0) exert no force on each other: the direction is undefined, and a zero keeps
the state finite instead of NaN.

Drag: a = -k (v - wind), drag = [k, wind (3,)]. The splitting methods and Wisdom-Holman apply
it exactly inside their kicks (drag_kick); Runge-Kutta and Gauss-Radau add it at their stages
(`with_drag`). User forces: fn(t, pos, vel, mass, ids, params, out) adds accelerations of every
body to out (n, 3); see USER_FORCE.
"""
import math

import numba
import numpy as np
from numba import types, typed
from numba.experimental import structref

from .._jit import NEVER, PARALLEL_MIN_PAIRS, TableType, kernel
from . import pairs, tape, tree
from .diagnostics import add

# gravity models: a code and a name each, their accelerations (accelerations) and potential
# (potential_energy, body_energies) below
NONE, DIRECT, UNIFORM, CENTRAL, TREE = 0, 1, 2, 3, 4
GRAVITY_MODELS = {"none": NONE, "direct": DIRECT, "uniform": UNIFORM, "central": CENTRAL,
                  "tree": TREE}

# the signature of a user force: (t [time], pos (n, 3), vel (n, 3), mass (n,), ids (n,) int64,
# params (p,) float64, out (n, 3) accelerations to add to) -> None
USER_FORCE = types.void(types.float64, types.float64[:, ::1], types.float64[:, ::1],
                        types.float64[::1], types.int64[::1], types.float64[::1],
                        types.float64[:, ::1])
USER_FORCE_TYPE = types.FunctionType(USER_FORCE)


@structref.register
class ForcesType(TableType):
    pass


class Forces(structref.StructRefProxy):
    """The force table (see the module); made by `make`, read only by the kernels."""


FIELDS = (
    "model",       # int: NONE | DIRECT | UNIFORM | CENTRAL | TREE
    "G",           # float [length^3 / (mass time^2)]
    "eps2",        # float: Plummer softening squared [length^2]
    "field",       # (3,): the uniform acceleration (UNIFORM) or the fixed body's position (CENTRAL)
    "field_mass",  # float: the fixed body's mass (CENTRAL)
    "mass",        # (n,) [mass]
    "ids",         # (n,) int64 body ids, for user forces
    "src",         # (ns,) int64 rows of the bodies that pull (DIRECT, TREE)
    "passive",     # (np,) int64 rows of the others
    "still",       # (k,) int64 rows of immovable bodies: their acceleration is zero
    "everyone",    # (n,) int64 rows 0..n-1
    "drag",        # (4,) [k [1/time], wind (3,) [length/time]]
    "held",        # (n, 6) [force (3,) [mass length/time^2], acceleration (3,)], or (0, 6)
    "scratch",     # (7, ns) DIRECT: the sources' x, y, z, m and their pulls on each other / G
                   # (pairs.pull_pairs); (4, ns) TREE, (4, 1) CENTRAL: x, y, z, m
    "user",        # typed List of USER_FORCE_TYPE
    "params",      # typed List of (p,) float64, one per user force
    "user_out",    # (n, 3) scratch the user forces add into
    "threads",     # (1,) int64: the fewest pair evaluations a force loop runs on threads
                   # (World's ThreadChoice sets it between calls: huge = never)
    "tape",        # (E, 4, ns) the pulling bodies' sources per force evaluation (kernels/tape)
    "ends",        # (T, ns, 14) their positions, velocities, masses per step (kernels/tape)
    "tape_at",     # (5,) int64: where the tape is and whether it runs (kernels/tape); off
    "taped",       # int: 1 once the table has a tape (set_tape). A scalar, read every step
                   # and evaluation at the cost of a load; the arrays' reads cost refcounts
    "theta",       # float: the tree's opening angle (TREE)
    "quadrupole",  # int: 1 for the tree's quadrupole moments, 0 for monopoles only (TREE)
)
structref.define_proxy(Forces, ForcesType, list(FIELDS))


@kernel
def _make(model, G, eps2, field, field_mass, mass, ids, src, passive, still, everyone, drag,
          held, scratch, user, params, user_out, threads, theta, quadrupole):
    return Forces(model, G, eps2, field, field_mass, mass, ids, src, passive, still, everyone,
                  drag, held, scratch, user, params, user_out, threads, np.zeros((0, 4, 0)),
                  np.zeros((0, 0, 14)), np.zeros(5, np.int64), 0, theta, quadrupole)


@kernel
def _make_plain(model, G, eps2, field, field_mass, mass, ids, src, passive, still, everyone,
                drag, held, scratch, user_out, threads, theta, quadrupole):
    """_make without user forces: the empty lists made here, so that a process that never
    adds a user force never pays for typed lists in Python (0.4 s of compilation)."""
    return Forces(model, G, eps2, field, field_mass, mass, ids, src, passive, still, everyone,
                  drag, held, scratch, typed.List.empty_list(USER_FORCE_TYPE),
                  typed.List.empty_list(types.float64[::1]), user_out, threads,
                  np.zeros((0, 4, 0)), np.zeros((0, 0, 14)), np.zeros(5, np.int64), 0, theta,
                  quadrupole)


@kernel
def set_tape(f, tape, ends, at):
    """Give the table a prediction's tape (kernels/tape.py): tape (E, 4, ns), ends (T, ns, 14),
    at (5,) int64, shared with the caller."""
    f.tape = tape
    f.ends = ends
    f.tape_at = at
    f.taped = 1


def no_user_forces():
    """(user, params): empty typed lists of the user-force types."""
    return typed.List.empty_list(USER_FORCE_TYPE), typed.List.empty_list(types.float64[::1])


def make(mass, ids, *, model, G, eps2, field, field_mass, src, passive, still, drag, held=None,
         user=None, params=None, threads=None, theta=0.5, quadrupole=True):
    """A Forces table for the bodies mass, ids (n,); arrays are shared, not copied (a change
    to drag or field between steps needs no new table). held : (n, 6) or None; user,
    params : typed lists (no_user_forces) or None; threads : (1,) int64, the fewest pair
    evaluations a force loop runs on threads (default _jit.PARALLEL_MIN_PAIRS); theta,
    quadrupole : the tree's (TREE)."""
    n = mass.shape[0]
    # rows 4-6 (pairs.pull_pairs' sums) only where direct summation uses them
    scratch = np.empty((7 if model == DIRECT else 4, src.size if model in (DIRECT, TREE) else 1))
    args = (int(model), float(G), float(eps2), field, float(field_mass), mass, ids, src,
            passive, still, np.arange(n, dtype=np.int64), drag,
            np.zeros((0, 6)) if held is None else held, scratch)
    if threads is None:
        threads = np.array([PARALLEL_MIN_PAIRS], np.int64)
    tree_args = (float(theta), int(bool(quadrupole)))
    if user is None:
        return _make_plain(*args, np.zeros((0, 3)), threads, *tree_args)
    return _make(*args, user, params, np.zeros((n, 3)), threads, *tree_args)


# ----------------------------------------------------------------------------- gravity

@kernel(fast=True, parallel=True, inline=True)
def _pull_all(fa, targets, pos, s, G, eps2, out, min_pairs):
    """out[k] = G * pull of the sources on pos[k] for every k in targets; on threads from
    min_pairs pair evaluations on. When the targets are every body or the sources (DIRECT,
    see _pairs_rest), the sources' pulls on each other come from pairs.pull_pairs (each pair
    once), and `pull` serves the passive bodies.

    Each target's sum runs in a fixed order, so the result does not depend on the thread
    count.
    """
    both, rest = _pairs_rest(fa, targets, pos, s)
    if both:
        ns = s.shape[1]
        if ns * (ns - 1) // 2 >= min_pairs:
            pairs.pull_pairs_threaded(s, ns, eps2)
        else:
            pairs.pull_pairs(s, ns, eps2)
        _pair_sums_out(fa[FA_SRC], s, G, out)
    if rest.size * s.shape[1] >= min_pairs:
        for a in numba.prange(rest.size):
            k = rest[a]
            ax, ay, az = pairs.pull(pos[k, 0], pos[k, 1], pos[k, 2], s, s.shape[1], eps2)
            out[k, 0] = G * ax
            out[k, 1] = G * ay
            out[k, 2] = G * az
    else:
        _pull_each(rest, pos, s, G, eps2, out)


@kernel(fast=True, inline=True)
def _pull_rows(fa, targets, pos, s, G, eps2, out):
    """_pull_all on the calling thread, bit for bit the same."""
    both, rest = _pairs_rest(fa, targets, pos, s)
    if both:
        pairs.pull_pairs(s, s.shape[1], eps2)
        _pair_sums_out(fa[FA_SRC], s, G, out)
    _pull_each(rest, pos, s, G, eps2, out)


@kernel(fast=True, inline=True)
def _pull_each(targets, pos, s, G, eps2, out):
    """out[k] = G * pull of the sources on pos[k], one target after another."""
    for a in range(targets.size):
        k = targets[a]
        ax, ay, az = pairs.pull(pos[k, 0], pos[k, 1], pos[k, 2], s, s.shape[1], eps2)
        out[k, 0] = G * ax
        out[k, 1] = G * ay
        out[k, 2] = G * az


@kernel(inline=True)
def _pairs_rest(fa, targets, pos, s):
    """(whether the sources' pulls on each other come from pairs.pull_pairs, the targets
    `pull` serves then): DIRECT gravity, the sources the gathered scratch (7, ns), at least
    pairs.PAIRS_FROM of them, and the targets every body (distinct rows: the passive ones
    left) or the sources' own row list (none left). Any other targets: (False, targets)."""
    src = fa[FA_SRC]
    if fa[FA_MODEL] != DIRECT or s.shape[0] != 7 or s.shape[1] < pairs.PAIRS_FROM:
        return False, targets
    if targets.size == pos.shape[0]:
        return True, fa[FA_PASSIVE]
    if targets.size == src.size and targets.ctypes.data == src.ctypes.data:
        return True, src[:0]
    return False, targets


@kernel(inline=True)
def _pair_sums_out(src, s, G, out):
    """out[src[a]] = G * the pair sums in rows 4-6 of s."""
    for a in range(src.size):
        k = src[a]
        out[k, 0] = G * s[4, a]
        out[k, 1] = G * s[5, a]
        out[k, 2] = G * s[6, a]


@kernel(inline=True)
def _gather_sources(src, pos, mass, scratch):
    """The pulling bodies' x, y, z, m into scratch's rows (4, ns): separate contiguous rows,
    so that the force loops load them unit-stride."""
    for a in range(src.size):
        k = src[a]
        scratch[0, a] = pos[k, 0]
        scratch[1, a] = pos[k, 1]
        scratch[2, a] = pos[k, 2]
        scratch[3, a] = mass[k]


# ----------------------------------------------------------------------------- the contract

@kernel(parallel=True)
def accelerations(f, t, pos, vel, out, targets, with_drag):
    """out[k] = the acceleration of body k, for every k in targets (other rows untouched).

    f : Forces; t : the time of the stage [time]; pos, vel : (n, 3) at the stage (vel is read
    by drag and user forces only); out : (n, 3) [length / time^2]; targets : int64 rows
    (f.everyone, f.src, f.passive or any subset); with_drag : add -k (v - wind) (the
    splittings and Wisdom-Holman apply drag in their kicks instead, see drag_kick). The force
    loop runs on threads from f.threads[0] pair evaluations on. A step loop calls
    lean_accelerations instead where it can (see hoist): bit for bit the same.
    """
    fa, _ = hoist(f)
    has, s = _sources(fa, pos)
    if f.model == TREE:
        tree.accelerations(s, f.src, targets, pos, f.G, f.eps2, f.theta, f.quadrupole, out,
                           targets.size * s.shape[1] >= f.threads[0])
    elif has:
        _pull_all(fa, targets, pos, s, f.G, f.eps2, out, f.threads[0])
    else:
        _field(fa, out, targets)
    _add_held(fa, out, targets)
    if f.user_out.shape[0]:               # made only with user forces (see make)
        _add_user(f, t, pos, vel, out, targets)
    _add_drag(fa, vel, out, targets, with_drag)


@kernel
def accelerations_serial(f, t, pos, vel, out, targets, with_drag):
    """accelerations on the calling thread, bit for bit the same: for a few bodies at a time
    (Gauss-Radau's riders, with user forces: without, they take lean_accelerations), where a
    threaded loop would only cost compile time."""
    fa, _ = hoist(f)
    has, s = _sources(fa, pos)
    if has:
        _pull_rows(fa, targets, pos, s, f.G, f.eps2, out)
    else:
        _field(fa, out, targets)
    _add_held(fa, out, targets)
    if f.user_out.shape[0]:               # made only with user forces (see make)
        _add_user(f, t, pos, vel, out, targets)
    _add_drag(fa, vel, out, targets, with_drag)


# A step loop evaluates forces thousands of times per call. Each read of a table's array field
# and each array passed to a helper costs two atomic reference-count updates there (numba's
# runtime; measured 10 ns the pair, 43% of a ship's prediction among 10 planets), so a step
# loop reads the table once (hoist) and hands the tuple to lean helpers, compiled without
# reference counting.
FA_MODEL, FA_G, FA_EPS2, FA_FIELD, FA_FIELD_MASS, FA_MASS, FA_SRC, FA_SCRATCH, FA_HELD, \
    FA_DRAG, FA_STILL, FA_TAPED, FA_TAPE, FA_TAPE_AT, FA_ENDS, FA_PASSIVE = range(16)


@kernel(inline=True)
def hoist(f):
    """(fa, lean_below): the table's fields as one tuple (FA_* index it), read once before a
    step loop, and the number of targets below which lean_accelerations serves (0: never,
    with user forces; otherwise up to the threaded loop's threshold f.threads[0])."""
    fa = (f.model, f.G, f.eps2, f.field, f.field_mass, f.mass, f.src, f.scratch, f.held,
          f.drag, f.still, f.taped, f.tape, f.tape_at, f.ends, f.passive)
    # a constant, not np.iinfo: with np.iinfo(np.int64).max here the step kernels took the
    # threaded path on every step of a 3-body scene (seen in gdb; not reproduced alone)
    lean_below = NEVER
    min_pairs = f.threads[0]
    if f.user_out.shape[0] or f.model == TREE:
        lean_below = 0
    elif f.model == DIRECT and f.src.size:
        # targets * ns < min_pairs; NEVER (min_pairs) + ns would overflow
        lean_below = (min_pairs - 1) // f.src.size + 1 if min_pairs > 0 else 0
    return fa, lean_below


@kernel(lean=True)
def lean_accelerations(fa, pos, vel, out, targets, with_drag):
    """accelerations from the hoisted table fa, on the calling thread, without user forces
    (the step loops call it for fewer targets than hoist's lean_below): bit for bit the
    same."""
    has, s = _sources(fa, pos)
    if has:
        _pull_rows(fa, targets, pos, s, fa[FA_G], fa[FA_EPS2], out)
    else:
        _field(fa, out, targets)
    _add_held(fa, out, targets)
    _add_drag(fa, vel, out, targets, with_drag)


@kernel(inline=True)
def _sources(fa, pos):
    """(whether the model has sources, the sources (>= 4, ns): x, y, z, m): the pulling bodies
    (DIRECT, TREE) gathered into the scratch, or a played step's straight from the
    prediction's tape; the fixed body (CENTRAL)."""
    model = fa[FA_MODEL]
    scratch = fa[FA_SCRATCH]
    if model == DIRECT or model == TREE:
        at = fa[FA_TAPE_AT]
        if fa[FA_TAPED] != 0 and at[tape.ON] != 0:      # a prediction's copy, its tape on
            e = at[tape.EVAL]
            at[tape.EVAL] = e + 1
            if tape.recorded(at):
                return True, fa[FA_TAPE][e]
            _gather_sources(fa[FA_SRC], pos, fa[FA_MASS], scratch)
            tape.record(fa[FA_TAPE], at, e, scratch)
            return True, scratch
        _gather_sources(fa[FA_SRC], pos, fa[FA_MASS], scratch)
        return True, scratch
    if model == CENTRAL:
        field = fa[FA_FIELD]
        scratch[0, 0] = field[0]
        scratch[1, 0] = field[1]
        scratch[2, 0] = field[2]
        scratch[3, 0] = fa[FA_FIELD_MASS]
        return True, scratch
    return False, scratch


@kernel(inline=True)
def _field(fa, out, targets):
    """The uniform field (or nothing) into out's target rows."""
    uniform = fa[FA_MODEL] == UNIFORM
    field = fa[FA_FIELD]
    g0 = field[0] if uniform else 0.0
    g1 = field[1] if uniform else 0.0
    g2 = field[2] if uniform else 0.0
    for a in range(targets.size):
        k = targets[a]
        out[k, 0] = g0
        out[k, 1] = g1
        out[k, 2] = g2


@kernel(inline=True)
def _add_held(fa, out, targets):
    """Held forces and accelerations."""
    held = fa[FA_HELD]
    if held.shape[0]:
        mass = fa[FA_MASS]
        for a in range(targets.size):
            k = targets[a]
            m = mass[k]
            for c in range(3):
                # a held force on a body of mass 0 has no acceleration to give
                out[k, c] += (held[k, c] / m if m > 0.0 else 0.0) + held[k, 3 + c]


@kernel(inline=True)
def _add_user(f, t, pos, vel, out, targets):
    """The user forces (each adds every body's acceleration into f.user_out)."""
    extra = f.user_out
    for i in range(extra.shape[0]):
        extra[i, 0] = 0.0
        extra[i, 1] = 0.0
        extra[i, 2] = 0.0
    for u in range(len(f.user)):
        fn = f.user[u]
        fn(t, pos, vel, f.mass, f.ids, f.params[u], extra)
    for a in range(targets.size):
        k = targets[a]
        out[k, 0] += extra[k, 0]
        out[k, 1] += extra[k, 1]
        out[k, 2] += extra[k, 2]


@kernel(inline=True)
def _add_drag(fa, vel, out, targets, with_drag):
    """Drag (with_drag); then zero for immovable bodies."""
    drag = fa[FA_DRAG]
    if with_drag and drag[0] > 0.0:
        for a in range(targets.size):
            k = targets[a]
            for c in range(3):
                out[k, c] -= drag[0] * (vel[k, c] - drag[1 + c])
    still = fa[FA_STILL]
    for a in range(still.size):
        k = still[a]
        out[k, 0] = 0.0
        out[k, 1] = 0.0
        out[k, 2] = 0.0


@kernel
def velocity_dependent(f):
    """Whether the accelerations read velocities (drag or user forces)."""
    return f.drag[0] > 0.0 or f.user_out.shape[0] > 0


@kernel(lean=True)
def drag_kick(fa, vel, acc, h, rows, wind):
    """The kick with linear drag toward the wind, dv/dt = a - k (v - wind) with a held, for
    the bodies in rows: exact, v <- v_t + (v - v_t) exp(-k h), v_t = wind + a / k the terminal
    velocity. Without drag (k = 0) the plain kick v += h a. fa : the hoisted table (hoist);
    wind : (3,), the drag's wind in inertial coordinates (0 for Wisdom-Holman's Jacobi
    velocities). Immovable bodies stay at rest."""
    k = fa[FA_DRAG][0]
    if k > 0.0:
        E = math.exp(-k * h)
        for a in range(rows.size):
            i = rows[a]
            for c in range(3):
                vt = wind[c] + acc[i, c] / k
                vel[i, c] = vt + (vel[i, c] - vt) * E
    else:
        for a in range(rows.size):
            i = rows[a]
            vel[i, 0] += h * acc[i, 0]
            vel[i, 1] += h * acc[i, 1]
            vel[i, 2] += h * acc[i, 2]
    still = fa[FA_STILL]
    for j in range(still.size):
        for c in range(3):
            vel[still[j], c] = 0.0


# ----------------------------------------------------------------------------- potentials

@kernel
def _pair_potential(xi, yi, zi, mi, xj, yj, zj, mj, eps2):
    dx = xj - xi
    dy = yj - yi
    dz = zj - zi
    r2 = dx * dx + dy * dy + dz * dz + eps2
    # coincident points exert no force (gravity.py), so they hold no pair energy either
    return -mi * mj / np.sqrt(r2) if r2 > 0.0 else 0.0


@kernel
def potential_energy(f, pos, mass, passive):
    """Potential energy of the state pos (n, 3) under the gravity model of the Forces table f,
    with the masses mass (n,) (f.mass, or those of the pulling bodies only).

    DIRECT: -G m_i m_j / sqrt(r^2 + eps2) over pairs of sources (f.src), and over (passive,
    source) pairs for the rows `passive`: a passive body sits in the sources' field. TREE: the
    same sum, exact (tree_potential_energy is the tree's). CENTRAL: each body in the fixed
    body's field. UNIFORM: -m g.x. NONE: 0. The immovable bodies' potential counts.
    """
    model, src, G, eps2 = f.model, f.src, f.G, f.eps2
    field, field_mass = f.field, f.field_mass
    s = 0.0
    c = 0.0
    if model == DIRECT or model == TREE:
        for a in range(src.size):
            i = src[a]
            for b in range(a + 1, src.size):
                j = src[b]
                s, c = add(s, c, _pair_potential(pos[i, 0], pos[i, 1], pos[i, 2], mass[i],
                                                  pos[j, 0], pos[j, 1], pos[j, 2], mass[j], eps2))
        for a in range(passive.size):
            i = passive[a]
            if mass[i] == 0.0:
                continue
            for b in range(src.size):
                j = src[b]
                s, c = add(s, c, _pair_potential(pos[i, 0], pos[i, 1], pos[i, 2], mass[i],
                                                  pos[j, 0], pos[j, 1], pos[j, 2], mass[j], eps2))
        return G * (s + c)
    if model == CENTRAL:
        for i in range(mass.size):
            s, c = add(s, c, _pair_potential(pos[i, 0], pos[i, 1], pos[i, 2], mass[i],
                                              field[0], field[1], field[2], field_mass, eps2))
        return G * (s + c)
    if model == UNIFORM:
        for i in range(mass.size):
            g_dot_x = field[0] * pos[i, 0] + field[1] * pos[i, 1] + field[2] * pos[i, 2]
            s, c = add(s, c, -mass[i] * g_dot_x)
        return s + c
    return 0.0


@kernel
def body_energies(f, pos, vel, mass, out):
    """Each body's share of the energy into out (n,): 1/2 m |v|^2 plus, under DIRECT, half
    of each pair potential among the sources src (other bodies get their kinetic energy
    only: give them mass 0 to leave them out); under CENTRAL and UNIFORM, its potential in
    the field. Sums to the total energy, to rounding: used to name the bodies whose energy
    changed when the total went wrong (under TREE too, exact: O(ns^2)). f : the Forces
    table (its model and sources)."""
    model, src, G, eps2 = f.model, f.src, f.G, f.eps2
    field, field_mass = f.field, f.field_mass
    for i in range(mass.size):
        v2 = vel[i, 0] * vel[i, 0] + vel[i, 1] * vel[i, 1] + vel[i, 2] * vel[i, 2]
        out[i] = 0.5 * mass[i] * v2
        if model == CENTRAL:
            out[i] += G * _pair_potential(pos[i, 0], pos[i, 1], pos[i, 2], mass[i],
                                          field[0], field[1], field[2], field_mass, eps2)
        elif model == UNIFORM:
            out[i] -= mass[i] * (field[0] * pos[i, 0] + field[1] * pos[i, 1]
                                 + field[2] * pos[i, 2])
    if model == DIRECT or model == TREE:
        for a in range(src.size):
            i = src[a]
            for b in range(a + 1, src.size):
                j = src[b]
                half = 0.5 * G * _pair_potential(pos[i, 0], pos[i, 1], pos[i, 2], mass[i],
                                                 pos[j, 0], pos[j, 1], pos[j, 2], mass[j], eps2)
                out[i] += half
                out[j] += half


@kernel(parallel=True)
def tree_potential_energy(f, pos, mass, passive):
    """potential_energy under TREE as its forces see it: the light sources' pairs from the
    tree's potential (1/2 m_i phi_i), every pair with a heavy source (kernels/tree.split)
    summed directly, and the rows `passive` of mass > 0 in the sources' field."""
    src = f.src
    s = np.empty((4, src.size))
    _gather_sources(src, pos, mass, s)
    heavy, light, is_heavy = tree.split(s)
    k = 0
    for a in range(src.size):
        k += 0 if is_heavy[a] else 1
    for a in range(passive.size):
        k += 1 if mass[passive[a]] != 0.0 else 0
    rows = np.empty(k, np.int64)          # the light sources, then the passive rows
    k = 0
    for a in range(src.size):
        if not is_heavy[a]:
            rows[k] = src[a]
            k += 1
    nlight = k
    for a in range(passive.size):
        if mass[passive[a]] != 0.0:
            rows[k] = passive[a]
            k += 1
    phi = np.empty(mass.size)
    t = tree.build(light, f.theta)
    tree.walk(t, np.empty((4, 0)), pos, rows, False, 1.0, f.eps2, f.quadrupole,
              np.empty((0, 3)), phi, True)
    total = 0.0
    c = 0.0
    nh = heavy.shape[1]
    for a in range(rows.size):
        i = rows[a]
        near = pairs.potential(pos[i, 0], pos[i, 1], pos[i, 2], heavy, nh, f.eps2)
        total, c = add(total, c, mass[i] * ((0.5 if a < nlight else 1.0) * phi[i] + near))
    for a in range(src.size):
        if is_heavy[a]:
            i = src[a]
            near = pairs.potential(pos[i, 0], pos[i, 1], pos[i, 2], heavy, nh, f.eps2)
            total, c = add(total, c, 0.5 * mass[i] * near)
    return f.G * (total + c)
