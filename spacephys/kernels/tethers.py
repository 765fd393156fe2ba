"""Tethers inside the step: springs and inextensible ropes and rods between pairs of bodies
(World.tether).

A tether joins rows i and j with a length L. With a stiffness k [mass/time^2] it is a
spring: stretched to a distance r it pulls both ends together with the force k (r - L); a
rope (rigid 0) is slack below L and never pushes, a rod (rigid 1) pushes back as hard when
compressed. Its energy k (r - L)^2 / 2 is in World.potential_energy.

With k = 0 it is inextensible: a constraint r = L (a rod) or r <= L (a rope), solved in two
parts. In every force evaluation (`add`, after every other force) it adds the
force that keeps the distance's second derivative zero: along d = p_j - p_i, on j
-lam d and on i +lam d, with

    lam = (|v_j - v_i|^2 + d . (a_j - a_i)) / ((1/m_i + 1/m_j) r^2)

from the other forces' accelerations a (the constraint differentiated twice: the index-1
form of the differential-algebraic equations), so every integrator follows it at its own
order; a rope takes only lam >= 0 (it pulls, never pushes), and only when it was taut at the
step's start (deciding at each stage, a stage's position a hair inside the length would drop
the force there). Tethers sharing
bodies (a chain) are solved together by Gauss-Seidel sweeps. After each step `settle`
projects the drift left by the integration away: the ends moved along d, weighted by their
inverse masses, to r = L exactly, and their relative velocity along d removed (a rope that
pulled through the step as a rod; one that did not, only when it ends the step stretched and
separating: the jerk of a rope snapping taut, which loses that energy). A
fixed end does not move (inverse mass 0).

After each step (an output interval for Gauss-Radau) `settle` also breaks the tethers whose
tension (k |r - L|, or lam r) passed their break force: gone from then on, with a
tether_break event.

    rows (T, 2) int64      the ends' rows
    params (T, 4) float64  [L [length], k [mass/time^2] (0: inextensible), rigid (0 or 1),
                           break force [mass length/time^2] (inf: never)]
    broken (T,) int64      1 once broken in this table's life (World then removes it)
    wanted (n,) bool       scratch: the rows an accelerations call asks for, False between
    fixed (T, 2) bool      whether each end is immovable
    lam (T,) float64       an inextensible tether's lam at the last force evaluation
    count (1,) int64       how many are inextensible
    taut (T,) int64        1: a rope taut at this step's start (rods: always)
"""
from collections import namedtuple

import math

import numpy as np

from .._jit import kernel
from .codes import EV_TETHER_BREAK
from .state import record

TetherArrays = namedtuple("TetherArrays", ("rows", "params", "broken", "wanted", "fixed",
                                           "lam", "count", "taut"))
LENGTH, STIFFNESS, RIGID, BREAK = range(4)
SWEEPS = 32            # Gauss-Seidel sweeps at most, for chains of inextensible tethers
TAUT = 1e-12           # a rope within this fraction of its length is taut (projection's
                       # rounding leaves it a hair short)


def make(rows, params, fixed, pos):
    """The kernels' tethers (rows, params: see the module) for a scene whose bodies' fixed
    flags are fixed (n,) and positions pos (n, 3) now."""
    rows = np.ascontiguousarray(rows, np.int64)
    params = np.ascontiguousarray(params, np.float64)
    r = np.linalg.norm(pos[rows[:, 1]] - pos[rows[:, 0]], axis=1)
    taut = (r >= params[:, LENGTH] * (1.0 - TAUT)) | (params[:, RIGID] != 0.0)
    return TetherArrays(rows, params, np.zeros(rows.shape[0], np.int64),
                        np.zeros(fixed.shape[0], np.bool_), np.ascontiguousarray(fixed[rows]),
                        np.zeros(rows.shape[0]),
                        np.array([np.count_nonzero(params[:, STIFFNESS] == 0.0)], np.int64),
                        taut.astype(np.int64))


@kernel(inline=True)
def _pull(params, k, r):
    """The tension of tether k at distance r (> 0 pulls the ends together, < 0: a rod
    pushes), 0 for a slack rope."""
    s = r - params[k, LENGTH]
    if s <= 0.0 and params[k, RIGID] == 0.0:
        return 0.0
    return params[k, STIFFNESS] * s


@kernel(lean=True)
def add(tt, pos, vel, mass, out, targets):
    """out += the tethers' accelerations of the rows in targets (tt: TetherArrays, or None:
    nothing, and nothing else compiled): the springs', then the inextensible tethers'
    constraint forces against everything in out (every row's)."""
    if tt is None:
        return
    _add_springs(tt, pos, mass, out, targets)
    _add_constraints(tt, pos, vel, mass, out)


@kernel(lean=True)
def _add_springs(tt, pos, mass, out, targets):
    """The springs' accelerations of the rows in targets; a body of mass 0 or fixed is not
    moved."""
    rows, params, broken, wanted = tt.rows, tt.params, tt.broken, tt.wanted
    for a in range(targets.size):
        wanted[targets[a]] = True
    for k in range(rows.shape[0]):
        if broken[k] or params[k, STIFFNESS] == 0.0:
            continue
        i, j = rows[k, 0], rows[k, 1]
        dx, dy, dz = _between(pos, i, j)
        r = math.sqrt(dx * dx + dy * dy + dz * dz)
        if r == 0.0:
            continue
        f = _pull(params, k, r) / r
        if f == 0.0:
            continue
        if wanted[i] and mass[i] > 0.0 and not tt.fixed[k, 0]:
            g = f / mass[i]
            out[i, 0] += g * dx
            out[i, 1] += g * dy
            out[i, 2] += g * dz
        if wanted[j] and mass[j] > 0.0 and not tt.fixed[k, 1]:
            g = f / mass[j]
            out[j, 0] -= g * dx
            out[j, 1] -= g * dy
            out[j, 2] -= g * dz
    for a in range(targets.size):
        wanted[targets[a]] = False


@kernel(inline=True)
def _between(arr, i, j):
    """arr[j] - arr[i] as three numbers (arr (n, 3))."""
    return arr[j, 0] - arr[i, 0], arr[j, 1] - arr[i, 1], arr[j, 2] - arr[i, 2]


@kernel(inline=True)
def _apart(arr, i, j, wi, wj, f, x, y, z):
    """arr[i] += f wi (x, y, z) and arr[j] -= f wj (x, y, z): equal and opposite, weighted
    by the ends' inverse masses."""
    arr[i, 0] += f * wi * x
    arr[i, 1] += f * wi * y
    arr[i, 2] += f * wi * z
    arr[j, 0] -= f * wj * x
    arr[j, 1] -= f * wj * y
    arr[j, 2] -= f * wj * z


@kernel(lean=True)
def constrained(tt):
    """Whether there are inextensible tethers (their force reads velocities)."""
    if tt is None:
        return False
    return tt.count[0] > 0


@kernel(inline=True)
def _inverse(tt, mass, k, e, row):
    """1/m of end e of tether k (0 for a fixed end)."""
    if tt.fixed[k, e] or mass[row] <= 0.0:
        return 0.0
    return 1.0 / mass[row]


@kernel(lean=True)
def _add_constraints(tt, pos, vel, mass, out):
    """out += the inextensible tethers' constraint accelerations (see the module), given the
    accelerations of every other force in out (every row: a constraint couples its ends)."""
    if tt.count[0] == 0:
        return
    rows, params, broken, lam = tt.rows, tt.params, tt.broken, tt.lam
    for k in range(rows.shape[0]):
        lam[k] = 0.0
    for sweep in range(SWEEPS):
        change = 0.0
        scale = 0.0
        for k in range(rows.shape[0]):
            if broken[k] or params[k, STIFFNESS] != 0.0:
                continue
            i, j = rows[k, 0], rows[k, 1]
            dx, dy, dz = _between(pos, i, j)
            r2 = dx * dx + dy * dy + dz * dz
            if r2 == 0.0 or not tt.taut[k]:
                continue                               # a rope slack at the step's start
            wi, wj = _inverse(tt, mass, k, 0, i), _inverse(tt, mass, k, 1, j)
            if wi + wj == 0.0:
                continue
            ux, uy, uz = _between(vel, i, j)
            ax, ay, az = _between(out, i, j)
            d_lam = (ux * ux + uy * uy + uz * uz + dx * ax + dy * ay + dz * az) \
                / ((wi + wj) * r2)
            if params[k, RIGID] == 0.0 and lam[k] + d_lam < 0.0:   # a rope never pushes
                d_lam = -lam[k]
            lam[k] += d_lam
            change = max(change, abs(d_lam))
            scale = max(scale, abs(lam[k]))
            _apart(out, i, j, wi, wj, d_lam, dx, dy, dz)
        if change <= 1e-15 * scale:
            break


@kernel
def settle(tt, state, t0, dt):
    """After a step from t0: the inextensible tethers' drift projected away, then the
    tethers pulling (or pushing) harder than their break force broken, each with a
    tether_break event (see the module)."""
    if tt is None:
        return
    rows, params, broken = tt.rows, tt.params, tt.broken
    pos, vel, ids, mass = state.pos, state.vel, state.ids, state.mass
    if tt.count[0] > 0:
        for sweep in range(SWEEPS // 4):
            for k in range(rows.shape[0]):
                if not broken[k] and params[k, STIFFNESS] == 0.0:
                    _project(tt, k, pos, vel, mass)
        for k in range(rows.shape[0]):           # whether each rope pulls in the next step
            if params[k, RIGID] == 0.0:
                dx, dy, dz = _between(pos, rows[k, 0], rows[k, 1])
                tt.taut[k] = math.sqrt(dx * dx + dy * dy + dz * dz) >= \
                    params[k, LENGTH] * (1.0 - TAUT)
    point = np.empty(3)
    normal = np.empty(3)
    for k in range(rows.shape[0]):
        if broken[k] or params[k, BREAK] == np.inf:
            continue
        i, j = rows[k, 0], rows[k, 1]
        r = 0.0
        for c in range(3):
            normal[c] = pos[j, c] - pos[i, c]
            r += normal[c] * normal[c]
        r = math.sqrt(r)
        tension = _pull(params, k, r) if params[k, STIFFNESS] != 0.0 else tt.lam[k] * r
        if abs(tension) <= params[k, BREAK]:
            continue
        broken[k] = 1
        speed = 0.0
        for c in range(3):
            point[c] = 0.5 * (pos[i, c] + pos[j, c])
            normal[c] = normal[c] / r if r > 0.0 else 0.0
            speed += (vel[j, c] - vel[i, c]) * normal[c]
        stretch = r - params[k, LENGTH]
        record(state, EV_TETHER_BREAK, ids[i], ids[j], t0 + dt, dt, point, normal, speed,
               0.5 * params[k, STIFFNESS] * stretch * stretch, r)


@kernel(lean=True)
def _project(tt, k, pos, vel, mass):
    """Inextensible tether k's ends to r = L along their line (a slack rope left alone),
    then their relative velocity along it removed (a rope's only when separating)."""
    i, j = tt.rows[k, 0], tt.rows[k, 1]
    wi, wj = _inverse(tt, mass, k, 0, i), _inverse(tt, mass, k, 1, j)
    if wi + wj == 0.0:
        return
    dx, dy, dz = _between(pos, i, j)
    r = math.sqrt(dx * dx + dy * dy + dz * dz)
    L = tt.params[k, LENGTH]
    # a rope that pulled through the step is held as a rod is: its drift either way is the
    # integration's, not the rope going slack (which its force, lam 0, would have let it)
    rigid = tt.params[k, RIGID] != 0.0 or (tt.taut[k] and tt.lam[k] > 0.0)
    if r == 0.0 or (not rigid and r < L):
        return
    nx, ny, nz = dx / r, dy / r, dz / r
    _apart(pos, i, j, wi, wj, (r - L) / (wi + wj), nx, ny, nz)
    ux, uy, uz = _between(vel, i, j)
    u = ux * nx + uy * ny + uz * nz
    if not rigid and u <= 0.0:
        return
    _apart(vel, i, j, wi, wj, u / (wi + wj), nx, ny, nz)


def potential(tt_rows, params, pos):
    """The springs' energy sum k (r - L)^2 / 2 over the tethers (rows (T, 2), params (T, 4),
    pos (n, 3)) [mass length^2/time^2]; slack ropes hold none."""
    if not len(tt_rows):
        return 0.0
    r = np.linalg.norm(pos[tt_rows[:, 1]] - pos[tt_rows[:, 0]], axis=1)
    s = r - params[:, LENGTH]
    held = (s > 0.0) | (params[:, RIGID] != 0.0)
    return float(0.5 * np.sum(np.where(held, params[:, STIFFNESS] * s * s, 0.0)))
