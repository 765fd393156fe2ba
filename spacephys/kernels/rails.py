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
method kept inside a bracket. From + - x / sqrt and kernels/libm: the same bits on every CPU.
"""
import math
from collections import namedtuple

from .._jit import kernel
from . import libm

# an orbit's row
T0, ECC, A, B, PX, PY, PZ, QX, QY, QZ, N_HI, N_LO, M0, MU = range(14)
ELEMENTS = 14

RailsArrays = namedtuple("RailsArrays", (
    "rows",       # (R,) int64 rows of the bodies on rails, every parent before its children
    "parents",    # (R,) int64 their parents' rows
    "elements",   # (R, ELEMENTS) float64: each orbit (see the module)
    "clock",      # (2,) the World's time base and step count at the call's start (World sets
                  # it before each call): a step's end is timed as World.t is
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
        s = libm.sin(E)
        f = E - e * s - M
        if f > 0.0:
            hi = E
        else:
            lo = E
        step = f / (1.0 - e * libm.cos(E))
        new = E - step
        if not lo < new < hi:
            new = 0.5 * (lo + hi)
        if abs(new - E) <= 4e-16 * (1.0 + abs(E)) or hi - lo <= 4e-16 * (1.0 + abs(E)):
            return new
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
        if f > 0.0:
            hi = H
        else:
            lo = H
        step = f / (e * libm.cosh(H) - 1.0)
        new = H - step
        if not lo < new < hi:
            new = 0.5 * (lo + hi)
        if abs(new - H) <= 4e-16 * (1.0 + abs(H)) or hi - lo <= 4e-16 * (1.0 + abs(H)):
            return new
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
def place(rails, t, pos, vel):
    """Put every body on rails where its orbit has it at time t (its parent's place and
    velocity in pos, vel plus its own about it: parents first). rails : RailsArrays or None
    (no rails: nothing)."""
    if rails is None:
        return
    rows, parents, elements = rails.rows, rails.parents, rails.elements
    for r in range(rows.size):
        i = rows[r]
        p = parents[r]
        x, y, z, vx, vy, vz = relative(elements[r], t)
        pos[i, 0] = pos[p, 0] + x
        pos[i, 1] = pos[p, 1] + y
        pos[i, 2] = pos[p, 2] + z
        vel[i, 0] = vel[p, 0] + vx
        vel[i, 1] = vel[p, 1] + vy
        vel[i, 2] = vel[p, 2] + vz


@kernel(lean=True)
def settle(rails, steps, dt, pos, vel):
    """After a round: put the bodies on rails where their orbits have them once `steps` steps
    of dt of this call are done, at World.t's own time (its time base + its step count x dt,
    not the call's start + steps x dt, which rounds differently)."""
    if rails is None:
        return
    clock = rails.clock
    place(rails, clock[0] + (clock[1] + steps) * dt, pos, vel)


@kernel(lean=True)
def hold(rails, out):
    """Zero the accelerations of the bodies on rails (they feel nothing)."""
    if rails is None:
        return
    for r in range(rails.rows.size):
        i = rails.rows[r]
        out[i, 0] = 0.0
        out[i, 1] = 0.0
        out[i, 2] = 0.0
