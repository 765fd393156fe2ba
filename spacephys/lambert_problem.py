"""Lambert's problem: the two-body orbit that goes from r1 to r2 in a given time.

Written from D. Izzo, "Revisiting Lambert's problem", Celestial Mechanics and Dynamical
Astronomy 121 (2015) 1-15: the Lancaster-Blanchard variable x with lambda^2 = 1 - c/s, the
non-dimensional time T(x) and its derivatives, Householder iterations from Izzo's initial
guesses; for N revolutions the minimum time by Halley iterations on dT/dx = 0 and the two
branches either side of it. Three departures, for full double precision everywhere (checked
against 50-digit arithmetic: T(x) to 3e-15, velocities to 6e-15 where the geometry is well
conditioned): T is Lagrange's form with sin(theta) = 2 sin cos of the half angle, and
Battin's series (with its own dT/dx) wherever the series argument is below 1/4, which
covers every place Lagrange's form cancels (near the parabola, and lambda near 1); lambda
and sigma come from the half transfer angle, not from 1 - c/s; every iteration stays inside
a bracket where T(x) is monotonic (bisection when a step leaves it).
"""
import math

import numpy as np

from . import _validate as check
from .kernels import libm

BRANCHES = ("left", "right")


def _series(z):
    """Battin's Q(z) = 4/3 2F1(3, 1; 5/2; z) and dQ/dz, for |z| < 1/4 (30 terms: 1e-17)."""
    term, q, dq = 1.0, 1.0, 0.0
    for n in range(1, 60):
        term *= (n + 2.0) / (n + 1.5) * z          # (3)_n / (5/2)_n z^n
        q += term
        dq += n * term
        if abs(term) < 1e-17 * q:
            break
    return 4.0 / 3.0 * q, 4.0 / 3.0 * (dq / z if z else 1.2)   # dQ/dz(0) = 4/3 * 6/5


def _w(half, sn, cn, hyperbolic):
    """(theta / sn)^3 S(theta) for theta = 2 half, sn, cn = sin, cos(half) (sinh, cosh for a
    hyperbola) and S = (theta - sin theta) / theta^3 ((sinh theta - theta) / theta^3): finite
    at theta = 0. sin theta = 2 sn cn, exact where sin(theta) of a rounded theta is not
    (sinh(140) from theta's last bit is 1e-14 off)."""
    th = 2.0 * half
    if abs(th) < 1.0:                               # the series: theta - sin theta cancels
        t2, term, s = th * th, 1.0 / 6.0, 1.0 / 6.0
        for j in range(4, 30, 2):
            term *= (t2 if hyperbolic else -t2) / (j * (j + 1))
            s += term
            if abs(term) < 1e-17 * s:
                break
    else:
        s = (2.0 * sn * cn - th if hyperbolic else th - 2.0 * sn * cn) / (th * th * th)
    r = th / sn if sn else 2.0
    return r * r * r * s


def _tof(x, lam, k, n):
    """T(x) and dT/dx for n revolutions; k = 1 - lam^2 (= c/s, kept exact)."""
    e = (1.0 - x) * (1.0 + x)                       # 1 - x^2, exact near x = +-1
    y = math.sqrt(k + lam * lam * x * x)            # sqrt(1 - lam^2 (1 - x^2))
    eta = k / (y + lam * x) if lam * x > 0 else y - lam * x       # y - lam x, no cancellation
    z = 0.5 * ((k / (1.0 + lam) if lam > 0 else 1.0 - lam) - x * eta)  # Battin's S1
    sq = math.sqrt(abs(e))
    multi = n * math.pi / (sq * sq * sq) if n else 0.0
    if abs(z) < 0.25:
        # Battin: near the parabola Lagrange's form is a difference of near-equal terms
        q, dq = _series(z)
        t = 0.5 * (eta * eta * eta * q + 4.0 * lam * eta) + multi
        # d eta/dx = -lam eta / y, dz/dx = -eta^2 / (2 y)
        dt = -eta / (2.0 * y) * (3.0 * lam * eta * eta * q + 0.5 * (eta * eta) * (eta * eta) * dq + 4.0 * lam * lam)
        return t, dt + (3.0 * x * multi / e if n else 0.0)
    if e > 0.0:                             # ellipse: alpha/2 = acos x, beta/2 = asin(lam sq)
        wa = _w(libm.py.atan2(sq, x), sq, x, False)
        wb = _w(libm.py.atan2(lam * sq, y), lam * sq, y, False)
    else:                                   # hyperbola: alpha/2 = acosh x
        wa = _w(libm.py.asinh(sq), sq, x, True)
        wb = _w(libm.py.asinh(lam * sq), lam * sq, y, True)
    lam3 = lam * lam * lam
    t = 0.5 * (wa - lam3 * wb) + multi
    return t, (3.0 * x * t - 2.0 + 2.0 * lam3 * x / y) / e


def _higher(x, lam, k, t, dt):
    """d2T/dx2 and d3T/dx3 from T and dT/dx (Izzo eq. 22)."""
    e = (1.0 - x) * (1.0 + x)
    y = math.sqrt(k + lam * lam * x * x)
    lam3, y3 = lam * lam * lam, y * y * y
    d2 = (3.0 * t + 5.0 * x * dt + 2.0 * k * lam3 / y3) / e
    d3 = (7.0 * x * d2 + 8.0 * dt - 6.0 * k * lam3 * lam * lam * x / (y3 * y * y)) / e
    return d2, d3


def _solve(target, lam, k, n, x, lo, hi, falling):
    """x in (lo, hi) with T(x) = target, T falling or rising there: Householder steps (Newton
    within 1e-4 of x = 1, where the recurrences for the higher derivatives lose digits)."""
    for _ in range(100):
        t, d1 = _tof(x, lam, k, n)
        f = t - target
        if abs(f) <= 1e-15 * target:                # T's own rounding: as close as it gets
            return x
        if (f > 0.0) == falling:                    # T too big on a falling branch: go right
            lo = x
        else:
            hi = x
        if abs((1.0 - x) * (1.0 + x)) > 1e-4:
            d2, d3 = _higher(x, lam, k, t, d1)
            new = x - f * (d1 * d1 - f * d2 / 2) / (d1 * (d1 * d1 - f * d2) + d3 * f * f / 6)
        else:
            new = x - f / d1
        # x's scale: the distance to the pole of T at x = -1 (and at +1 for n >= 1)
        if abs(new - x) <= 1e-13 * (min(1.0 + x, 1.0 - x) if n else 1.0 + x):
            return new                              # order 4 (2): the next step is noise
        if not lo < new < hi:                       # left the bracket (or NaN): bisect
            new = 0.5 * (lo + hi) if hi < math.inf else 2.0 * x + 1.0
            if not lo < new < hi:                   # lo and hi are neighbouring doubles
                return x
        x = new
    raise ArithmeticError(f"lambert: no convergence for T = {target}, lambda = {lam}")


def _minimum_time(lam, k, n):
    """(x, T) of the least time for n >= 1 revolutions: Halley on dT/dx = 0, T convex."""
    x, lo, hi = 0.0, -1.0, 1.0
    for _ in range(100):
        t, d1 = _tof(x, lam, k, n)
        d2, d3 = _higher(x, lam, k, t, d1)
        lo, hi = (lo, x) if d1 > 0.0 else (x, hi)
        new = x - 2.0 * d1 * d2 / (2.0 * d2 * d2 - d1 * d3)
        if abs(new - x) <= 1e-14:                   # Halley, order 3: converged
            return new, _tof(new, lam, k, n)[0]
        if not lo < new < hi:
            new = 0.5 * (lo + hi)
        x = new
    return x, _tof(x, lam, k, n)[0]


def _cross(a, b):
    return [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]


def _vector(name, value):
    arr = check.floats(name, value)
    if arr.shape not in ((2,), (3,)):
        raise ValueError(f"{name} has shape {arr.shape}, expected (2,) or (3,)")
    if not arr.any():
        raise ValueError(f"{name} = {arr.tolist()}: must not be zero (the centre of attraction)")
    return arr


def lambert(r1, r2, tof, mu, *, prograde=True, revolutions=0, branch="left"):
    """Velocities (v1, v2) at r1 and r2 of the two-body orbit from r1 to r2 in time tof.

    r1, r2 : (3,) or (2,) positions relative to the centre of attraction [length]; v1, v2
             come back in the same shape [length / time]
    tof : float > 0, the time of flight [time]
    mu : float > 0, the gravitational parameter G M [length^3 / time^2]
    prograde : True: the transfer turns counter-clockwise about +z (h_z >= 0); False:
               clockwise (h_z <= 0). This picks the short or the long way round
    revolutions : int >= 0, the full turns made on the way
    branch : "left" | "right", which of the two orbits of revolutions >= 1 (ignored for 0):
             Izzo's branches of T(x), left or right of the minimum time; left is the one
             of smaller semi-major axis
    Raises ValueError on bad input; for r1 and r2 pointing the same way (transfer angle 0
    or 360 degrees), or exactly opposite in 3D (no plane); for a tof below the minimum for
    the revolutions asked (the message gives that minimum) or outside what doubles resolve
    (1e-30 to ~1e19 times sqrt(s^3 / 2 mu), s the half perimeter of the triangle centre,
    r1, r2). In 3D near 0 and 180 degrees the plane, and so the answer, moves by ~1e-16 /
    sin(angle) with the last bits of r1 and r2.
    """
    a, b = _vector("r1", r1), _vector("r2", r2)
    if b.shape != a.shape:
        raise ValueError(f"r2 has shape {b.shape}, expected {a.shape} like r1")
    tof = check.scalar("tof", tof, positive=True)
    mu = check.scalar("mu", mu, positive=True)
    if not isinstance(prograde, (bool, np.bool_)):
        raise ValueError(f"prograde = {prograde!r}: must be True or False")
    n = check.count("revolutions", revolutions)
    if not isinstance(branch, str) or branch not in BRANCHES:
        raise ValueError(f"branch = {branch!r}: must be 'left' or 'right'")
    dim = a.shape[0]
    # plain floats from here: numpy's overhead on 3-vectors would be most of the cost
    p1, p2 = a.tolist() + [0.0] * (3 - dim), b.tolist() + [0.0] * (3 - dim)
    m1, m2 = math.hypot(*p1), math.hypot(*p2)
    u1, u2 = [q / m1 for q in p1], [q / m2 for q in p2]
    normal = _cross(u1, u2)
    nn = math.hypot(*normal)
    if nn == 0.0 and sum(p * q for p, q in zip(u1, u2)) > 0.0:
        raise ValueError(f"r1 = {a.tolist()} and r2 = {b.tolist()} point the same way: the "
                         f"transfer angle is 0 or 360 degrees, a radial orbit or a full turn")
    # the transfer's angular momentum direction: +-z in 2D; in 3D the normal of r1, r2 or
    # its opposite, so that h_z has the asked sign (the long way round when it flips)
    long_way = normal[2] < 0.0 if prograde else normal[2] > 0.0
    if dim == 2:
        h = [0.0, 0.0, 1.0 if prograde else -1.0]
    elif nn == 0.0:
        raise ValueError(f"r1 = {a.tolist()} and r2 = {b.tolist()} are 180 degrees apart: the "
                         f"plane of the transfer is undefined (tilt either slightly)")
    else:
        h = [q / nn * (-1.0 if long_way else 1.0) for q in normal]
    # the half transfer angle from |u1 + u2| = 2 cos and |u2 - u1| = 2 sin: exact near 0 and
    # 180 degrees, where 1 - c / s and sqrt(1 - rho^2) would cancel
    cos_half, sin_half = 0.5 * math.dist(u1, [-q for q in u2]), 0.5 * math.dist(u1, u2)
    c = math.dist(p1, p2)
    s = 0.5 * (m1 + m2 + c)
    lam = math.sqrt(m1 * m2) / s * cos_half * (-1.0 if long_way else 1.0)
    k = c / s                                        # 1 - lam^2
    scale = math.sqrt(2.0 * mu / s) / s              # T = scale * tof, Izzo's time
    T = tof * scale
    T00 = libm.py.atan2(math.sqrt(k), lam) + lam * math.sqrt(k)        # T(x = 0), n = 0
    # beyond these x would lie within 1e-13 of +-1 (or T itself near underflow), where
    # doubles no longer resolve it: lambert would return some neighbouring orbit
    longest = 1e19 * (T00 if n == 0 else n * math.pi)
    if not 1e-30 <= T <= longest:
        raise ValueError(f"tof = {tof}: outside what double precision resolves for this "
                         f"geometry and {n} revolution(s), {1e-30 / scale:.3g} to "
                         f"{longest / scale:.3g}")

    if n == 0:
        T1 = 2.0 / 3.0 * (1.0 - lam * lam * lam)                           # T(x = 1), the parabola
        if T >= T00:
            x0 = libm.py.pow(T00 / T, 2.0 / 3.0) - 1.0
        elif T < T1:
            x0 = 2.5 * T1 / T * (T1 - T) / (1.0 - lam * lam * lam * lam * lam) + 1.0
        else:
            x0 = libm.py.pow(T00 / T, libm.py.log(T1 / T00) * 1.4426950408889634) - 1.0  # log2
        x = _solve(T, lam, k, 0, x0, -1.0, math.inf, True)
    else:
        xm, tmin = _minimum_time(lam, k, n)
        if T < tmin:
            raise ValueError(f"tof = {tof}: too short for {n} revolution(s) on this geometry; "
                             f"the minimum is {tmin / scale!r}")
        if branch == "left":
            q = libm.py.pow((n + 1) * math.pi / (8.0 * T), 2.0 / 3.0)
            lo, hi = -1.0, xm
        else:
            q = libm.py.pow(8.0 * T / (n * math.pi), 2.0 / 3.0)
            lo, hi = xm, 1.0
        x0 = (q - 1.0) / (q + 1.0)
        if not lo < x0 < hi:
            x0 = 0.5 * (lo + hi)
        x = _solve(T, lam, k, n, x0, lo, hi, branch == "left") if T > tmin else xm

    # velocities from x (Izzo section 3): radial and transverse parts at both ends
    y = math.sqrt(k + lam * lam * x * x)
    gamma = math.sqrt(0.5 * mu * s)
    rho = (m1 - m2) / c
    sigma = 2.0 * math.sqrt(m1 * m2) * sin_half / c  # sqrt(1 - rho^2)
    transverse = gamma * sigma * (y + lam * x if lam * x >= 0 else k / (y - lam * x))
    vr1 = gamma * ((lam * y - x) - rho * (lam * y + x)) / m1
    vr2 = -gamma * ((lam * y - x) + rho * (lam * y + x)) / m2
    v1 = [vr1 * u + transverse / m1 * t for u, t in zip(u1, _cross(h, u1))]
    v2 = [vr2 * u + transverse / m2 * t for u, t in zip(u2, _cross(h, u2))]
    return np.array(v1[:dim]), np.array(v2[:dim])
