"""Wisdom-Holman mapping in Jacobi coordinates: Kepler drifts + interaction kicks.

J. Wisdom & M. Holman, AJ 102 (1991) 1528: H = H_Kepler + H_interaction in Jacobi coordinates,
each body k >= 1 on a Kepler orbit of mu_k = G M_k about the centre of mass of bodies 0..k-1
(M_k: the mass of bodies 0..k). Drift-kick-drift, the half drifts of successive steps merged.
The kick is the N-body acceleration transformed to Jacobi coordinates minus its Kepler part,
a'_int = J(a) + G M_k x'_k / |x'_k|^3; exact because the Jacobi transformation is linear and
diagonalises the kinetic energy. Optional third-order symplectic corrector of Wisdom, Holman &
Touma, Fields Inst. Commun. 10 (1996) 217.

The Kepler drift solves the universal Kepler equation r0 s + eta0 G2(s) + zeta0 G3(s) = dt for
the universal anomaly s (Danby, Fundamentals of Celestial Mechanics, 2nd ed. 1988, ch. 6.9;
G_n = s^n c_n(beta s^2) with Stumpff's c_n), one formula for elliptic, parabolic and hyperbolic
orbits, by Halley's method from a Taylor or mean-anomaly start, inside a bracket of the root
(the equation is monotonic in s) that bisection falls back on. No fastmath: the solver's
convergence test and the Stumpff functions' cancellations need exact rounding.
"""
import math
from collections import namedtuple

import numpy as np

from .._jit import kernel
from . import step
from .arrays import zeroed
from .control import F, thrust_dv
from .forces import accelerations
from .step import next_frame
from . import libm

# 1/n! for n = 0..25, for the Stumpff series
_INV_FACTORIAL = tuple(1.0 / math.factorial(n) for n in range(26))


@kernel
def _stumpff23(z):
    """Stumpff c2(z) = (1 - cos sqrt z) / z and c3(z) = (sqrt z - sin sqrt z) / z^(3/2), with
    their continuations for z <= 0; the series near 0, where the closed forms cancel."""
    az = abs(z)
    if az < 1.0:
        # c2 = sum_k (-z)^k / (2k+2)!, c3 = sum_k (-z)^k / (2k+3)!, to k = K where the next
        # term is below 1e-19 of the sum: K = 11 for |z| < 1, 7 below 0.1, 5 below 0.01
        top = 11 if az >= 0.1 else (7 if az >= 0.01 else 5)
        c2 = _INV_FACTORIAL[2 * top + 2]
        c3 = _INV_FACTORIAL[2 * top + 3]
        for k in range(top - 1, -1, -1):
            c2 = _INV_FACTORIAL[2 * k + 2] - z * c2
            c3 = _INV_FACTORIAL[2 * k + 3] - z * c3
        return c2, c3
    if z > 0.0:
        w = math.sqrt(z)
        h = libm.sin(0.5 * w)
        return 2.0 * h * h / z, (w - libm.sin(w)) / (z * w)
    w = math.sqrt(-z)
    h = libm.sinh(0.5 * w)
    return -2.0 * h * h / z, (libm.sinh(w) - w) / (-z * w)


@kernel
def _eccentric_anomaly(M, e):
    """E with E - e sin E = M (0 <= e < 1): Newton from Danby's start M + 0.85 e sign(sin M)."""
    M = M - 2.0 * math.pi * math.floor(M / (2.0 * math.pi) + 0.5)      # to [-pi, pi)
    E = M + 0.85 * e * (1.0 if libm.sin(M) >= 0.0 else -1.0)
    for _ in range(30):
        dE = (E - e * libm.sin(E) - M) / (1.0 - e * libm.cos(E))
        E -= dE
        if abs(dE) <= 1e-15:
            break
    return E


@kernel
def _initial_s(r0, eta0, v2sq, beta, mu, dt):
    """A starting value of the universal anomaly s for a drift of dt."""
    if dt * dt * v2sq < 0.09 * r0 * r0:                # |dt| v < 0.3 r0, without a sqrt
        # a short step on the local scale r0 / v: the Taylor series of s(dt) to third order,
        # from dt = r0 s + eta0 s^2 / 2 + zeta0 s^3 / 6 + ...
        zeta0 = mu - beta * r0
        u = dt / r0
        return u * (1.0 + u * (-0.5 * eta0 / r0 + u * (0.5 * eta0 * eta0 / (r0 * r0)
                                                     - zeta0 / (6.0 * r0))))
    if beta <= 0.0:
        # unbound, long step: r grows like exp(w s), w = sqrt(-beta), so dt ~ C exp(w |s|)
        w = math.sqrt(-beta) if beta < 0.0 else 1e-300
        zeta0 = mu - beta * r0
        return math.copysign(libm.log1p(2.0 * w * w * w * abs(dt) / (abs(eta0) * w + zeta0)) / w, dt)
    # bound orbit, long step: through the mean anomaly, s = (E1 - E0) / sqrt(beta)
    sqb = math.sqrt(beta)
    ecosE = 1.0 - r0 * beta / mu
    esinE = eta0 * sqb / mu
    e = math.hypot(ecosE, esinE)
    E0 = libm.atan2(esinE, ecosE)
    dM = beta * sqb / mu * dt                                      # mean motion * dt
    E1 = _eccentric_anomaly(E0 - esinE + dM, e)
    dE = E1 - E0
    dE += 2.0 * math.pi * math.floor((dM - dE) / (2.0 * math.pi) + 0.5)  # the branch near dM
    return dE / sqb


@kernel
def kepler_drift(x, v, k, mu, dt):
    """Move body k of x, v (n, 3) along its two-body orbit about a fixed mass: mu = G M
    [length^3 / time^2], for a time dt (any length, any sign).

    Returns (iterations, s): iterations -1 if the solver did not converge, the state then left
    unchanged; s the universal anomaly of the drift.
    """
    x0, x1, x2 = x[k, 0], x[k, 1], x[k, 2]
    v0, v1, v2 = v[k, 0], v[k, 1], v[k, 2]
    if mu == 0.0:
        x[k, 0] = x0 + dt * v0
        x[k, 1] = x1 + dt * v1
        x[k, 2] = x2 + dt * v2
        return 0, 0.0
    r0 = math.sqrt(x0 * x0 + x1 * x1 + x2 * x2)
    eta0 = x0 * v0 + x1 * v1 + x2 * v2
    v2sq = v0 * v0 + v1 * v1 + v2 * v2
    beta = 2.0 * mu / r0 - v2sq                      # > 0 bound, 0 parabolic, < 0 unbound
    zeta0 = mu - beta * r0
    # a step longer than the period (dt^2 beta^3 > (2 pi mu)^2): only the remainder matters,
    # and it keeps s small
    if beta > 0.0 and dt * dt * beta * beta * beta > 4.0 * math.pi * math.pi * mu * mu:
        period = 2.0 * math.pi * mu / (beta * math.sqrt(beta))
        dt -= period * math.trunc(dt / period)
    # f(s) below is increasing (f' = r > 0) with f(0) = -dt: keep a bracket of the root and
    # bisect whenever an iteration leaves it (or overflows on a long hyperbolic step)
    lo = 0.0 if dt >= 0.0 else -np.inf
    hi = np.inf if dt >= 0.0 else 0.0
    s = _initial_s(r0, eta0, v2sq, beta, mu, dt)
    short = dt * dt * v2sq < 0.09 * r0 * r0             # the Taylor start of _initial_s
    if not (lo < s < hi):
        s = 0.5 * dt / r0 if dt != 0.0 else 0.0
    iterations = -1
    G1 = G2 = fp = 0.0
    exact = False                  # G1, G2, fp above belong to the final s
    for it in range(100):
        c2, c3 = _stumpff23(beta * s * s)
        G1 = s * (1.0 - beta * s * s * c3)
        G2 = s * s * c2
        G3 = s * s * s * c3
        G0 = 1.0 - beta * G2
        f = r0 * s + eta0 * G2 + zeta0 * G3 - dt
        fp = r0 + eta0 * G1 + zeta0 * G2            # = r(s) > 0
        fpp = eta0 * G0 + zeta0 * G1
        if f == 0.0:
            iterations = it + 1
            exact = True
            break
        if f < 0.0:
            lo = s
        elif f > 0.0:
            hi = s
        else:                                        # NaN (overflow): treat as past the root
            hi = s
        # Halley's method, cubic near the root; far from it the bracket below takes over
        new = s - 2.0 * f * fp / (2.0 * fp * fp - f * fpp)
        ds = new - s
        # Halley's error after this step is about (f3 / (6 f1) - f2^2 / (4 f1^2)) ds^3 (f1, f2,
        # f3: derivatives of f): when that is below round-off the root is found. Then carry
        # G1, G2 to the new s by their Taylor series (G_n' = G_{n-1}, G0' = -beta G1) instead
        # of evaluating the Stumpff functions again (the next terms are ds^3 small): one
        # evaluation instead of two.
        fppp = zeta0 * G0 - beta * eta0 * G1
        ds3 = abs(ds) ** 3
        left = (abs(fppp / (6.0 * fp)) + fpp * fpp / (4.0 * fp * fp)) * ds3
        # the Taylor remainders: |G1'''| ds^3 / 6 = |beta G0| ds^3 / 6, |G2'''| = |beta G1|
        # only from the short-step Taylor start, where that error estimate holds (after
        # bisections it need not)
        shortcut = (it == 0 and short and lo < new < hi and left <= 1e-18 * abs(s)
                    and abs(beta * G0) * ds3 <= 6e-18 * abs(G1)
                    and abs(beta * G1) * ds3 <= 6e-18 * abs(G2))
        if shortcut:
            G1, G2 = (G1 + ds * (G0 - 0.5 * beta * ds * G1),
                      G2 + ds * (G1 + 0.5 * ds * G0))
            fp = r0 + eta0 * G1 + zeta0 * G2
            s = new
            iterations = it + 1
            exact = True
            break
        if not (lo < new < hi):
            if math.isinf(lo):
                new = hi - 2.0 * (abs(hi) + 1.0)     # walk out until the root is bracketed
            elif math.isinf(hi):
                new = lo + 2.0 * (abs(lo) + 1.0)
            else:
                new = 0.5 * (lo + hi)
        ds = new - s
        s = new
        if abs(ds) <= 2e-16 * abs(s):
            # the G's just computed are those of s to round-off: no need to evaluate again
            iterations = it + 1
            exact = True
            break
        if hi - lo <= 4e-16 * abs(s):
            iterations = it + 1
            break
    if iterations < 0:
        return -1, s
    if not exact:
        c2, c3 = _stumpff23(beta * s * s)
        G1 = s * (1.0 - beta * s * s * c3)
        G2 = s * s * c2
        fp = r0 + eta0 * G1 + zeta0 * G2
    f = 1.0 - mu * G2 / r0
    g = r0 * G1 + eta0 * G2                          # = dt - mu G3, without the cancellation
    fd = -mu * G1 / (r0 * fp)
    gd = 1.0 - mu * G2 / fp
    x[k, 0] = f * x0 + g * v0
    x[k, 1] = f * x1 + g * v1
    x[k, 2] = f * x2 + g * v2
    v[k, 0] = fd * x0 + gd * v0
    v[k, 1] = fd * x1 + gd * v1
    v[k, 2] = fd * x2 + gd * v2
    return iterations, s


@kernel
def _to_jacobi(pos, vel, order, m, xj, vj):
    """Jacobi coordinates of the bodies taken in `order`: xj[k] = x_k - R_{k-1} (R_k the centre
    of mass of bodies 0..k, masses m in the same order); xj[0] = the centre of mass of all."""
    M = m[0]
    # R, V: the centre of mass of bodies 0..k and its velocity, in xj[0], vj[0] as they grow
    # (the step loops call this without reference counts: it allocates nothing)
    j = order[0]
    for c in range(3):
        xj[0, c] = pos[j, c]
        vj[0, c] = vel[j, c]
    for k in range(1, order.size):
        i = order[k]
        for c in range(3):
            xj[k, c] = pos[i, c] - xj[0, c]
            vj[k, c] = vel[i, c] - vj[0, c]
        Mk = M + m[k]
        if Mk > 0.0:
            for c in range(3):
                xj[0, c] += m[k] * xj[k, c] / Mk
                vj[0, c] += m[k] * vj[k, c] / Mk
        M = Mk


@kernel
def _from_jacobi(xj, vj, order, m, M, pos, vel):
    """The inverse of _to_jacobi; M[k] = sum of m[0..k]."""
    R0, R1, R2 = xj[0, 0], xj[0, 1], xj[0, 2]           # R_k, from k = n-1 down
    V0, V1, V2 = vj[0, 0], vj[0, 1], vj[0, 2]
    for k in range(order.size - 1, 0, -1):
        i = order[k]
        w = m[k] / M[k] if M[k] > 0.0 else 0.0
        R0 -= w * xj[k, 0]                                 # R_{k-1} = R_k - m_k/M_k x'_k
        R1 -= w * xj[k, 1]
        R2 -= w * xj[k, 2]
        V0 -= w * vj[k, 0]
        V1 -= w * vj[k, 1]
        V2 -= w * vj[k, 2]
        pos[i, 0] = xj[k, 0] + R0
        pos[i, 1] = xj[k, 1] + R1
        pos[i, 2] = xj[k, 2] + R2
        vel[i, 0] = vj[k, 0] + V0
        vel[i, 1] = vj[k, 1] + V1
        vel[i, 2] = vj[k, 2] + V2
    j = order[0]
    pos[j, 0], pos[j, 1], pos[j, 2] = R0, R1, R2
    vel[j, 0], vel[j, 1], vel[j, 2] = V0, V1, V2


@kernel
def _drift_all(xj, vj, M, G, dt):
    """Kepler drift of every Jacobi body (k >= 1, mu = G M_k) and free drift of the centre of
    mass; returns False if a Kepler solve failed."""
    if dt == 0.0:
        return True
    for c in range(3):
        xj[0, c] += dt * vj[0, c]
    ok = True
    for k in range(1, xj.shape[0]):
        if kepler_drift(xj, vj, k, G * M[k], dt)[0] < 0:
            ok = False
    return ok


@kernel(parallel=True, inline=True)
def _kick(xj, vj, order, m, M, fx, t, pos, vel, acc, dt, actors, thrust, dissipate):
    """v'_k += dt (J(a) + G M_k x'_k / r'^3): the interaction part of the acceleration of
    every body (forces.accelerations from fx, drag aside), plus the thrust accelerations (A, 3) of the
    actors (rows `actors`). dissipate: the kick also relaxes the velocities toward the wind
    (forces.kick in Jacobi coordinates, where every relative velocity relaxes toward 0
    and the centre of mass toward the wind, the Jacobi transformation being linear with
    weights summing to one)."""
    _from_jacobi(xj, vj, order, m, M, pos, vel)
    accelerations(fx, t, pos, vel, acc, fx.everyone, False)
    for q in range(actors.size):
        for c in range(3):
            acc[actors[q], c] += thrust[q, c]
    # Jacobi transform of the accelerations: a'_k = a_k - (mass-weighted mean of a over 0..k-1),
    # written into acc's rows in Jacobi order (acc[order[k]] is not read again once done)
    G = fx.gravity.G
    Mprev = m[0]
    A0 = acc[order[0], 0]
    A1 = acc[order[0], 1]
    A2 = acc[order[0], 2]
    for k in range(1, order.size):
        i = order[k]
        a0 = acc[i, 0] - A0
        a1 = acc[i, 1] - A1
        a2 = acc[i, 2] - A2
        r2 = xj[k, 0] * xj[k, 0] + xj[k, 1] * xj[k, 1] + xj[k, 2] * xj[k, 2]
        # no Kepler part about no mass (and none to remove): 0, not 0/0
        w = G * M[k] / (r2 * math.sqrt(r2)) if M[k] > 0.0 else 0.0
        Mk = Mprev + m[k]
        if Mk > 0.0:
            A0 += m[k] * a0 / Mk
            A1 += m[k] * a1 / Mk
            A2 += m[k] * a2 / Mk
        Mprev = Mk
        acc[i, 0] = a0 + w * xj[k, 0]
        acc[i, 1] = a1 + w * xj[k, 1]
        acc[i, 2] = a2 + w * xj[k, 2]
    # the centre of mass moves with the mass-weighted mean acceleration A: zero under mutual
    # gravity alone (kept exactly 0, not rounding noise); held and user forces can push it.
    # Nothing pulls: the first body is its own "centre of mass", kicked by its own acceleration
    free = Mprev == 0.0 or _pushed(fx.held, fx.user)
    j = order[0]
    acc[j, 0] = A0
    acc[j, 1] = A1
    acc[j, 2] = A2
    _jacobi_kick(vj, acc, order, fx.drag, dt, dissipate, 0 if free else 1)


@kernel
def _pushed(held, user):
    """Whether held or user forces may push the centre of mass."""
    return held is not None or user is not None


@kernel
def _jacobi_kick(vj, acc, order, drag, dt, dissipate, first):
    """vj[k] += dt acc[order[k]] for k >= first, or with drag (dissipate) the exact relaxation
    of forces.kick: toward the wind for the centre of mass (k = 0), toward rest for the
    relative velocities."""
    if dissipate and _drag_kick(vj, acc, order, drag, dt, first):
        return
    for k in range(first, order.size):
        i = order[k]
        vj[k, 0] += dt * acc[i, 0]
        vj[k, 1] += dt * acc[i, 1]
        vj[k, 2] += dt * acc[i, 2]


@kernel
def _drag_kick(vj, acc, order, drag, dt, first):
    """_jacobi_kick's relaxation with drag; False (nothing done) without drag."""
    if drag is None:
        return False
    k_drag = drag[0]
    if not k_drag > 0.0:
        return False
    E = libm.exp(-k_drag * dt)
    for k in range(order.size):
        i = order[k]
        for c in range(3):
            # the centre's own acceleration only where it has one (see _kick)
            a = acc[i, c] if k >= first else 0.0
            vt = (drag[1 + c] if k == 0 else 0.0) + a / k_drag
            vj[k, c] = vt + (vj[k, c] - vt) * E
    return True


# Third-order corrector (Wisdom, Holman & Touma 1996): C = X(a, b) X(-a, -b) with
# X(a, b) = drift(-a) kick(b) drift(a), a = sqrt(7/40) dt, so that C = exp(2 a b [A, B] + ..)
# to leading order (A: Kepler, B: interaction). The drift-kick-drift map's leading error is
# -dt^3/24 [A, [A, B]] (the Strang splitting's), which conjugation by C cancels when
# 2 a b = dt^2/24, i.e. b = dt / (48 sqrt(7/40)). Measured: 116x smaller energy error on two
# planets at 50 steps per orbit; half that kick (the kick-drift-kick form's) gains only 2x.
_CORRECTOR_A = math.sqrt(7.0 / 40.0)
_CORRECTOR_B = 1.0 / (48.0 * _CORRECTOR_A)


@kernel
def _schedule(q, nsteps, dt, corrector):
    """(drift, kick) before and of the q-th kick of a call, in time units.

    Plain: drift dt/2, then kick dt / drift dt, ..., ending with a drift dt/2 (outside).
    Corrected: C = [drift -a, kick b, drift 2a, kick -b, drift -a] first, C^-1 = [drift a,
    kick b, drift -2a, kick -b, drift a] last (X(a, b)^-1 = X(a, -b)); a = _CORRECTOR_A dt,
    b = _CORRECTOR_B dt.
    """
    a = _CORRECTOR_A * dt
    b = _CORRECTOR_B * dt
    if corrector:
        if q == 0:
            return -a, b
        if q == 1:
            return 2.0 * a, -b
        if q == 2:
            return 0.5 * dt - a, dt
        if q == nsteps + 2:
            return 0.5 * dt + a, b
        if q == nsteps + 3:
            return -2.0 * a, -b
        return dt, dt
    return (0.5 * dt if q == 0 else dt), dt


# The family's table (steppers.WisdomHolman.method): order (n,) int64, the central body first,
# then the other pulling bodies, then the passive ones; m (n,) masses in that order, 0 for
# passive bodies (they do not move the Jacobi frames); corrector: apply the third-order
# symplectic corrector at the start and its inverse at the end of each run of steps between
# synchronisations.
WisdomHolman = namedtuple("WisdomHolman", ("order", "m", "corrector"))


def _scratch(method, state, fx, actors):
    """(xj, vj (n, 3): Jacobi positions and velocities, M (n,): the masses of bodies 0..k,
    the actors' rows and burns, their thrust (A, 3) and none of it)."""
    n = method.order.size
    movers = np.empty(0, np.int64) if actors is None else actors.actors
    burn = np.empty((0, 8)) if actors is None else actors.burn
    return (np.empty((n, 3)), np.empty((n, 3)), np.cumsum(method.m), movers, burn,
            zeroed(np.empty((movers.size, 3))), zeroed(np.empty((movers.size, 3))))


def _run_length(method, every, frames, frame, done, nsteps):
    """The steps between synchronisations: one with collisions or actors (the collision
    pass sees positions and velocities after every step); else up to the next frame a
    recording takes, and the call's last step alone (its start is kept for interpolation)."""
    if every:
        return 1
    upto = min(nsteps - 1 if done < nsteps - 1 else nsteps, next_frame(frames, frame, nsteps))
    return upto - done


def _map(method, carry, sa, burns, fx, t, dt, steps, kicked, played):
    """`steps` steps of the Wisdom-Holman map from t, synchronised at the end (the corrector
    and its inverse around them). Thrust enters the step's kick as its exact velocity change
    over the step, dv(dt) / dt (actors must be passive: their mass changes); drag relaxes the
    velocities exactly within the step's kick. False when a Kepler solve did not converge.
    One loop of drift-then-kick over the whole schedule, so that the force code appears once
    in the compiled kernel; corrector drifts merge with their neighbours: Kepler flows
    compose exactly."""
    order, m, corrector = method
    xj, vj, M, movers, burn, thrust, none = carry
    pos, vel, acc = sa.pos, sa.vel, sa.acc
    G = fx.gravity.G
    for q in range(movers.size):
        dv = thrust_dv(burn, q, dt) if burn[q, F] != 0.0 else 0.0
        for c in range(3):
            thrust[q, c] = dv / dt * burn[q, c]
    ok = True
    if order.size > 0:    # no body left (all expired or destroyed in this call): time passes
        _to_jacobi(pos, vel, order, m, xj, vj)
        kicks = steps + (4 if corrector else 0)
        tau = 0.0
        for q in range(kicks):
            d, k = _schedule(q, steps, dt, corrector)
            ok = _drift_all(xj, vj, M, G, d) & ok
            tau += d
            # the step's own kick carries the thrust and the drag, the corrector's do not
            main = not corrector or 2 <= q < steps + 2
            _kick(xj, vj, order, m, M, fx, t + tau, pos, vel, acc, k, movers,
                  thrust if main else none, main)
        ok = _drift_all(xj, vj, M, G, _CORRECTOR_A * dt if corrector else 0.5 * dt) & ok
        _from_jacobi(xj, vj, order, m, M, pos, vel)
    return ok


step.register(WisdomHolman, start_=_scratch, advance_=_map, span_=_run_length, keep=True,
              nonfinite_fails=True, parallel=True, lean=True)
