"""What a World measures of its bodies: energies (kinetic, potential, each body's), momentum,
angular momentum, mass and centre of mass, gravity's accelerations now; the watched energy
(watch_energy) and the health check after a step (NaN, the energy error), the precision
check on the tables' rebuild, and the names of bodies those messages give.

A part of World: World's methods of the same names delegate here, each function taking the
World first (World holds the defaults and the docstrings). It reads World's private attributes.
"""
import math
import warnings

import numpy as np

from . import _validate as check
from .errors import InstabilityError, PrecisionWarning, caller_level
from .kernels import diagnostics
from .kernels import forces as kforces
from .kernels import gravity as kgravity
from .kernels import tethers as ktethers
from .kernels.codes import NONFINITE


# ---------------------------------------------------------------- instability
def named(w, rows, most=5):
    """'body 3 (planet), body 7 (moon) and 12 more' for rows of live bodies."""
    b = w._b
    names = [f"body {int(b.ids[r])} ({w._kinds[b.kind[r]]})" for r in rows[:most]]
    more = f" and {len(rows) - most} more" if len(rows) > most else ""
    return ", ".join(names) + more


def closest_pulling_pair(w):
    """World.closest_pulling_pair: (2,) or (0,) int64 rows."""
    rows = w._sources()[0]
    if not 2 <= rows.size <= 2048:
        return rows[:0]
    p = w._b.pos[rows]
    d2 = ((p[:, None, :] - p[None, :, :]) ** 2).sum(axis=2)
    d2[np.diag_indices(rows.size)] = np.inf
    i, j = np.unravel_index(np.argmin(d2), d2.shape)
    return rows[[i, j]]


def check_health(w, t0, status):
    """After a step() from time t0: InstabilityError if a body's state is not finite (the
    kernel's status says), or if the watched energy error passed its limit."""
    b = w._b
    n = b.n
    if status & NONFINITE:
        rows = np.flatnonzero(~(np.isfinite(b.pos[:n]).all(axis=1)
                                & np.isfinite(b.vel[:n]).all(axis=1)))
        if rows.size:
            raise InstabilityError(
                f"the state became NaN or infinite between t = {t0:g} and t = {w.t:g}: "
                f"{w.named(rows)}. A step too long for a close approach, bodies "
                f"meeting without softening, or a speed past the range of doubles; take "
                f"a shorter dt, soften gravity, or use gauss_radau (w.remove(ids) drops "
                f"them)", b.ids[rows].copy(), w.t)
    if w._watch is None:
        return
    limit, E0, e0, ids0 = w._watch
    if E0 == 0.0:                      # bodies removed since: no scale left to judge by
        return
    error = abs(w.energy(True) / E0 - 1.0)
    if error <= limit:                 # (a NaN energy is not <= limit either)
        return
    # the bodies whose own energy changed most, as a fraction of |E0|
    now = _body_energies(w)
    _, then_rows, now_rows = np.intersect1d(ids0, b.ids[:n], return_indices=True)
    change = np.abs(now[now_rows] - e0[then_rows]) / abs(E0)
    order = np.argsort(-np.nan_to_num(change, nan=np.inf), kind="stable")
    rows = now_rows[order]
    shares = ", ".join(f"{change[k]:.2g}" for k in order[:5])
    raise InstabilityError(
        f"energy error {error:.3g} since watch_energy passed its limit {limit:g} between "
        f"t = {t0:g} and t = {w.t:g}; the energy changed most in {w.named(rows)} "
        f"({shares} of |E0|). Their orbits are not resolved by dt = {w._dt:g} with "
        f"{w.integrator}: take a shorter dt or use gauss_radau",
        b.ids[rows].copy(), w.t)


def _body_energies(w):
    """(n,) each body's share of the pulling bodies' energy (gravity.body_energies), by row."""
    b = w._b
    out = np.empty(b.n)
    src = w._sources()[0]
    kgravity.body_energies(w._forces.model(src.size), b.pos[:b.n], b.vel[:b.n],
                           _masses(w, True), src, out)
    return out


def watch_energy(w, limit):
    """World.watch_energy: sets w._watch to (limit, E0, body energies, ids), or None."""
    if limit is None:
        w._watch = None
        return
    limit = check.scalar("limit", limit, positive=True)
    reference = _energy_reference(w)
    if reference[0] == 0.0:
        raise ValueError("watch_energy: the pulling bodies' energy is 0, so a relative "
                         "error has no scale (no massive bodies, or none moving)")
    w._watch = (limit,) + reference


def _energy_reference(w):
    """(E0, body energies, ids): what watch_energy measures against."""
    return (w.energy(True), _body_energies(w), w._b.ids[:w._b.n].copy())


def rewatch(w):
    """The World was changed between steps (bodies added, removed or set, the origin
    moved): the watched energy starts again from here."""
    if w._watch is not None:
        w._watch = (w._watch[0],) + _energy_reference(w)


def check_precision(w, pos):
    """Warn once (PrecisionWarning) when the bodies lie so far from the origin, for how
    far apart they are, that positions keep fewer than 8 significant digits within the
    scene (beyond ~1e8 times its size): a circular orbit of radius 1 at 1e9 ends a
    period 6x less accurately than at the origin, at 1e12 2 800x. Checked whenever the
    tables are rebuilt (bodies come or go)."""
    if w._precision_warned or pos.shape[0] < 2:
        return
    span, far = diagnostics.extent(pos)
    if span > 0.0 and np.spacing(far) > 1e-8 * span:
        w._precision_warned = True
        digits = max(0.0, -math.log10(np.spacing(far) / span))
        warnings.warn(PrecisionWarning(
            f"the bodies lie {far:.3g} from the origin but only {span:.3g} apart: their "
            f"positions keep about {digits:.0f} significant digits within the scene (16 "
            f"at the origin), and the integration's errors grow with that. Move the "
            f"origin to the scene: w.shift_origin(w.center_of_mass()) (journaled; "
            f"velocities and the motion are unchanged)"), stacklevel=caller_level())


# ---------------------------------------------------------------- diagnostics
# Diagnostics cover every body by default. With pulling_only=True they cover the bodies that
# pull only: when passive bodies have mass (ships), those are the quantities the dynamics
# conserve, since a passive body is pulled without pulling back.
def _masses(w, pulling_only):
    """(n,) the masses the diagnostics weigh by: 0 for the bodies left out."""
    b = w._b
    return np.where(w.pulls, b.mass[:b.n], 0.0) if pulling_only else b.mass[:b.n]


def gravity_accelerations(w, ids, exact):
    """World.gravity_accelerations: (k, dim) [length / time^2]."""
    b = w._b
    rows = np.arange(b.n, dtype=np.int64) if ids is None else \
        np.asarray(w.index_of(ids, "ids"), np.int64).reshape(-1)
    src, passive, _ = w._sources()
    f = w._forces.gravity_table(b.mass[:b.n], b.ids[:b.n], src, passive, exact)
    out = np.zeros((b.n, 3))
    kforces.accelerations_of(f, w.t, b.pos[:b.n], b.vel[:b.n], out, rows, False)
    return out[rows, :w._dim]


def kinetic_energy(w, pulling_only):
    """sum m v^2 / 2 [mass length^2 / time^2]."""
    b = w._b
    return diagnostics.kinetic_energy(b.vel[:b.n], _masses(w, pulling_only))


def potential_energy(w, pulling_only, exact):
    """World.potential_energy [mass length^2 / time^2]."""
    b = w._b
    src, passive, _ = w._sources()
    passive = passive[:0] if pulling_only else passive
    springs = 0.0
    rows = w._tether_rows()
    if rows is not None:
        both = np.isin(rows, src).all(axis=1) if pulling_only else np.ones(len(rows), bool)
        springs = ktethers.potential(rows[both], w._forces.tether_params[both], b.pos[:b.n])
    return kgravity.potential(w._forces.model(src.size), b.pos[:b.n],
                              _masses(w, pulling_only), src, passive, exact) + springs


def energy(w, pulling_only, exact):
    """Kinetic + potential energy [mass length^2 / time^2]."""
    return w.kinetic_energy(pulling_only) + w.potential_energy(pulling_only, exact)


def momentum(w, pulling_only):
    """(dim,) sum m v [mass length / time]."""
    b = w._b
    return (_masses(w, pulling_only)[:, None] * b.vel[:b.n]).sum(axis=0)[:w._dim]


def angular_momentum(w, pulling_only):
    """sum m r x v about the origin: (3,) in 3D, the scalar z component in 2D."""
    b = w._b
    L = (_masses(w, pulling_only)[:, None] * np.cross(b.pos[:b.n], b.vel[:b.n])).sum(axis=0)
    return L if w._dim == 3 else float(L[2])


def total_mass(w):
    """The live bodies' summed mass [mass]."""
    return float(w._b.mass[:w._b.n].sum())


def center_of_mass(w):
    """(dim,) [length]; ValueError if the total mass is 0."""
    b = w._b
    M = w.total_mass()
    if M <= 0:
        raise ValueError("center_of_mass: the total mass is 0 (only test particles)")
    return (b.mass[:b.n, None] * b.pos[:b.n]).sum(axis=0)[:w._dim] / M


def center_of_mass_velocity(w):
    """(dim,) [length / time]; ValueError if the total mass is 0."""
    M = w.total_mass()
    if M <= 0:
        raise ValueError("center_of_mass_velocity: the total mass is 0 (only test particles)")
    return w.momentum() / M
