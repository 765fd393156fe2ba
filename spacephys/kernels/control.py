"""Ships and missiles inside the step: rotation, guidance, thrust with fuel burn, fuses, lifetimes.

Per step (per output interval for Gauss-Radau) the controls are held: begin_step turns every
actor (ship or missile) for the whole step, takes its thrust direction at mid-step, and fills
one row of `burn` per actor:
    burn[q] = [dx, dy, dz, F, mdot, m0, t_stop, ve, t_start, limit]
a thrust of magnitude F [mass length/time^2] along the unit vector d, burning mdot
[mass/time] from the mass m0, from t_start (0 but for a planned burn starting within the step)
until t_stop [times after the step's start] when the fuel, the burn time or the planned burn
runs out (inf if not within reach); ve = F / mdot; limit is t_stop but for the fuel.
Within the step the thrust acceleration is exact for that burn: with s = tau - t_start,
a(tau) = d F / (m0 - mdot s), whose integrals are
    dv(tau) = -ve log(1 - mdot s / m0)                (Tsiolkovsky)
    p(tau)  = ve m0 / mdot g(mdot s / m0),  g(x) = x + (1 - x) log(1 - x)
(the velocity and the displacement the thrust adds by tau; zero before t_start, constant /
linear after t_stop).

A ship with a plan (rows of `plan`, see FIELDS) is flown by the autopilot while a planned burn
covers the step: heading held along the burn's direction in its frame (taken at the step's
start), the planned throttle, thrust from the burn's start to its stop to the exact time.
Splitting methods drift with these exactly, Runge-Kutta and Gauss-Radau sample a(tau) at their
stages, Wisdom-Holman kicks with dv(dt) / dt. After the integration end_burn books the fuel,
after the collisions after_step fires proximity fuses and ends lifetimes.
Compiled without fastmath: log1p and the series of g carry the small-burn accuracy.
"""
import math
from collections import namedtuple

import numpy as np
from numba import types
from numba.experimental import structref

from .._jit import TableType, field_type, implements, kernel, read
from .codes import (BURN_ANTINORMAL, BURN_NORMAL, BURN_PROGRADE, BURN_RADIAL_IN,
                    BURN_RETROGRADE, BURN_VECTOR, EV_BURNOUT, EV_DETONATION, EV_EXPIRY,
                    EV_FUEL_EMPTY, NO_GUIDANCE, PURSUIT)
from .rules import wrap
from .state import hoist as state_arrays, record
from . import libm
from .rotations import normalised, qexp, qmul, rotate

# pending events (the lean functions cannot grow the event buffer; flush records them): a row
# each, [kind, row i, row j (-1: none), time into the step, point (3,), normal (3,), speed,
# distance]
PENDING = 12

# flags: what has been reported once, a missile that never meets its launcher (armed or
# not: MissileSpec.hits_launcher False), and a rotor: a body with an orientation and no
# engine (World.set_heading or set_body(angular_velocity=) on a body that is not an actor;
# no thrust, infinite inertia: it keeps its spin)
_FLAG_EMPTY, _FLAG_BURNOUT, FLAG_SPARES, FLAG_ROTOR = 1, 2, 4, 8
# burn columns
DX, DY, DZ, F, MDOT, M0, T_STOP, VE, T_START, LIMIT = range(10)
# plan columns (a row per planned burn; a ship's rows sorted by start, not overlapping)
P_START, P_STOP, P_DIRECTION, P_FRAME, P_THROTTLE = range(5)   # then 5-7: vector, 8-10: point


@structref.register
class ActorsType(TableType):
    pass


class Actors(structref.StructRefProxy):
    """The actors' table (see FIELDS); made by `make`, read and updated by the kernels."""


FIELDS = (
    "actors",      # (A,) int64 rows of the ships and missiles
    "quat",        # (n, 4) orientation quaternion (w, x, y, z): body x is the heading
    "omega",       # (n, 3) body-frame angular velocity [rad/time] (physical rotation)
    "throttle",    # (n,) in [0, 1]
    "turn",        # (n, 3) body-frame turn commands in [-1, 1] (roll, pitch, yaw); 2D: z
    "strafe",      # (n, 3) body-frame side thrust commands in [-1, 1]; x unused
    "dry",         # (n,) dry mass [mass]
    "fuel",        # (n,) fuel left [mass]
    "thrust",      # (n,) main engine thrust at full throttle [mass length/time^2]
    "side",        # (n,) side thrusters' thrust at full command
    "exhaust",     # (n,) exhaust speed [length/time]
    "turn_rate",   # (n,) arcade turning at full command [rad/time]
    "inertia",     # (n,) moment of inertia; > 0 selects physical rotation [mass length^2]
    "torque",      # (n,) torque at full command [mass length^2/time^2]
    "curve",       # (n, 2) int64: first row and row count in curve_table (0 rows: factor 1)
    "curve_table",  # (K, 2) speed [length/time], thrust factor: piecewise linear
    "guidance",    # (n,) int64: NO_GUIDANCE | PURSUIT | PROPORTIONAL
    "nav",         # (n,) navigation constant N of proportional navigation
    "target",      # (n,) int64 row of the target, -1 none
    "burn_end",    # (n,) time the motor stops (inf: never) [time]
    "armed_at",    # (n,) time the fuse arms [time]
    "fuse",        # (n,) proximity fuse radius (0: none) [length]
    "kill",        # (n,) bool: a detonation destroys the target too
    "flags",       # (n,) int64: _FLAG_* already reported
    "expires",     # (n,) time of expiry (inf: never), or (0,) when no body has a lifetime
    "dim",         # 2 or 3
    "plan",        # (P, 11) planned burns: start, stop [time], direction code (codes.py),
                   # frame row (-1: the fixed point), throttle, vector (3,), fixed point (3,);
                   # None when no ship has a plan (the autopilot is then not compiled)
    "clock",       # (2,) the World's time base and step count at this step's start (World
                   # sets it before a call, end_burn counts): a plan is timed as World.t is
    "planned",     # (A, 2) int64: first row and row count of each actor's burns in plan;
                   # None with plan
    "burn",        # (A, 10) this step's burn per actor (see the module)
    "saved",       # (A, 7) orientations and rates at the step's start, to undo a failed step
    "pending",     # (3A + len(expires), PENDING) a step's events queued for flush: fuel and
                   # burn time out and a detonation per actor, an expiry per body (PENDING)
)
structref.define_proxy(Actors, ActorsType, list(FIELDS))

# the table's fields as a tuple, read once before a kernel's step loop (step.hoist): the
# per-step functions below take it and are compiled without reference counting (_jit lean)
ActorArrays = namedtuple("ActorArrays", FIELDS)


@kernel(inline=True)
def hoist(act):
    """The Actors table's fields as an ActorArrays tuple."""
    return read(act, ActorArrays)


@kernel
def _make(*fields):
    return Actors(*fields)


def make(columns, actors, target, curve_table, expires, dim, plan, clock, planned):
    """An Actors table: columns maps the per-body FIELDS (quat ... flags but target) to (n, ...)
    arrays, shared, not copied; actors (A,) rows, target (n,) rows, expires (n,) or (0,);
    plan (P, 11), the clock (2,) (shared) and planned (A, 2): the planned burns (plan and
    planned None when no ship has a plan)."""
    fields = dict(columns, actors=actors, target=target, curve_table=curve_table,
                  expires=expires, dim=int(dim), plan=plan, clock=clock, planned=planned,
                  burn=np.zeros((actors.size, 10)), saved=np.zeros((actors.size, 7)),
                  # written before read
                  pending=np.empty((3 * actors.size + expires.shape[0], PENDING)))
    return _make(*(fields[name] for name in FIELDS))


@kernel(inline=True)
def _curve_factor(act, i, speed):
    """The thrust curve at this speed: piecewise linear through the table rows, flat beyond."""
    first = act.curve[i, 0]
    count = act.curve[i, 1]
    if count == 0:
        return 1.0
    table = act.curve_table
    if speed <= table[first, 0]:
        return table[first, 1]
    for k in range(first + 1, first + count):
        if speed <= table[k, 0]:
            s0, f0 = table[k - 1, 0], table[k - 1, 1]
            s1, f1 = table[k, 0], table[k, 1]
            return f0 + (f1 - f0) * (speed - s0) / (s1 - s0)
    return table[first + count - 1, 1]


@kernel(inline=True)
def _desired(act, i, j, pos, vel, hx, hy, hz, a_max, L):
    """The direction guidance asks missile i to accelerate in, toward target j; the heading
    when there is nothing to do. Pursuit: along the line of sight. Proportional navigation:
    the lateral acceleration N Vc (line-of-sight rate) = N Vc v_perp / |r|, plus whatever
    thrust is left along the line of sight to close; pursuit while the range opens."""
    rx = wrap(pos[j, 0] - pos[i, 0], L[0])           # the nearest image when wrapping
    ry = wrap(pos[j, 1] - pos[i, 1], L[1])
    rz = wrap(pos[j, 2] - pos[i, 2], L[2])
    r = math.sqrt(rx * rx + ry * ry + rz * rz)
    if r == 0.0:
        return hx, hy, hz
    ux, uy, uz = rx / r, ry / r, rz / r
    if act.guidance[i] == PURSUIT:
        return ux, uy, uz
    wx = vel[j, 0] - vel[i, 0]
    wy = vel[j, 1] - vel[i, 1]
    wz = vel[j, 2] - vel[i, 2]
    along = wx * ux + wy * uy + wz * uz
    closing = -along
    if closing <= 0.0:
        return ux, uy, uz
    k = act.nav[i] * closing / r
    cx = k * (wx - along * ux)
    cy = k * (wy - along * uy)
    cz = k * (wz - along * uz)
    c2 = cx * cx + cy * cy + cz * cz
    rest = a_max * a_max - c2
    if rest > 0.0:
        s = math.sqrt(rest)
        cx += s * ux
        cy += s * uy
        cz += s * uz
    norm = math.sqrt(cx * cx + cy * cy + cz * cz)
    if norm == 0.0:
        return ux, uy, uz
    return cx / norm, cy / norm, cz / norm


@kernel
def _turn_toward(q0, q1, q2, q3, hx, hy, hz, dx, dy, dz, max_angle, dim):
    """The world-frame rotation (axis, angle) turning heading h toward d by at most max_angle."""
    ax = hy * dz - hz * dy
    ay = hz * dx - hx * dz
    az = hx * dy - hy * dx
    s = math.sqrt(ax * ax + ay * ay + az * az)
    c = hx * dx + hy * dy + hz * dz
    angle = libm.atan2(s, c)
    if s < 1e-300:
        if c > 0.0:
            return 0.0, 0.0, 1.0, 0.0
        # straight behind: turn about the body's own z (2D: the plane's normal)
        ax, ay, az = (0.0, 0.0, 1.0) if dim == 2 else rotate(q0, q1, q2, q3, 0.0, 0.0, 1.0)
        s = math.sqrt(ax * ax + ay * ay + az * az)
    return ax / s, ay / s, az / s, min(angle, max_angle)


# ---------------------------------------------------------------- the burn
@kernel
def _g(x):
    """x + (1 - x) log(1 - x) = sum_{k>=2} x^k / (k (k - 1)), without cancellation."""
    if abs(x) < 0.05:
        s = 0.0
        p = x * x
        for k in range(2, 20):
            s += p / (k * (k - 1))
            p *= x
        return s
    return x + (1.0 - x) * libm.log1p(-x)


@kernel
def thrust_dv(burn, q, tau):
    """Speed the thrust has added along d by tau [time after the step's start]."""
    s = min(tau, burn[q, T_STOP]) - burn[q, T_START]
    if s < 0.0 and burn[q, T_START] > 0.0:
        return 0.0                       # not started (a burn on from the step's start is
                                         # continued to the negative times of Yoshida's drifts)
    return -burn[q, VE] * libm.log1p(-burn[q, MDOT] * s / burn[q, M0])


@kernel
def thrust_p(burn, q, tau):
    """Displacement along d the thrust has added by tau (the integral of thrust_dv)."""
    t_stop = burn[q, T_STOP]
    s = min(tau, t_stop) - burn[q, T_START]
    if s < 0.0 and burn[q, T_START] > 0.0:
        return 0.0
    x = burn[q, MDOT] * s / burn[q, M0]
    p = burn[q, VE] * burn[q, M0] / burn[q, MDOT] * _g(x)
    if tau > t_stop:
        p += thrust_dv(burn, q, t_stop) * (tau - t_stop)
    return p


@kernel(inline=True)
def drift_thrust(actors, burn, pos, vel, ta, tb):
    """The thrust's exact share of a drift from ta to tb [time after the step's start]: call
    after pos += (tb - ta) vel, with vel still that at ta."""
    for q in range(actors.size):
        if burn[q, F] == 0.0:
            continue
        i = actors[q]
        dva = thrust_dv(burn, q, ta)
        dv = thrust_dv(burn, q, tb) - dva
        dp = thrust_p(burn, q, tb) - thrust_p(burn, q, ta) - dva * (tb - ta)
        for c in range(3):
            pos[i, c] += dp * burn[q, c]
            vel[i, c] += dv * burn[q, c]


@kernel(lean=True)
def add_thrust(actors, burn, acc, tau, mask, want):
    """acc += the thrust acceleration at tau [time after the step's start], for every actor
    (want = -1) or for those whose row has mask[i] == want (0 or 1)."""
    for q in range(actors.size):
        if burn[q, F] == 0.0 or not tau < burn[q, T_STOP] or \
                (tau < burn[q, T_START] and burn[q, T_START] > 0.0):
            continue
        i = actors[q]
        if want >= 0 and mask[i] != (want == 1):
            continue
        a = burn[q, F] / (burn[q, M0] - burn[q, MDOT] * (tau - burn[q, T_START]))
        for c in range(3):
            acc[i, c] += a * burn[q, c]


@kernel(lean=True)
def rk_thrust_fix(actors, burn, vel, a, b, dt):
    """Replace the Runge-Kutta quadrature of the thrust, dt sum_s b_s a(c_s dt), in vel by its
    exact integral dv(dt): Tsiolkovsky holds to rounding, the order of the method is kept."""
    for q in range(actors.size):
        if burn[q, F] == 0.0:
            continue
        quad = 0.0
        for s in range(b.size):
            tau = 0.0
            for j in range(s):
                tau += a[s, j]
            tau *= dt
            if tau < burn[q, T_STOP] and (tau >= burn[q, T_START] or burn[q, T_START] == 0.0):
                quad += b[s] * burn[q, F] / (burn[q, M0]
                                             - burn[q, MDOT] * (tau - burn[q, T_START]))
        dv = thrust_dv(burn, q, dt) - dt * quad
        i = actors[q]
        for c in range(3):
            vel[i, c] += dv * burn[q, c]


@kernel
def snap_stops(actors, burn, now, eps):
    """Burns starting or stopping within eps of now do so now (exactly: a step starting there
    sees them on (off), instead of off (on) at its first node and on (off) at the next)."""
    for q in range(actors.size):
        if burn[q, F] != 0.0:
            if burn[q, T_START] > 0.0 and abs(burn[q, T_START] - now) <= eps:
                burn[q, T_START] = now
            if abs(burn[q, T_STOP] - now) <= eps:
                burn[q, T_STOP] = now


@kernel
def next_stop(actors, burn, after):
    """The earliest t_start or t_stop later than `after` (inf if none): where thrust jumps."""
    best = np.inf
    for q in range(actors.size):
        if burn[q, F] != 0.0:
            if burn[q, T_START] > after:
                best = min(best, burn[q, T_START])
            if burn[q, T_STOP] > after:
                best = min(best, burn[q, T_STOP])
    return best


@kernel(lean=True, by_address=True, returns=types.none)
def begin_step(table, owner, actors, t0, dt, L):
    """Arm fuses (the collision table's owners), keep every actor's orientation (for
    undo_turns), turn every live actor over the step and set its burn in burn (see the
    module). table, actors : the State and Actors tables, whole (through the slot a table
    is a pointer; its arrays, hoisted, would be hundreds of arguments: 50 ns a step);
    owner : step.hoist's; L : 3-tuple, the periods of a wrapping boundary (zeros: none)."""
    state, act = state_arrays(table), hoist(actors)
    actors = act.actors
    alive = state.alive
    pos, vel, mass, burn = state.pos, state.vel, state.mass, act.burn
    for q in range(actors.size):
        i = actors[q]
        for k in range(4):
            act.saved[q, k] = act.quat[i, k]
        for k in range(3):
            act.saved[q, 4 + k] = act.omega[i, k]
    for q in range(actors.size):
        i = actors[q]
        for k in range(10):
            burn[q, k] = 0.0
        burn[q, T_STOP] = np.inf
        burn[q, LIMIT] = np.inf
        burn[q, M0] = 1.0
        if not alive[i]:
            continue
        if owner.size and owner[i] >= 0 and t0 >= act.armed_at[i] and \
                act.flags[i] & FLAG_SPARES == 0:
            owner[i] = -1                            # armed: its launcher can be hit now
        if _flies_plan(act, q, i, state, t0, dt):
            continue
        q0, q1, q2, q3 = act.quat[i, 0], act.quat[i, 1], act.quat[i, 2], act.quat[i, 3]
        hx, hy, hz = rotate(q0, q1, q2, q3, 1.0, 0.0, 0.0)
        speed = math.sqrt(vel[i, 0] ** 2 + vel[i, 1] ** 2 + vel[i, 2] ** 2)
        burning = act.fuel[i] > 0.0 and t0 < act.burn_end[i]
        main = act.throttle[i] * act.thrust[i] * _curve_factor(act, i, speed) \
            if burning else 0.0
        j = act.target[i]
        if act.guidance[i] != NO_GUIDANCE and j >= 0 and alive[j]:
            # a world-frame turn toward what guidance asks for, at most turn_rate dt
            a_max = main / mass[i] if mass[i] > 0.0 else 0.0
            dx, dy, dz = _desired(act, i, j, pos, vel, hx, hy, hz, a_max, L)
            ax, ay, az, angle = _turn_toward(q0, q1, q2, q3, hx, hy, hz, dx, dy, dz,
                                             act.turn_rate[i] * dt, act.dim)
            m0, m1, m2, m3 = qexp(ax, ay, az, 0.5 * angle)
            e0, e1, e2, e3 = qexp(ax, ay, az, angle)
            h0, h1, h2, h3 = qmul(m0, m1, m2, m3, q0, q1, q2, q3)
            n0, n1, n2, n3 = qmul(e0, e1, e2, e3, q0, q1, q2, q3)
        else:
            # body-frame rates: commanded (arcade) or from torque (physical, the step's mean)
            if act.inertia[i] > 0.0:
                wx = act.omega[i, 0]
                wy = act.omega[i, 1]
                wz = act.omega[i, 2]
                f = act.torque[i] / act.inertia[i] * dt
                act.omega[i, 0] += f * act.turn[i, 0]
                act.omega[i, 1] += f * act.turn[i, 1]
                act.omega[i, 2] += f * act.turn[i, 2]
                wx = 0.5 * (wx + act.omega[i, 0])
                wy = 0.5 * (wy + act.omega[i, 1])
                wz = 0.5 * (wz + act.omega[i, 2])
            else:
                wx = act.turn_rate[i] * act.turn[i, 0]
                wy = act.turn_rate[i] * act.turn[i, 1]
                wz = act.turn_rate[i] * act.turn[i, 2]
            m0, m1, m2, m3 = qexp(wx, wy, wz, 0.5 * dt)
            e0, e1, e2, e3 = qexp(wx, wy, wz, dt)
            h0, h1, h2, h3 = qmul(q0, q1, q2, q3, m0, m1, m2, m3)
            n0, n1, n2, n3 = qmul(q0, q1, q2, q3, e0, e1, e2, e3)
        n0, n1, n2, n3 = normalised(n0, n1, n2, n3)
        act.quat[i, 0] = n0
        act.quat[i, 1] = n1
        act.quat[i, 2] = n2
        act.quat[i, 3] = n3
        if not burning:
            continue
        # thrust along the mid-step frame: main along x, side thrusters along y and z
        fx, fy, fz = rotate(h0, h1, h2, h3, main, 0.0, 0.0)
        sy = act.side[i] * act.strafe[i, 1]
        sz = act.side[i] * act.strafe[i, 2]
        px, py, pz = rotate(h0, h1, h2, h3, 0.0, sy, sz)
        fx += px
        fy += py
        fz += pz
        force = math.sqrt(fx * fx + fy * fy + fz * fz)
        if force == 0.0 or mass[i] <= 0.0:
            continue
        mdot = (abs(main) + abs(sy) + abs(sz)) / act.exhaust[i]
        burn[q, DX] = fx / force
        burn[q, DY] = fy / force
        burn[q, DZ] = fz / force
        burn[q, F] = force
        burn[q, MDOT] = mdot
        burn[q, M0] = mass[i]
        burn[q, LIMIT] = act.burn_end[i] - t0
        burn[q, T_STOP] = min(act.fuel[i] / mdot, burn[q, LIMIT])
        burn[q, VE] = force / mdot


@kernel(lean=True)
def _plan_direction(act, k, i, pos, vel):
    """The unit direction of planned burn k for the body in row i, from its state relative to
    the burn's frame now; (0, 0, 0) when the direction is undefined (no motion relative to
    the frame)."""
    plan = act.plan
    code = int(plan[k, P_DIRECTION])
    if code == BURN_VECTOR:
        return plan[k, 5], plan[k, 6], plan[k, 7]
    j = int(plan[k, P_FRAME])
    rx, ry, rz = pos[i, 0] - plan[k, 8], pos[i, 1] - plan[k, 9], pos[i, 2] - plan[k, 10]
    vx, vy, vz = vel[i, 0], vel[i, 1], vel[i, 2]
    if j >= 0:
        rx, ry, rz = pos[i, 0] - pos[j, 0], pos[i, 1] - pos[j, 1], pos[i, 2] - pos[j, 2]
        vx, vy, vz = vx - vel[j, 0], vy - vel[j, 1], vz - vel[j, 2]
    hx, hy, hz = ry * vz - rz * vy, rz * vx - rx * vz, rx * vy - ry * vx
    if code == BURN_PROGRADE or code == BURN_RETROGRADE:
        dx, dy, dz = vx, vy, vz
    elif code == BURN_NORMAL or code == BURN_ANTINORMAL:
        dx, dy, dz = hx, hy, hz
    else:                        # radial out: r's part normal to v, in the orbit's plane
        dx, dy, dz = vy * hz - vz * hy, vz * hx - vx * hz, vx * hy - vy * hx
    norm = math.sqrt(dx * dx + dy * dy + dz * dz)
    if norm == 0.0:
        return 0.0, 0.0, 0.0
    if code == BURN_RETROGRADE or code == BURN_ANTINORMAL or code == BURN_RADIAL_IN:
        norm = -norm
    return dx / norm, dy / norm, dz / norm


def _flies_plan(act, q, i, state, t0, dt):
    """Whether actor q flies a planned burn in the step from t0 (_fly_plan set it); False
    without plans."""


implements(_flies_plan, lambda act, q, i, state, t0, dt: False,
           lambda act, *rest: isinstance(field_type(act, "planned"), types.NoneType))
implements(_flies_plan, lambda act, q, i, state, t0, dt:
           act.planned[q, 1] > 0 and _fly_plan(act, q, i, state, t0, dt),
           lambda act, *rest: not isinstance(field_type(act, "planned"), types.NoneType),
           inline=True)


@kernel(lean=True)
def _fly_plan(act, q, i, state, t0, dt):
    """The autopilot: when one of actor q's planned burns covers part of the step from t0,
    hold the heading along its direction (rates zeroed), set the burn from its start to its
    stop and return True; False when none does (the ship's own controls fly the step)."""
    plan = act.plan
    first, count = act.planned[q, 0], act.planned[q, 1]
    # the step's start as World.t computes it, whatever the steps' grouping into calls: a
    # prediction in one call and the game's step(1) calls then time a burn to the same bit
    t0 = act.clock[0] + act.clock[1] * dt
    t1 = t0 + dt
    k = -1
    for r in range(first, first + count):
        if plan[r, P_START] < t1 and plan[r, P_STOP] > t0:
            k = r
            break
    if k < 0:
        return False
    dx, dy, dz = _plan_direction(act, k, i, state.pos, state.vel)
    if dx == 0.0 and dy == 0.0 and dz == 0.0:
        return False
    # the heading's quaternion: the shortest rotation taking body x to d (2D: about z)
    c = dx
    if c < -1.0 + 1e-15:
        q0, q1, q2, q3 = 0.0, 0.0, 0.0, 1.0
    else:
        q0, q1, q2, q3 = normalised(1.0 + c, 0.0, -dz, dy)
    act.quat[i, 0] = q0
    act.quat[i, 1] = q1
    act.quat[i, 2] = q2
    act.quat[i, 3] = q3
    for c3 in range(3):
        act.omega[i, c3] = 0.0
    if not (act.fuel[i] > 0.0 and t0 < act.burn_end[i]):
        return True
    speed = math.sqrt(state.vel[i, 0] ** 2 + state.vel[i, 1] ** 2 + state.vel[i, 2] ** 2)
    force = plan[k, P_THROTTLE] * act.thrust[i] * _curve_factor(act, i, speed)
    mass = state.mass[i]
    if force == 0.0 or mass <= 0.0:
        return True
    burn = act.burn
    mdot = force / act.exhaust[i]
    start = max(plan[k, P_START] - t0, 0.0)
    limit = min(plan[k, P_STOP] - t0, act.burn_end[i] - t0)
    if not limit > start:
        return True                      # the ship's burn time ends first
    burn[q, DX] = dx
    burn[q, DY] = dy
    burn[q, DZ] = dz
    burn[q, F] = force
    burn[q, MDOT] = mdot
    burn[q, M0] = mass
    burn[q, T_START] = start
    burn[q, LIMIT] = limit
    burn[q, T_STOP] = min(start + act.fuel[i] / mdot, burn[q, LIMIT])
    burn[q, VE] = act.exhaust[i]
    return True


@kernel(lean=True)
def end_burn(ht, t0, dt):
    """Book the fuel the step burned; report fuel running out and burn times ending (into
    the pending rows: returns how many, for flush); count the step on the clock."""
    state, act = ht.state, ht.actors
    pending = act.pending
    act.clock[1] += 1.0
    actors = act.actors
    pos, mass, burn = state.pos, state.mass, act.burn
    m = 0
    for q in range(actors.size):
        i = actors[q]
        if not state.alive[i]:
            continue
        if burn[q, F] != 0.0:
            t_burn = min(dt, burn[q, T_STOP])
            fuel = act.fuel[i] - burn[q, MDOT] * (t_burn - burn[q, T_START])
            # empty within the step, or left with the rounding of the subtractions (which
            # would burn for a sliver of the next step)
            empty = burn[q, T_START] + act.fuel[i] / burn[q, MDOT] <= min(dt, burn[q, LIMIT]) \
                or fuel <= 1e-9 * burn[q, MDOT] * dt
            if empty:
                fuel = 0.0
                if act.flags[i] & _FLAG_EMPTY == 0:
                    act.flags[i] |= _FLAG_EMPTY
                    m = _pend(pending, m, EV_FUEL_EMPTY, i, -1, t_burn, pos[i, 0], pos[i, 1],
                              pos[i, 2], 0.0, 0.0, 0.0, 0.0, 0.0)
            act.fuel[i] = max(fuel, 0.0)
            mass[i] = act.dry[i] + act.fuel[i]     # exactly dry once the fuel is gone
        end = act.burn_end[i]
        if t0 < end <= t0 + dt and act.fuel[i] > 0.0 and act.flags[i] & _FLAG_BURNOUT == 0:
            act.flags[i] |= _FLAG_BURNOUT
            m = _pend(pending, m, EV_BURNOUT, i, -1, end - t0, pos[i, 0], pos[i, 1], pos[i, 2],
                      0.0, 0.0, 0.0, 0.0, 0.0)
    return m


@kernel(inline=True)
def _pend(pending, m, kind, i, j, t_in_step, px, py, pz, nx, ny, nz, speed, distance):
    """Write pending row m (see PENDING); returns m + 1."""
    pending[m, 0] = kind
    pending[m, 1] = i
    pending[m, 2] = j
    pending[m, 3] = t_in_step
    pending[m, 4] = px
    pending[m, 5] = py
    pending[m, 6] = pz
    pending[m, 7] = nx
    pending[m, 8] = ny
    pending[m, 9] = nz
    pending[m, 10] = speed
    pending[m, 11] = distance
    return m + 1


@kernel
def flush(state, ht, m, t0):
    """Record the first m pending rows (the Actors table's) as events of the step from t0, in
    order."""
    pending = ht.actors.pending
    ids = state.ids
    point = np.empty(3)
    normal = np.empty(3)
    for r in range(m):
        i, j = int(pending[r, 1]), int(pending[r, 2])
        for c in range(3):
            point[c] = pending[r, 4 + c]
            normal[c] = pending[r, 7 + c]
        record(state, int(pending[r, 0]), ids[i], ids[j] if j >= 0 else -1,
               t0 + pending[r, 3], pending[r, 3], point, normal, pending[r, 10], 0.0,
               pending[r, 11])


@kernel(lean=True, by_address=True, returns=types.Tuple((types.bool_, types.int64)))
def after_step(table, actors, t0, dt, L):
    """Proximity fuses (the closest approach along both bodies' straight lines over the step)
    and lifetimes, their events into the pending rows (table, actors: as begin_step's).
    Returns (a body died (World must remove it, and may spawn its explosion), pending rows
    written)."""
    state, act = state_arrays(table), hoist(actors)
    pending = act.pending
    alive = state.alive
    pos0, pos = state.pos0, state.pos
    died = False
    m = 0
    actors = act.actors
    for q in range(actors.size):
        i = actors[q]
        j = act.target[i]
        if act.fuse[i] <= 0.0 or j < 0 or not alive[i] or not alive[j]:
            continue
        # nearest images when wrapping: pos is already wrapped into the box
        d0x = wrap(pos0[j, 0] - pos0[i, 0], L[0])
        d0y = wrap(pos0[j, 1] - pos0[i, 1], L[1])
        d0z = wrap(pos0[j, 2] - pos0[i, 2], L[2])
        ex = wrap(pos[j, 0] - pos0[j, 0], L[0]) - wrap(pos[i, 0] - pos0[i, 0], L[0])
        ey = wrap(pos[j, 1] - pos0[j, 1], L[1]) - wrap(pos[i, 1] - pos0[i, 1], L[1])
        ez = wrap(pos[j, 2] - pos0[j, 2], L[2]) - wrap(pos[i, 2] - pos0[i, 2], L[2])
        ee = ex * ex + ey * ey + ez * ez
        s = 0.0
        if ee > 0.0:
            s = min(max(-(d0x * ex + d0y * ey + d0z * ez) / ee, 0.0), 1.0)
        armed = act.armed_at[i]
        if t0 + s * dt < armed:
            if t0 + dt < armed:
                continue
            # armed within the step, after the closest approach: the range only grows from
            # then on, so the arming moment is the closest armed one
            s = (armed - t0) / dt
        nx, ny, nz = d0x + s * ex, d0y + s * ey, d0z + s * ez
        dist2 = nx * nx + ny * ny + nz * nz
        fuse = act.fuse[i]
        if dist2 > fuse * fuse:
            continue
        dist = math.sqrt(dist2)
        closing = 0.0
        if dist > 0.0:
            nx, ny, nz = nx / dist, ny / dist, nz / dist
            closing -= nx * ex / dt
            closing -= ny * ey / dt
            closing -= nz * ez / dt
        px = pos0[i, 0] + s * wrap(pos[i, 0] - pos0[i, 0], L[0])
        py = pos0[i, 1] + s * wrap(pos[i, 1] - pos0[i, 1], L[1])
        pz = pos0[i, 2] + s * wrap(pos[i, 2] - pos0[i, 2], L[2])
        m = _pend(pending, m, EV_DETONATION, i, j, s * dt, px, py, pz, nx, ny, nz, closing,
                  dist)
        alive[i] = False
        if act.kill[i]:
            alive[j] = False
        died = True
    if act.expires.size:
        t1 = t0 + dt
        for i in range(pos.shape[0]):
            if alive[i] and act.expires[i] <= t1:
                alive[i] = False
                died = True
                m = _pend(pending, m, EV_EXPIRY, i, -1, max(act.expires[i] - t0, 0.0),
                          pos[i, 0], pos[i, 1], pos[i, 2], 0.0, 0.0, 0.0, 0.0, 0.0)
    return died, m


@kernel
def undo_turns(act):
    """Put every actor's orientation and rate back to where begin_step found them."""
    for q in range(act.actors.size):
        i = act.actors[q]
        for k in range(4):
            act.quat[i, k] = act.saved[q, k]
        for k in range(3):
            act.omega[i, k] = act.saved[q, 4 + k]
