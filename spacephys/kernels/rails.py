"""Bodies on rails: moved along fixed Kepler orbits about their parents, never integrated
(spacephys/rails.py sets them up). A body on rails pulls the others and feels nothing: every
force evaluation first puts it where its orbit has it at the evaluation's time (`place`, so a
Runge-Kutta stage or a Gauss-Radau node sees it at its own time) and then zeroes its
acceleration (`hold`); the step puts it there again at the step's end (`settle`, timed as
World.t is).

An orbit's elements (ELEMENTS, a row each) give the body's place relative to its parent's at
time t: the mean anomaly M = M0 + n (t - t0), with n held as a double-double (n_hi + n_lo)
and M reduced modulo 2 pi in double-double arithmetic (Dekker's exact products, no fused
multiply-add), so that after 10^6 periods the phase is still right to rounding; then
Kepler's equation, E - e sin E = M (elliptic) or e sinh H - H = M (hyperbolic), by Newton's
method kept inside a bracket. A body on an ephemeris instead takes its place and velocity from
piecewise Chebyshev polynomials (`chebyshev`, as JPL's ephemerides are evaluated). From + - x / sqrt and kernels/libm: the same bits on every CPU.
"""
import math
from collections import namedtuple

import numpy as np

from numba import types

from .._jit import implements, kernel
from . import libm

# an orbit's row
T0, ECC, A, B, PX, PY, PZ, QX, QY, QZ, N_HI, N_LO, M0, MU = range(14)
ELEMENTS = 14

# an ephemeris's row in elements (parent -1): its first time, its segments' length, their
# count, the first of them in coef, the coefficients per coordinate
E_START, E_LENGTH, E_COUNT, E_FIRST, E_TERMS = range(5)

RailsArrays = namedtuple("RailsArrays", (
    "rows",       # (R,) int64 rows of the bodies on rails, every parent before its children
    "parents",    # (R,) int64 their parents' rows; -1: on an ephemeris
    "elements",   # (R, ELEMENTS) float64: each orbit (see the module), or its ephemeris's
                  # row (E_START ...)
    "coef",       # (C, 3, D) float64: the ephemerides' Chebyshev coefficients, a segment a
                  # row (spacephys/ephemeris.py)
    "clock",      # (2,) the World's time base and step count at the call's start (World sets
                  # it before each call): a step's end is timed as World.t is
    "placed",     # (1,) int64: how many of the rows (the first) a force evaluation places;
                  # the rest, coasting bodies that pull nothing, only at a step's end
))

TWO_PI_HI = 6.283185307179586
TWO_PI_LO = 2.4492935982947064e-16
@kernel(lean=True)
def mean_anomaly(el, t, periodic):
    """M0 + n (t - t0) [rad], in (-pi, pi] when periodic (an ellipse)."""
    dt = t - el[T0]
    p, e = libm.two_product(el[N_HI], dt)
    e += el[N_LO] * dt
    if not periodic:
        return el[M0] + (p + e)
    k = math.floor((p + e + el[M0]) / TWO_PI_HI + 0.5)
    kh, kl = libm.two_product(k, TWO_PI_HI)
    return (((p - kh) - kl) + e - k * TWO_PI_LO) + el[M0]


@kernel(lean=True)
def eccentric_anomaly(M, e):
    """E with E - e sin E = M, M in [-pi, pi], 0 <= e < 1: Newton's steps inside the bracket
    [-pi, pi] (a bisection where a step would leave it)."""
    lo, hi = -math.pi, math.pi
    E = M + e * libm.sin(M) if e < 0.8 else (math.pi if M > 0.0 else -math.pi) * 0.9
    for _ in range(100):
        f = E - e * libm.sin(E) - M
        if f == 0.0:
            return E
        if f > 0.0:
            hi = E
        else:
            lo = E
        new = E - f / (1.0 - e * libm.cos(E))
        if abs(new - E) <= 4e-16 * (1.0 + abs(E)):
            return new                         # converged: Newton's step is rounding
        if not lo <= new <= hi:
            new = 0.5 * (lo + hi)
        E = new
    return E


@kernel(lean=True)
def hyperbolic_anomaly(M, e):
    """H with e sinh H - H = M, e > 1: Newton's steps inside a bracket (bisection where a
    step would leave it)."""
    bound = libm.asinh(abs(M) / (e - 1.0)) + 1.0 if M != 0.0 else 1.0
    lo, hi = -bound, bound
    H = libm.asinh(M / e)
    for _ in range(200):
        f = e * libm.sinh(H) - H - M
        if f == 0.0:
            return H
        if f > 0.0:
            hi = H
        else:
            lo = H
        new = H - f / (e * libm.cosh(H) - 1.0)
        if abs(new - H) <= 4e-16 * (1.0 + abs(H)):
            return new
        if not lo <= new <= hi:
            new = 0.5 * (lo + hi)
        H = new
    return H


@kernel(lean=True)
def relative(el, t):
    """The orbit's place and velocity relative to its parent at time t: (x, y, z, vx, vy,
    vz)."""
    e = el[ECC]
    a = el[A]
    b = el[B]
    n = el[N_HI]
    if e < 1.0:
        E = eccentric_anomaly(mean_anomaly(el, t, True), e)
        c, s = libm.cos(E), libm.sin(E)
        u = a * (c - e)
        w = b * s
        k = n * a / (1.0 - e * c)
        du = -k * s
        dw = k * (b / a) * c
    else:
        H = hyperbolic_anomaly(mean_anomaly(el, t, False), e)
        c, s = libm.cosh(H), libm.sinh(H)
        u = a * (e - c)
        w = b * s
        k = n * a / (e * c - 1.0)
        du = -k * s
        dw = k * (b / a) * c
    return (u * el[PX] + w * el[QX], u * el[PY] + w * el[QY], u * el[PZ] + w * el[QZ],
            du * el[PX] + dw * el[QX], du * el[PY] + dw * el[QY], du * el[PZ] + dw * el[QZ])


@kernel(lean=True)
def chebyshev(coef, row, t):
    """Place and velocity (x, y, z, vx, vy, vz) at time t of the ephemeris whose row (E_START
    ...) is given: the segment holding t (the first or last beyond the ends), its polynomials
    sum_k c_k T_k(s) at s in [-1, 1] and their derivatives (T_k and T_k' by their
    recurrences)."""
    length = row[E_LENGTH]
    count = int(row[E_COUNT])
    k = int(math.floor((t - row[E_START]) / length))
    k = min(max(k, 0), count - 1)
    s = 2.0 * (t - (row[E_START] + k * length)) / length - 1.0
    seg = int(row[E_FIRST]) + k
    terms = int(row[E_TERMS])
    x0 = 0.0
    x1 = 0.0
    x2 = 0.0
    v0 = 0.0
    v1 = 0.0
    v2 = 0.0
    t_prev, t_now = 1.0, s            # T_0, T_1
    d_prev, d_now = 0.0, 1.0          # T_0', T_1'
    for j in range(terms):
        if j == 0:
            T, D = 1.0, 0.0
        elif j == 1:
            T, D = s, 1.0
        else:
            T = 2.0 * s * t_now - t_prev
            D = 2.0 * t_now + 2.0 * s * d_now - d_prev
            t_prev, t_now = t_now, T
            d_prev, d_now = d_now, D
        x0 += coef[seg, 0, j] * T
        x1 += coef[seg, 1, j] * T
        x2 += coef[seg, 2, j] * T
        v0 += coef[seg, 0, j] * D
        v1 += coef[seg, 1, j] * D
        v2 += coef[seg, 2, j] * D
    f = 2.0 / length
    return x0, x1, x2, v0 * f, v1 * f, v2 * f


@kernel
def chebyshev_many(coef, row, times, out):
    """chebyshev at each of times (m,) into out (m, 6) (Ephemeris.state)."""
    for q in range(times.size):
        r = chebyshev(coef, row, times[q])
        for c in range(6):
            out[q, c] = r[c]


def _place(rails, t, pos, vel):
    """Put the bodies on rails a force evaluation needs where their orbits have them at time
    t: all but the coasting bodies that pull nothing (nothing feels them, they feel nothing)."""
    _place_rows(rails, t, pos, vel, rails.placed[0])


@kernel(lean=True)
def _place_rows(rails, t, pos, vel, count):
    """Put the first `count` bodies on rails where their orbits have them at time t (its
    parent's place and velocity in pos, vel plus its own about it: parents first)."""
    rows, parents, elements = rails.rows, rails.parents, rails.elements
    for r in range(count):
        i = rows[r]
        p = parents[r]
        if p < 0:
            x, y, z, vx, vy, vz = chebyshev(rails.coef, elements[r], t)
            pos[i, 0] = x
            pos[i, 1] = y
            pos[i, 2] = z
            vel[i, 0] = vx
            vel[i, 1] = vy
            vel[i, 2] = vz
            continue
        x, y, z, vx, vy, vz = relative(elements[r], t)
        pos[i, 0] = pos[p, 0] + x
        pos[i, 1] = pos[p, 1] + y
        pos[i, 2] = pos[p, 2] + z
        vel[i, 0] = vel[p, 0] + vx
        vel[i, 1] = vel[p, 1] + vy
        vel[i, 2] = vel[p, 2] + vz


def _now(rails, t0, steps, dt):
    """The time after `steps` steps of dt of this call: t0 + steps dt, or with rails World.t's
    own (its time base + its step count x dt), so that a body on rails sees the same times
    however a run is cut into calls (a recorded World's calls end at its frames)."""
    return rails.clock[0] + (rails.clock[1] + steps) * dt


def _settle(rails, steps, dt, pos, vel):
    """After a round: put every body on rails where its orbit has it once `steps` steps of
    dt of this call are done, at World.t's own time (its time base + its step count x dt,
    not the call's start + steps x dt, which rounds differently)."""
    _place_rows(rails, now(rails, 0.0, steps, dt), pos, vel, rails.rows.size)


def _hold(rails, out):
    """Zero the accelerations of the bodies on rails (they feel nothing)."""
    for r in range(rails.rows.size):
        i = rails.rows[r]
        out[i, 0] = 0.0
        out[i, 1] = 0.0
        out[i, 2] = 0.0


# Each has one body for None (no rails: inlined into its caller, so that a scene without
# rails compiles nothing more for them) and one for RailsArrays (see step._actor_arrays).
def place(rails, t, pos, vel):
    """Put the bodies on rails where their orbits have them at time t (see _place)."""


def settle(rails, steps, dt, pos, vel):
    """The bodies on rails placed after a round (see _settle)."""


def hold(rails, out):
    """Zero the bodies on rails' accelerations (see _hold)."""


def now(rails, t0, steps, dt):
    """The time after `steps` steps of this call (see _now)."""


def _plain_now(rails, t0, steps, dt):
    return t0 + steps * dt


def _none(t, *rest):
    return isinstance(t, types.NoneType)


def _table(t, *rest):
    return not isinstance(t, types.NoneType)


# (the None bodies name their arguments: a *args body inlined into a parallel loop does not
# lower)
for _stub, _body, _nothing in (
        (place, _place, lambda rails, t, pos, vel: None),
        (settle, _settle, lambda rails, steps, dt, pos, vel: None),
        (hold, _hold, lambda rails, out: None),
        (now, _now, _plain_now)):
    implements(_stub, _nothing, _none, inline=True)
    implements(_stub, _body, _table, lean=True)


@kernel
def jump(rails, steps, dt, pos, vel, prev):
    """Time passes with nothing integrated (time warp, World.advance): the bodies on rails
    where their orbits have them after `steps` steps of this call, and their places one step
    before into prev (what World.interpolate draws from)."""
    _place_rows(rails, now(rails, 0.0, steps - 1, dt), pos, vel, rails.rows.size)
    for r in range(rails.rows.size):
        i = rails.rows[r]
        for c in range(3):
            prev[i, c] = pos[i, c]
    _place_rows(rails, now(rails, 0.0, steps, dt), pos, vel, rails.rows.size)


@kernel
def jump_frames(rails, at, steps, dt, pos, vel, mass, fpos, fvel, fmass):
    """The frames a jump of `steps` steps passes (at (F,): step counts of this call, its
    last step's included, as step.capture takes them): every body as it is (nothing is
    integrated), the bodies on rails where their orbits have them then."""
    for f in range(at.size):
        if at[f] > steps:
            break
        for i in range(mass.size):
            for c in range(3):
                fpos[f, i, c] = pos[i, c]
                fvel[f, i, c] = vel[i, c]
            fmass[f, i] = mass[i]
        _place_rows(rails, now(rails, 0.0, at[f], dt), fpos[f], fvel[f], rails.rows.size)


@kernel
def fit(times, values, start, length, terms, out):
    """Least-squares Chebyshev polynomials of `terms` terms through the samples values
    (m, 3) at times (m,) of one segment [start, start + length]: out (3, terms). The normal
    equations summed and solved (Gaussian elimination, partial pivoting) in a fixed order:
    the same coefficients on every CPU (a LAPACK fit would not be)."""
    m = times.size
    G = np.zeros((terms, terms))
    r = np.zeros((terms, 3))
    T = np.empty(terms)
    for q in range(m):
        s = 2.0 * (times[q] - start) / length - 1.0
        for j in range(terms):
            T[j] = 1.0 if j == 0 else (s if j == 1 else 2.0 * s * T[j - 1] - T[j - 2])
        for j in range(terms):
            for k in range(terms):
                G[j, k] += T[j] * T[k]
            for c in range(3):
                r[j, c] += T[j] * values[q, c]
    for col in range(terms):                      # elimination with partial pivoting
        best = col
        for row in range(col + 1, terms):
            if abs(G[row, col]) > abs(G[best, col]):
                best = row
        if best != col:
            for k in range(terms):
                G[col, k], G[best, k] = G[best, k], G[col, k]
            for c in range(3):
                r[col, c], r[best, c] = r[best, c], r[col, c]
        for row in range(col + 1, terms):
            f = G[row, col] / G[col, col]
            for k in range(col, terms):
                G[row, k] -= f * G[col, k]
            for c in range(3):
                r[row, c] -= f * r[col, c]
    for col in range(terms - 1, -1, -1):
        for c in range(3):
            acc = r[col, c]
            for k in range(col + 1, terms):
                acc -= G[col, k] * out[c, k]
            out[c, col] = acc / G[col, col]
