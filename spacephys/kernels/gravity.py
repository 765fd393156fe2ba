"""The gravity models. Each is a namedtuple type (its settings and scratch) with its
accelerations, its potential energy and each body's share of it, `register`ed here:

  None      no gravity
  Direct    direct summation F = G m1 m2 / D^2: the bodies `src` (active, massive) pull every
            body; the `passive` ones (test particles, ships, debris) feel but never pull
  Uniform   a constant field g (Basic Game Physics' `y += gravity` near a planet's surface)
  Central   a fixed body of mass M at a point pulls every body; bodies ignore each other
  Tree      as Direct, the sum approximated by a Barnes-Hut tree (kernels/tree.py)

Softening is Plummer's: a = G m d / (|d|^2 + eps2)^(3/2). Two bodies at exactly the same point
(|d|^2 + eps2 == 0) exert no force on each other: the direction is undefined, and a zero keeps
the state finite instead of NaN.

The kernels call `pull(model, ...)`; numba picks the model's own function by the model's
type when it compiles, so a scene compiles its model's code and no other. The diagnostics
(potential energy, each body's energy) are called from Python through `MODELS`.
"""
from collections import namedtuple
from dataclasses import dataclass

import numba
import numpy as np
from numba import types
from .._jit import implements, is_table, kernel, stack_rows
from . import pairs
from .pairs import CHUNK
from . import tape as ktape
from .diagnostics import add

# G [length^3 / (mass time^2)]; eps2: softening squared [length^2]; sources (4, ns): the
# pulling bodies' x, y, z, m, gathered per evaluation; sums (3, ns) their pulls on each other
# with each pair evaluated once (pairs.pull_pairs), or None below pairs.PAIRS_FROM sources (a
# type of its own: those scenes compile none of the pairs code)
Direct = namedtuple("Direct", ("G", "eps2", "sources", "sums"))
# g (3,) [length / time^2]
Uniform = namedtuple("Uniform", ("g",))
# the fixed body: at (3,) [length], shared with the World (shift_origin moves it), mass
# [mass]; sources (4, 1) its x, y, z, m
Central = namedtuple("Central", ("G", "eps2", "at", "mass", "sources"))


@dataclass(frozen=True)
class Model:
    """A gravity model's diagnostics, called from Python: potential(model, pos, mass, src,
    passive) -> float and body_energies(model, pos, vel, mass, src, out) -> None, exact (a
    tree's by direct summation); own_potential: the potential as the model's forces see it
    (a tree's own), default potential."""
    name: str
    potential: object
    body_energies: object
    own_potential: object = None


MODELS = {}          # the namedtuple type -> Model


def pull(model, tape, src, passive, pos, mass, out, targets, threads):
    """out[k] = the acceleration by gravity of body k [length / time^2], for every k in
    targets (int64 rows; other rows untouched). model : a registered namedtuple, or None (no
    gravity: zeros); tape : a prediction's tape (kernels/tape.TapeArrays) or None; src,
    passive : the rows that pull and the others; pos (n, 3), mass (n,); threads : None (the
    scene's loops never run on threads: none is compiled) or (1,) int64, the fewest pair
    evaluations a loop runs on threads from. Each target's sum runs in a fixed order, so the
    result does not depend on the thread count. Kernels call it; numba runs the model's own
    pull, chosen by the model's type (register)."""


def register(table, model, own_pull, **options):
    """A gravity model: its table (a namedtuple type), its diagnostics (Model), and its pull
    (a plain function with pull's arguments), compiled with _jit.kernel's options into the
    kernels that call `pull` with a table of that type."""
    MODELS[table] = model
    implements(pull, own_pull, lambda t, *rest: is_table(t, table), **options)


def _no_gravity(model, tape, src, passive, pos, mass, out, targets, threads):
    _fill(out, targets, 0.0, 0.0, 0.0)


implements(pull, _no_gravity, lambda t, *rest: isinstance(t, types.NoneType), lean=True,
           forceinline=True)


@kernel(lean=True, forceinline=True)
def _fill(out, targets, gx, gy, gz):
    for a in range(targets.size):
        k = targets[a]
        out[k, 0] = gx
        out[k, 1] = gy
        out[k, 2] = gz


@kernel(inline=True)
def threaded(threads, work):
    """Whether a loop of `work` pair evaluations runs on threads (threads: see pull)."""
    if threads is None:
        return False
    return work >= threads[0]


# ----------------------------------------------------------------------------- direct

def _direct_pull(model, tape, src, passive, pos, mass, out, targets, threads):
    s = model.sources
    ktape.sources(tape, s, src, pos, mass)
    left = _pairs_first(model.sums, s, src, pos, out, targets, model.G, model.eps2, threads)
    if left == _NONE_LEFT:
        return
    rest = passive if left == _PASSIVE_LEFT else targets
    if threaded(threads, rest.size * s.shape[1]):
        _pull_threaded(rest, pos, s, model.G, model.eps2, out)
    else:
        _pull_each(rest, pos, s, model.G, model.eps2, out)


# what _pairs_first leaves to the one-sided sums
_ALL_LEFT, _PASSIVE_LEFT, _NONE_LEFT = 0, 1, 2


@kernel(parallel=True, lean=True, forceinline=True)
def _pairs_first(sums, s, src, pos, out, targets, G, eps2, threads):
    """With sums (the scene has pairs.PAIRS_FROM sources or more) and the targets every body
    or exactly the sources: the sources' pulls on each other, each pair once, into out.
    Returns which targets are left: the passive ones, none, or (no pairs) all of them."""
    if sums is None:
        return _ALL_LEFT
    if targets.size == pos.shape[0]:
        left = _PASSIVE_LEFT
    elif targets.size == src.size and targets.ctypes.data == src.ctypes.data:
        left = _NONE_LEFT
    else:
        return _ALL_LEFT
    ns = s.shape[1]
    if threaded(threads, ns * (ns - 1) // 2):
        pairs.pull_pairs_threaded(s, sums, ns, eps2)
    else:
        pairs.pull_pairs(s, sums, ns, eps2)
    for a in range(src.size):
        k = src[a]
        out[k, 0] = G * sums[0, a]
        out[k, 1] = G * sums[1, a]
        out[k, 2] = G * sums[2, a]
    return left


@kernel(parallel=True, by_address=True, returns=types.none)
def _pull_threaded(targets, pos, s, G, eps2, out):
    """out[k] = G * the pull of the sources s on pos[k], the targets on threads, a chunk of
    pairs.CHUNK each. Called by address (compiled beside the step): it runs only where the
    work is worth threads, and a call through the slot costs nanoseconds."""
    nc = (targets.size + pairs.CHUNK - 1) // pairs.CHUNK
    for c in numba.prange(nc):
        # (a prange index is unsigned: as int64, _pull_chunk is compiled once)
        _pull_chunk(targets, np.int64(c) * pairs.CHUNK, pos, s, G, eps2, out, False)


@kernel(lean=True, forceinline=True)
def _pull_each(targets, pos, s, G, eps2, out):
    """_pull_threaded on the calling thread, bit for bit the same."""
    for a in range(0, targets.size, pairs.CHUNK):
        _pull_chunk(targets, a, pos, s, G, eps2, out, True)


@kernel(lean=True, forceinline=True)
def _pull_chunk(targets, a, pos, s, G, eps2, out, pad):
    """out[k] = G * the pull of the sources s on pos[k] for k in targets[a : a + CHUNK],
    the chunk's points summed side by side (pairs.pull_points). pad: a last vector of 5-7
    points filled up (below; the same bits): on one thread, for scenes of a few bodies; the
    threaded sums, whose chunks are full but the last, compile without it."""
    nt = min(pairs.CHUNK, targets.size - a)
    if nt == 1:                             # a ship among planets: its sum alone
        k = targets[a]
        gx, gy, gz = pairs.pull_point(pos[k, 0], pos[k, 1], pos[k, 2], s, s.shape[1], eps2)
        out[k, 0] = G * gx
        out[k, 1] = G * gy
        out[k, 2] = G * gz
        return
    rows = stack_rows(G, 6, CHUNK)          # x, y, z, then the sums
    for t in range(nt):
        k = targets[a + t]
        rows[0, t] = pos[k, 0]
        rows[1, t] = pos[k, 1]
        rows[2, t] = pos[k, 2]
        rows[3, t] = 0.0
        rows[4, t] = 0.0
        rows[5, t] = 0.0
    # a last vector of 5-7 points filled up with points at the origin (their sums unread):
    # the vectorised loop then takes it, where it would step them one at a time
    full = nt
    if pad and nt % pairs.GROUP >= 5:
        full = (nt + pairs.GROUP - 1) // pairs.GROUP * pairs.GROUP
    for t in range(nt, full):
        for c in range(6):
            rows[c, t] = 0.0
    pairs.pull_points(rows[0], rows[1], rows[2], full, s, s.shape[1], eps2, rows[3],
                      rows[4], rows[5])
    for t in range(nt):
        k = targets[a + t]
        out[k, 0] = G * rows[3, t]
        out[k, 1] = G * rows[4, t]
        out[k, 2] = G * rows[5, t]


@kernel
def _pair_potential(xi, yi, zi, mi, xj, yj, zj, mj, eps2):
    dx = xj - xi
    dy = yj - yi
    dz = zj - zi
    r2 = dx * dx + dy * dy + dz * dz + eps2
    # coincident points exert no force, so they hold no pair energy either
    return -mi * mj / np.sqrt(r2) if r2 > 0.0 else 0.0


@kernel
def mutual_potential(G, eps2, pos, mass, src, passive):
    """-G m_i m_j / sqrt(r^2 + eps2) over pairs of sources (src), and over (passive, source)
    pairs for the rows `passive` (a passive body sits in the sources' field), compensated."""
    s = 0.0
    c = 0.0
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


@kernel
def mutual_body_energies(G, eps2, pos, vel, mass, src, out):
    """Each body's kinetic energy into out (n,), plus half of each pair potential among the
    sources src (other bodies get their kinetic energy only)."""
    kinetic_into(vel, mass, out)
    for a in range(src.size):
        i = src[a]
        for b in range(a + 1, src.size):
            j = src[b]
            half = 0.5 * G * _pair_potential(pos[i, 0], pos[i, 1], pos[i, 2], mass[i],
                                             pos[j, 0], pos[j, 1], pos[j, 2], mass[j], eps2)
            out[i] += half
            out[j] += half


@kernel
def kinetic_into(vel, mass, out):
    """out (n,) = 1/2 m |v|^2 of each body."""
    for i in range(mass.size):
        v2 = vel[i, 0] * vel[i, 0] + vel[i, 1] * vel[i, 1] + vel[i, 2] * vel[i, 2]
        out[i] = 0.5 * mass[i] * v2


def _direct_potential(model, pos, mass, src, passive):
    return mutual_potential(model.G, model.eps2, pos, mass, src, passive)


def _direct_energies(model, pos, vel, mass, src, out):
    mutual_body_energies(model.G, model.eps2, pos, vel, mass, src, out)


register(Direct, Model("direct", _direct_potential, _direct_energies), _direct_pull,
         parallel=True, lean=True, forceinline=True)


# ----------------------------------------------------------------------------- uniform

def _uniform_pull(model, tape, src, passive, pos, mass, out, targets, threads):
    g = model.g
    _fill(out, targets, g[0], g[1], g[2])


@kernel
def _uniform_potential(model, pos, mass, src, passive):
    """-sum m g.x: the field's potential, zero at the origin (it has no natural zero)."""
    g = model.g
    s = 0.0
    c = 0.0
    for i in range(mass.size):
        s, c = add(s, c, -mass[i] * (g[0] * pos[i, 0] + g[1] * pos[i, 1] + g[2] * pos[i, 2]))
    return s + c


@kernel
def _uniform_energies(model, pos, vel, mass, src, out):
    g = model.g
    kinetic_into(vel, mass, out)
    for i in range(mass.size):
        out[i] -= mass[i] * (g[0] * pos[i, 0] + g[1] * pos[i, 1] + g[2] * pos[i, 2])


register(Uniform, Model("uniform", _uniform_potential, _uniform_energies), _uniform_pull,
         lean=True, forceinline=True)


# ----------------------------------------------------------------------------- central

def _central_pull(model, tape, src, passive, pos, mass, out, targets, threads):
    s = model.sources
    at = model.at
    s[0, 0] = at[0]
    s[1, 0] = at[1]
    s[2, 0] = at[2]
    s[3, 0] = model.mass
    _pull_each(targets, pos, s, model.G, model.eps2, out)


@kernel
def _central_potential(model, pos, mass, src, passive):
    """Each body in the fixed body's field."""
    at = model.at
    s = 0.0
    c = 0.0
    for i in range(mass.size):
        s, c = add(s, c, _pair_potential(pos[i, 0], pos[i, 1], pos[i, 2], mass[i], at[0], at[1],
                                          at[2], model.mass, model.eps2))
    return model.G * (s + c)


@kernel
def _central_energies(model, pos, vel, mass, src, out):
    at = model.at
    kinetic_into(vel, mass, out)
    for i in range(mass.size):
        out[i] += model.G * _pair_potential(pos[i, 0], pos[i, 1], pos[i, 2], mass[i], at[0],
                                            at[1], at[2], model.mass, model.eps2)


register(Central, Model("central", _central_potential, _central_energies), _central_pull,
         lean=True, forceinline=True)


def _no_potential(model, pos, mass, src, passive):
    return 0.0


def _no_energies(model, pos, vel, mass, src, out):
    kinetic_into(vel, mass, out)


NONE = Model("none", _no_potential, _no_energies)


def model_of(model):
    """The Model of a gravity table (None: NONE)."""
    return NONE if model is None else MODELS[type(model)]


def potential(model, pos, mass, src, passive, exact=False):
    """The potential energy of pos (n, 3), mass (n,) under `model`, the rows `passive` of mass
    > 0 in the sources' field [mass length^2 / time^2]; exact: by direct summation, whatever
    the model's own sum (a tree's)."""
    m = model_of(model)
    own = m.potential if exact or m.own_potential is None else m.own_potential
    return own(model, pos, mass, src, passive)


def body_energies(model, pos, vel, mass, src, out):
    """Each body's share of the energy into out (n,): 1/2 m |v|^2 plus half of each pair
    potential among the sources (direct, tree: exact), or its potential in the field
    (uniform, central). Sums to the total energy, to rounding: World names the bodies whose
    energy changed when the total went wrong."""
    model_of(model).body_energies(model, pos, vel, mass, src, out)
