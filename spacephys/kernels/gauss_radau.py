"""Adaptive 15th-order Gauss-Radau integration (the IAS15 family) of y'' = a(y).

Written from the published method: E. Everhart, "An efficient integrator that uses Gauss-Radau
spacings", IAU Colloq. 83 (1985) 185; H. Rein & D. S. Spiegel, MNRAS 446 (2015) 1424
(predictor-corrector to convergence, compensated summation); D. Pham, H. Rein & D. S. Spiegel,
OJAp (2024), arXiv:2401.02849 (the step criterion from acceleration, jerk and snap).

Within a step of length h the acceleration of each body is the polynomial
    a(tau) = a0 + b1 tau + ... + b7 tau^7,   tau = (t - t0) / h in [0, 1],
fitted at the seven Gauss-Radau nodes. In Newton form its coefficients are g1..g7 (divided
differences), which the corrector updates node by node. Integrating twice gives the position and
velocity at any tau. Compiled without fastmath: the compensated sums and the convergence test
depend on exact rounding.
"""
import math
from collections import namedtuple

import numpy as np
from numba import types

from .._jit import kernel
from . import libm
from . import step
from .arrays import copy_into, zeroed
from .control import add_thrust, next_stop, snap_stops
from .forces import accelerations, velocity_dependent

_PC_TOLERANCE = 1e-16      # corrector converged: the sweep changed b7 by < this fraction of |a|
_PC_ROUNDOFF = 1e-10       # below this, an error that stops shrinking is round-off: also converged
_PC_MAX_SWEEPS = 12
_SAFETY = 0.25             # redo a step if the criterion asks for < 1/4 of it; grow at most 4x
# b7 / |a| below this is round-off, never a reason to redo a step: b7 is a seventh divided
# difference of nearly equal accelerations, whose rounding it amplifies (seen up to 5e-10)
_TRUNCATION_FLOOR = 1e-8

# stats slots
STEPS, REJECTED, AT_MIN_STEP, NOT_CONVERGED, RIDER_SUBSTEPS, SWEEPS = range(6)
# most substeps a rider may take within one step of the bodies that set it
_MAX_RIDER_SUBSTEPS = 4096


@kernel(inline=True)
def _newton_row(b, d_bg, g, i):
    """g_j = sum_k d_bg[k, j] b_k for body i, every component."""
    for c in range(3):
        for j in range(7):
            s = 0.0
            for k in range(j, 7):
                s += d_bg[k, j] * b[i, k, c]
            g[i, j, c] = s


@kernel
def _newton_form(b, d_bg, g):
    """_newton_row for every body."""
    for i in range(b.shape[0]):
        _newton_row(b, d_bg, g, i)


@kernel
def _rescale(b, e, q):
    """The same polynomials over a step q times as long: b_k -> b_k q^k (and the predictions)."""
    for k in range(7):
        f = q ** (k + 1)
        for i in range(b.shape[0]):
            for c in range(3):
                b[i, k, c] *= f
                e[i, k, c] *= f


@kernel
def _position_at(rows, pos, csx, vel, a0, b, tau, h, x):
    """x = x0 + tau h v0 + (tau h)^2 [a0/2 + sum_k b_k tau^k / ((k+1)(k+2))] for the bodies in
    rows, with x0 the compensated position (pos - csx): the compensation enters before the
    one rounding."""
    for q in range(rows.size):
        i = rows[q]
        for c in range(3):
            s = b[i, 6, c] / 72.0
            s = s * tau + b[i, 5, c] / 56.0
            s = s * tau + b[i, 4, c] / 42.0
            s = s * tau + b[i, 3, c] / 30.0
            s = s * tau + b[i, 2, c] / 20.0
            s = s * tau + b[i, 1, c] / 12.0
            s = s * tau + b[i, 0, c] / 6.0
            s = s * tau + a0[i, c] / 2.0
            x[i, c] = pos[i, c] + (tau * h * (vel[i, c] + tau * h * s) - csx[i, c])


@kernel
def _velocity_at(rows, vel, csv, a0, b, tau, h, v):
    """v = v0 + tau h [a0 + sum_k b_k tau^(k+1) / (k+2)] for the bodies in rows, with v0 the
    compensated velocity (vel - csv): the velocities the stage's drag and user forces see."""
    for q in range(rows.size):
        i = rows[q]
        for c in range(3):
            s = b[i, 6, c] / 8.0
            s = s * tau + b[i, 5, c] / 7.0
            s = s * tau + b[i, 4, c] / 6.0
            s = s * tau + b[i, 3, c] / 5.0
            s = s * tau + b[i, 2, c] / 4.0
            s = s * tau + b[i, 1, c] / 3.0
            s = s * tau + b[i, 0, c] / 2.0
            v[i, c] = vel[i, c] + (tau * h * (a0[i, c] + tau * s) - csv[i, c])


@kernel
def _correct_at_node(rows, node, nodes, a, a0, g, b, c_gb):
    """Refit g_{node+1} of the bodies in rows to their acceleration a at nodes[node] and carry
    the change into b."""
    tau = nodes[node]
    for q in range(rows.size):
        i = rows[q]
        for c in range(3):
            r = (a[i, c] - a0[i, c]) / tau
            for j in range(node):
                r = (r - g[i, j, c]) / (tau - nodes[j])
            dg = r - g[i, node, c]
            g[i, node, c] = r
            for k in range(node + 1):
                b[i, k, c] += c_gb[node, k] * dg


@kernel
def _step_criterion(b, a0, h, control):
    """min over control bodies of their dynamical time (_body_time) [time]; inf when no
    control body accelerates."""
    best = np.inf
    for q in range(control.size):
        best = min(best, _body_time(b, a0, h, control[q]))
    return best


@kernel
def _body_time(b, a0, h, i):
    """sqrt(2 |a|^2 / (|j|^2 + |a| |s|)) [time] of body i (Pham et al. 2024), with acceleration
    a, jerk j and snap s at the end of the step read off its polynomial; inf if a = 0."""
    a2 = 0.0
    j2 = 0.0
    s2 = 0.0
    for c in range(3):
        a = a0[i, c]
        j = 0.0
        s = 0.0
        for k in range(7):
            a += b[i, k, c]
            j += (k + 1) * b[i, k, c]
            s += (k + 1) * k * b[i, k, c]
        a2 += a * a
        j2 += j * j
        s2 += s * s
    den = j2 + math.sqrt(a2 * s2)
    if a2 > 0.0 and den > 0.0:
        # j and s lack their 1/h, 1/h^2: this is tau in units of h
        return math.sqrt(2.0 * a2 / den) * h
    return np.inf


@kernel
def _kahan_add(s, comp, i, c, delta):
    y = delta - comp[i, c]
    t = s[i, c] + y
    comp[i, c] = (t - s[i, c]) - y
    s[i, c] = t


@kernel
def _finish_step(rows, pos, vel, csx, csv, a0, b, h):
    """Move the bodies in rows to the end of the step with compensated (Kahan) sums, small
    terms first."""
    for q in range(rows.size):
        i = rows[q]
        for c in range(3):
            sx = b[i, 6, c] / 72.0 + b[i, 5, c] / 56.0
            sx += b[i, 4, c] / 42.0
            sx += b[i, 3, c] / 30.0
            sx += b[i, 2, c] / 20.0
            sx += b[i, 1, c] / 12.0
            sx += b[i, 0, c] / 6.0
            sx += a0[i, c] / 2.0
            sv = b[i, 6, c] / 8.0 + b[i, 5, c] / 7.0
            sv += b[i, 4, c] / 6.0
            sv += b[i, 3, c] / 5.0
            sv += b[i, 2, c] / 4.0
            sv += b[i, 1, c] / 3.0
            sv += b[i, 0, c] / 2.0
            sv += a0[i, c]
            _kahan_add(pos, csx, i, c, h * h * sx + h * vel[i, c])
            _kahan_add(vel, csv, i, c, h * sv)


@kernel
def _forget(b, e):
    for i in range(b.shape[0]):
        for k in range(7):
            for c in range(3):
                b[i, k, c] = 0.0
                e[i, k, c] = 0.0


@kernel
def _predict(b, e, q, have_predictor):
    """Everhart's predictor for a next step q times this one: the polynomial continued past
    tau = 1 and re-expanded, e_k = q^k sum_{j>=k} C(j, k) b_j, plus the error the previous
    prediction made (b - e), which tends to repeat."""
    for i in range(b.shape[0]):
        for c in range(3):
            for k in range(1, 8):
                s = 0.0
                binom = 1.0                          # C(j, k) for j = k, k+1, ...
                for j in range(k, 8):
                    s += binom * b[i, j - 1, c]
                    binom = binom * (j + 1) / (j + 1 - k)
                new = s * q ** k
                correction = b[i, k - 1, c] - e[i, k - 1, c] if have_predictor else 0.0
                e[i, k - 1, c] = new
                b[i, k - 1, c] = new + correction


@kernel(parallel=True, inline=True)
def _sweep(rows, targets, first, fx, t, pos, csx, vel, csv, a0, b, g, x, v, a, b7, h, nodes,
           c_gb, thrust):
    """One predictor-corrector sweep over the seven nodes, updating the bodies in rows (whose
    accelerations are computed for `targets`, see forces.accelerations). first = -1 evaluates
    a0, the acceleration at the step's start (of every body), before the nodes. fx :
    forces.hoist(Forces), read once per kernel call; t : the time of the step's start.
    thrust = (actors, burn, t_off, rider, want): the burns (control.begin_step) are added for
    the actors whose rider flag equals want (-1: all), the step starting t_off after the
    interval's. Returns the change of b7 in this sweep relative to the largest |a| (over
    rows)."""
    for q in range(rows.size):
        for c in range(3):
            b7[rows[q], c] = b[rows[q], 6, c]
    moving = velocity_dependent(fx)
    everyone = fx.everyone
    for node in range(first, 7):
        # the only call of the force code for the bodies setting the step: each call site of
        # an inlined parallel loop is compiled anew
        if node >= 0:
            _position_at(everyone, pos, csx, vel, a0, b, nodes[node], h, x)
            if moving:
                _velocity_at(everyone, vel, csv, a0, b, nodes[node], h, v)
        else:
            # the start: no polynomial needed (and a0, not yet known, must not enter: 0 * an
            # uninitialised NaN is NaN)
            for i in range(pos.shape[0]):
                for c in range(3):
                    x[i, c] = pos[i, c] - csx[i, c]
                    v[i, c] = vel[i, c] - csv[i, c]
        tau = nodes[node] * h if node >= 0 else 0.0
        out = a if node >= 0 else a0
        who = targets if node >= 0 else everyone
        accelerations(fx, t + tau, x, v, out, who, True)
        actors, burn, t_off, rider, want = thrust
        if burn.shape[0]:
            add_thrust(actors, burn, a if node >= 0 else a0, t_off + tau, rider,
                       want if node >= 0 else -1)
        if node >= 0:
            _correct_at_node(rows, node, nodes, a, a0, g, b, c_gb)
    max_a = 0.0
    max_db7 = 0.0
    for q in range(rows.size):
        i = rows[q]
        for c in range(3):
            max_a = max(max_a, abs(a[i, c]))
            max_db7 = max(max_db7, abs(b[i, 6, c] - b7[i, c]))
    return max_db7 / max_a if max_a > 0.0 else max_db7


@kernel(parallel=True, inline=True)
def _converge(rows, targets, with_a0, fx, t, pos, csx, vel, csv, a0, b, g, x, v, a, b7, h,
              nodes, c_gb, thrust):
    """Sweep until b7 stops changing: below _PC_TOLERANCE, or stalled at round-off. Returns
    (converged within _PC_MAX_SWEEPS, sweeps made). with_a0: evaluate a0 first."""
    last = np.inf
    for sweep in range(_PC_MAX_SWEEPS):
        first = -1 if with_a0 and sweep == 0 else 0
        error = _sweep(rows, targets, first, fx, t, pos, csx, vel, csv, a0, b, g, x, v, a, b7,
                       h, nodes, c_gb, thrust)
        if error < _PC_TOLERANCE or (sweep > 1 and error >= last and error < _PC_ROUNDOFF):
            return True, sweep + 1
        last = error
    return False, _PC_MAX_SWEEPS


@kernel
def _unmasked(mask):
    """The rows i where mask[i] is False, in order: a loop, since the array expression
    (~mask) would be a parallel region of its own in the step kernel."""
    rows = np.empty(mask.size - np.count_nonzero(mask), np.int64)
    k = 0
    for i in range(mask.size):
        if not mask[i]:
            rows[k] = i
            k += 1
    return rows


@kernel
def _needy_riders(riders, b, a0, h, dt_scale, mask, converged):
    """The riders whose own dynamical time asks for a step shorter than h, or all of them if
    their corrector did not converge over h (marked in mask)."""
    count = 0
    for q in range(riders.size):
        r = riders[q]
        if not converged or dt_scale * _body_time(b, a0, h, r) < h:
            mask[r] = True
            count += 1
    needy = np.empty(count, np.int64)
    k = 0
    for q in range(riders.size):
        if mask[riders[q]]:
            needy[k] = riders[q]
            k += 1
    return needy


@kernel(parallel=True, by_address=True, returns=types.none)
def _substep_riders(needy, h, dt_scale, reject_above, control, fx, t, nodes, c_gb, d_bg, pos,
                    csx, vel, csv, a0, b, g, x, v, a, b7, stats, actors, burn, t_off,
                    needy_mask):
    """Integrate the needy riders across the step [0, h] in adaptive substeps of their own.

    The control bodies have not moved yet: at any time of the step their positions (and
    velocities) come from their fitted polynomials (pos, a0, b over h), so the riders see
    them where they are and never change them. Each substep is a Gauss-Radau step of the
    riders alone, iterated to convergence, its length from the riders' dynamical time, redone
    when its truncation error says it was too long; at most _MAX_RIDER_SUBSTEPS of them.
    Forces come from forces.accelerations for the needy riders only (fx : forces.hoist(Forces);
    t : the time of the step's start). Thrusting riders (in needy_mask) add their thrust, the step
    starting t_off after the interval's."""
    moving = velocity_dependent(fx)
    hs = np.inf
    for q in range(needy.size):
        hs = min(hs, dt_scale * _body_time(b, a0, h, needy[q]))
    hs = min(max(hs, h / _MAX_RIDER_SUBSTEPS), h)
    _scale_rows(needy, b, hs / h)          # the whole step's polynomials start the first
    elapsed = 0.0
    taken = 0
    while elapsed < h:
        landing = hs >= (h - elapsed) * (1.0 - 1e-12) or taken >= _MAX_RIDER_SUBSTEPS
        if landing and taken >= _MAX_RIDER_SUBSTEPS:
            stats[AT_MIN_STEP] += 1
        h_try = h - elapsed if landing else hs
        if h_try != hs:
            _scale_rows(needy, b, h_try / hs)
            hs = h_try
        _position_at(control, pos, csx, vel, a0, b, elapsed / h, h, x)
        if moving:
            _velocity_at(control, vel, csv, a0, b, elapsed / h, h, v)
        for q in range(needy.size):
            r = needy[q]
            for c in range(3):
                x[r, c] = pos[r, c] - csx[r, c]
                v[r, c] = vel[r, c] - csv[r, c]
        accelerations(fx, t + elapsed, x, v, a0, needy, True)
        if burn.shape[0]:
            add_thrust(actors, burn, a0, t_off + elapsed, needy_mask, 1)
        for q in range(needy.size):
            _newton_row(b, d_bg, g, needy[q])
        last = np.inf
        for sweep in range(_PC_MAX_SWEEPS):
            for q in range(needy.size):
                for c in range(3):
                    b7[needy[q], c] = b[needy[q], 6, c]
            for node in range(7):
                at = (elapsed + nodes[node] * hs) / h
                _position_at(control, pos, csx, vel, a0, b, at, h, x)
                _position_at(needy, pos, csx, vel, a0, b, nodes[node], hs, x)
                if moving:
                    _velocity_at(control, vel, csv, a0, b, at, h, v)
                    _velocity_at(needy, vel, csv, a0, b, nodes[node], hs, v)
                accelerations(fx, t + elapsed + nodes[node] * hs, x, v, a, needy, True)
                if burn.shape[0]:
                    add_thrust(actors, burn, a, t_off + elapsed + nodes[node] * hs,
                               needy_mask, 1)
                _correct_at_node(needy, node, nodes, a, a0, g, b, c_gb)
            max_a = 0.0
            max_db7 = 0.0
            for q in range(needy.size):
                for c in range(3):
                    max_a = max(max_a, abs(a[needy[q], c]))
                    max_db7 = max(max_db7, abs(b[needy[q], 6, c] - b7[needy[q], c]))
            error = max_db7 / max_a if max_a > 0.0 else max_db7
            if error < _PC_TOLERANCE or (sweep > 1 and error >= last and error < _PC_ROUNDOFF):
                break
            last = error
        max_a = 0.0
        max_b7 = 0.0
        nxt = np.inf
        for q in range(needy.size):
            r = needy[q]
            nxt = min(nxt, dt_scale * _body_time(b, a0, hs, r))
            for c in range(3):
                max_a = max(max_a, abs(a[r, c]))
                max_b7 = max(max_b7, abs(b[r, 6, c]))
        nxt = min(nxt, hs / _SAFETY)
        if max_b7 > reject_above * max_a and taken < _MAX_RIDER_SUBSTEPS and \
                nxt < _SAFETY * hs:
            _scale_rows(needy, b, nxt / hs)    # too long: again, shorter
            hs = nxt
            continue
        _finish_step(needy, pos, vel, csx, csv, a0, b, hs)
        stats[RIDER_SUBSTEPS] += 1
        taken += 1
        elapsed = h if landing else elapsed + hs
        # the next substep starts from this one's polynomial, continued
        _predict_rows(needy, b, nxt / hs)
        hs = nxt


@kernel
def _scale_rows(rows, b, q):
    """The rows' polynomials over a step q times as long: b_k -> b_k q^k."""
    for k in range(7):
        f = q ** (k + 1)
        for r in range(rows.size):
            for c in range(3):
                b[rows[r], k, c] *= f


@kernel
def _predict_rows(rows, b, q):
    """Everhart's continuation of the rows' polynomials to a next step q times as long."""
    new = np.empty(7)
    for r in range(rows.size):
        i = rows[r]
        for c in range(3):
            for k in range(1, 8):
                s_ = 0.0
                binom = 1.0
                for j in range(k, 8):
                    s_ += binom * b[i, j - 1, c]
                    binom = binom * (j + 1) / (j + 1 - k)
                new[k - 1] = s_ * q ** k
            for k in range(7):
                b[i, k, c] = new[k]


# The family's table (steppers.GaussRadau.method):
# csx, csv : (n, 3), the Kahan compensations of pos and vel;
# b, e : (n, 7, 3), the polynomial coefficients and their last prediction, carried over;
# control : int64 rows of the bodies that set the step and whose convergence is required for
#   it; riders : the passive bodies outside control (empty, or exactly forces.passive),
#   iterated to convergence afterwards against the control bodies' final polynomials, so that
#   they never change them;
# nodes : (7,) Gauss-Radau spacings; c_gb : (7, 7), b_k = sum_j c_gb[j, k] g_j; d_bg : (7, 7),
#   g_j = sum_k d_bg[k, j] b_k;
# params : float64 [tolerance, max_step, min_step, dt_proposal, dt_of_b, have_predictor]; the
#   last three are updated. tolerance 0: fixed steps of min(dt_proposal, max_step);
# stats : int64 [steps, rejected, at_min_step, not_converged, rider_substeps, sweeps],
#   incremented.
GaussRadau = namedtuple("GaussRadau", ("csx", "csv", "b", "e", "control", "riders", "nodes",
                                       "c_gb", "d_bg", "params", "stats"))


def _scratch(method, state, fx, actors):
    """The call's scratch: accelerations at the step's start and at a node, positions and
    velocities at a node, the divided differences, b7 before a sweep, the compensations at
    the interval's start, which riders substep, which are riders; the actors' rows and
    burns."""
    n = state.pos.shape[0]
    params = method.params
    if params[0] == 0.0:
        # tolerance 0: steps of min(dt_out, max_step), whatever was proposed before
        params[3] = np.inf
    rider = zeroed(np.empty(n, np.bool_))
    for q in range(method.riders.size):
        rider[method.riders[q]] = True
    movers = np.empty(0, np.int64) if actors is None else actors.actors
    burn = np.empty((0, 8)) if actors is None else actors.burn
    return (np.empty((n, 3)), np.empty((n, 3)), np.empty((n, 3)), np.empty((n, 3)),
            np.empty((n, 7, 3)), np.empty((n, 3)), np.empty((2, n, 3)),
            zeroed(np.empty(n, np.bool_)), rider, movers, burn)


def _interval(method, carry, sa, burns, fx, t_start, dt_out, k, kicked, played):
    """One output interval of dt_out from t_start, landing exactly on its end, in adaptive
    steps. The collision pass runs at the end of each interval (so dt_out caps the collision
    step); controls are held over it, thrust is sampled at the nodes, and steps end where a
    burn stops (fuel or burn time), so none straddles the jump. Drag and user forces are
    evaluated at each node's velocity, read off the velocity polynomial. False when a step
    underflowed the clock or turned NaN: the compensations are then as the interval found
    them (the step kernel takes the rest back)."""
    csx, csv, b, e, control, riders, nodes, c_gb, d_bg, params, stats = method
    a0, a, x, v, g, b7, saved, needy_mask, rider, movers, burn = carry
    pos, vel = sa.pos, sa.vel
    n = pos.shape[0]
    tolerance, max_step, min_step = params[0], params[1], params[2]
    dt = params[3]
    dt_b = params[4]
    have_predictor = params[5] != 0.0
    everyone = control.size == n
    all_rows = fx.everyone
    dt_scale = libm.pow(5040.0 * tolerance, 1.0 / 7.0)     # (7! tolerance)^(1/7)
    # the step was over 4x too long (b7 ~ dt^7); but never within the round-off of b7 / |a|,
    # or tiny tolerances would reject every step
    reject_above = max(tolerance / _SAFETY ** 7, _TRUNCATION_FLOOR)
    # tolerance 0: steps of min(dt_out, max_step), whatever was proposed before; a step whose
    # corrector does not converge is retried shorter, and the next one is full again
    fixed_h = min(dt_out, max_step)
    if tolerance == 0.0 and dt == np.inf:
        dt = fixed_h                                 # (the call's first interval)
    copy_into(saved[0], csx)
    copy_into(saved[1], csv)
    elapsed = 0.0
    while True:
        h = min(dt, max_step)
        # land when the step covers what is left, bar a sliver that rounding would leave
        landing = h >= (dt_out - elapsed) * (1.0 - 1e-12)
        if landing:
            h = dt_out - elapsed
        # end the step where a burn stops: thrust jumps there
        stop = np.inf
        if burn.shape[0]:
            snap_stops(movers, burn, elapsed, 1e-12 * dt_out)
            stop = next_stop(movers, burn, elapsed)
        clipped = stop < elapsed + h and stop < dt_out * (1.0 - 1e-12)
        if clipped:
            h = stop - elapsed
            landing = False
        if not (h > 0.0) or (not landing and elapsed + h == elapsed):
            landing = False                      # NaN, or a step below the clock's resolution
            break
        if h != dt_b:
            _rescale(b, e, h / dt_b)
            dt_b = h
        _newton_form(b, d_bg, g)
        # phase 0: the bodies that set the step; phase 1: the riders, against the control
        # bodies' final polynomials (so they never change them)
        redo = False
        failed = False
        riders_converged = True
        dt_new = fixed_h if tolerance == 0.0 else dt
        for phase in range(2):
            if phase == 1 and (everyone or riders.size == 0):
                break
            rows = control if phase == 0 else riders
            want = (-1 if everyone else 0) if phase == 0 else 1
            converged, sweeps = _converge(rows, rows, phase == 0, fx, t_start + elapsed, pos,
                                          csx, vel, csv, a0, b, g, x, v, a, b7, h, nodes,
                                          c_gb, (movers, burn, elapsed, rider, want))
            if phase == 1:
                # riders that do not converge over the whole step take substeps below
                riders_converged = converged
                break
            stats[SWEEPS] += sweeps
            if not converged:
                stats[NOT_CONVERGED] += 1
            if not converged and h > min_step:
                # the fixed-point iteration diverges when the step is far too long
                stats[REJECTED] += 1
                dt = max(_SAFETY * h, min_step)
                redo = True
                break
            if tolerance > 0.0:
                # The next step comes from the dynamical time of Pham et al. (2024). Whether
                # this step is redone is decided by the truncation error it actually made,
                # measured by the last term of the polynomial relative to the largest
                # acceleration (Rein & Spiegel 2015): the dynamical time alone collapses for
                # a body whose acceleration passes through zero, and would reject such steps
                # forever.
                max_a = 0.0
                max_b7 = 0.0
                for q in range(control.size):
                    i = control[q]
                    for c in range(3):
                        max_a = max(max_a, abs(a[i, c]))
                        max_b7 = max(max_b7, abs(b[i, 6, c]))
                truncation = max_b7 / max_a if max_a > 0.0 else 0.0
                dt_new = dt_scale * _step_criterion(b, a0, h, control)
                if not (dt_new > 0.0):
                    failed = True                    # NaN accelerations
                    break
                # a landing or clipped step is short by choice
                basis = max(h, dt) if landing or clipped else h
                dt_new = min(dt_new, basis / _SAFETY)
                if dt_new < min_step:
                    dt_new = min_step
                    stats[AT_MIN_STEP] += 1
                if truncation > reject_above and h > min_step:
                    stats[REJECTED] += 1
                    dt = max(min(dt_new, _SAFETY * h), min_step)
                    redo = True
                    break
        if failed:
            landing = False
            break
        if redo:
            continue
        # riders whose own dynamical time says this step is too long for them take
        # substeps of their own inside it, against the control bodies' fitted motion
        needy = all_rows[:0]
        if not everyone and riders.size and tolerance > 0.0:
            needy = _needy_riders(riders, b, a0, h, dt_scale, needy_mask, riders_converged)
            if needy.size:
                _substep_riders(needy, h, dt_scale, reject_above, control, fx,
                                t_start + elapsed, nodes, c_gb, d_bg, pos, csx, vel, csv,
                                a0, b, g, x, v, a, b7, stats, movers, burn, elapsed,
                                needy_mask)
        _finish_step(all_rows if needy.size == 0 else _unmasked(needy_mask), pos, vel,
                     csx, csv, a0, b, h)
        needy_mask[needy] = False
        stats[STEPS] += 1
        elapsed = 0.0 if landing else (stop if clipped else elapsed + h)
        h_next = min(dt_new, max_step, dt_out - elapsed)     # the next step, as far as known
        if h_next / h > 1.0 / _SAFETY:
            # a short landing step's fit, extrapolated far past its interval, is mostly
            # amplified noise: start the next step without a prediction
            _forget(b, e)
            have_predictor = False
        else:
            _predict(b, e, h_next / h, have_predictor)
            have_predictor = True
        for q in range(needy.size):
            # a substepping rider's polynomial spans its last substep: start it afresh
            for kk in range(7):
                for c in range(3):
                    b[needy[q], kk, c] = 0.0
                    e[needy[q], kk, c] = 0.0
        dt_b = h_next
        dt = dt_new
        if landing:
            break
    params[3] = dt
    params[4] = dt_b
    params[5] = 1.0 if have_predictor else 0.0
    if not landing:                              # the interval was abandoned
        copy_into(csx, saved[0])
        copy_into(csv, saved[1])
        return False
    return True


step.register(GaussRadau, start_=_scratch, advance_=_interval, keep=True, parallel=True,
              counted=True)
