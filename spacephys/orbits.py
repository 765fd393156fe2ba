"""Orbital elements <-> state vectors for two-body orbits (elliptic, parabolic, hyperbolic),
and Kepler's equation.

Conventions as in Murray & Dermott, Solar System Dynamics (1999), ch. 2: a semi-major axis
(negative for a hyperbola, inf for a parabola), e eccentricity, i inclination, Omega longitude
of the ascending node, omega argument of pericentre, f true anomaly, M mean anomaly (elliptic:
E - e sin E, in (-pi, pi]; hyperbolic: e sinh F - F; parabolic: Barker's D + D^3/3 with D = tan(f/2));
angles in radians; mu = G (m_parent + m). Where an angle is undefined it is set so that the
state still round-trips: an equatorial orbit has Omega = 0 (omega then counts from the x axis,
clockwise seen from +z when i = pi), a circular one omega = 0 (f counts from the node).
"""
import math
from dataclasses import dataclass

import numpy as np

from . import _validate as check
from .forces import MUTUAL
from .kernels import conics, libm, markers
from . import portable


def solve_kepler(M, e):
    """Eccentric anomaly E with E - e sin E = M, for 0 <= e < 1; to full double precision.

    Newton's method from the start E = M + 0.85 e sign(sin M) (Danby 1988), which converges for
    every M and e < 1; M is reduced to [-pi, pi] first (kernels/conics.py, run by Python).
    """
    e = check.scalar("e", e, minimum=0.0)
    if not e < 1.0:
        raise ValueError(f"e = {e}: Kepler's equation E - e sin E = M is for 0 <= e < 1 "
                         f"(true_anomaly takes any e)")
    return conics.py.solve_kepler(check.scalar("M", M), e)


def mean_anomaly(E, e):
    """E - e sin E, as (1 - e) E + e (E - sin E): near e = 1 and E = 0 the plain form loses
    the digits that (1 - e) E keeps (kernels/conics.py, run by Python)."""
    return conics.py.mean_anomaly(E, e)


def elements_to_state(mu, a=None, e=0.0, i=0.0, Omega=0.0, omega=0.0, *, f=None, M=None,
                      q=None):
    """Position and velocity (3,) relative to the parent, for any conic.

    mu > 0 [length^3 / time^2]; e >= 0; the size as a [length] (a > 0 for e < 1, a < 0 for
    e > 1) or as the pericentre distance q > 0 (the only way for e = 1); give exactly one of
    f (true anomaly) or M (mean anomaly). sp.state_from_elements is the same function.
    """
    mu = check.scalar("mu", mu, positive=True)
    e = check.scalar("e", e, minimum=0.0)
    if (a is None) == (q is None):
        raise ValueError("give exactly one of a (semi-major axis) or q (pericentre distance)")
    if q is not None:
        q = check.scalar("q", q, positive=True)
    else:
        a = check.scalar("a", a)
        if e == 1.0 or not (a > 0.0 if e < 1.0 else a < 0.0):
            raise ValueError(f"a = {a} with e = {e}: a > 0 for an ellipse (e < 1), a < 0 for "
                             f"a hyperbola (e > 1); give q, the pericentre distance, for a "
                             f"parabola (e = 1)")
        q = a * (1.0 - e)
    if (f is None) == (M is None):
        raise ValueError("give exactly one of f (true anomaly) or M (mean anomaly)")
    if f is None:
        f = true_anomaly(check.scalar("M", M), e)
    f = check.scalar("f", f)
    # a (1 - e^2) as before q existed: the scenes built on it keep their bits
    p = q * (1.0 + e) if a is None else a * (1.0 - e * e)
    if e >= 1.0 and 1.0 + e * libm.py.cos(f) <= 0.0:
        limit = libm.py.acos(-1.0 / e)
        raise ValueError(f"f = {f}: an orbit of e = {e} has no point there (|f| < {limit:.6g})")
    x, y, z, vx, vy, vz = conics.py.state(mu, p, e, check.scalar("i", i),
                                          check.scalar("Omega", Omega),
                                          check.scalar("omega", omega), f)
    return np.array([x, y, z]), np.array([vx, vy, vz])


state_from_elements = elements_to_state


def true_anomaly(M, e):
    """f from the mean anomaly M for any e >= 0 (see the module for M's definitions)."""
    if e < 1.0:
        return conics.py.elliptic_anomaly(M, e)
    if e == 1.0:
        # Barker: D + D^3/3 = M, the real root of the cubic
        w = libm.py.cbrt(1.5 * M + math.sqrt(2.25 * M * M + 1.0))
        return 2.0 * libm.py.atan(w - 1.0 / w)
    # e sinh F - F = M by Newton from asinh(M / e) (monotonic and convex on each side)
    F = libm.py.asinh(M / e)
    for _ in range(100):
        step = (e * libm.py.sinh(F) - F - M) / (e * libm.py.cosh(F) - 1.0)
        F -= step
        if abs(step) <= 4e-16 * max(1.0, abs(F)):
            break
    return 2.0 * libm.py.atan2(math.sqrt(e + 1) * libm.py.sinh(F / 2),
                               math.sqrt(e - 1) * libm.py.cosh(F / 2))


@dataclass(frozen=True)
class Elements:
    """Osculating elements of a two-body orbit (see the module for the conventions; f and
    M in (-pi, pi]).

    a [length] (< 0 hyperbolic, inf parabolic), e, i, Omega, omega, f, M [rad]; period
    [time] (inf unless bound); pericentre, apocentre [length] (apocentre inf unless bound);
    time_to_pericentre [time] (the next passage; for an unbound orbit negative once it is
    past), time_to_apocentre [time] (inf unless bound); mu [length^3 / time^2]; about: the
    id of the body the orbit is about (None: a central field or a given mu).
    """
    a: float
    e: float
    i: float
    Omega: float
    omega: float
    f: float
    M: float
    period: float
    pericentre: float
    apocentre: float
    time_to_pericentre: float
    time_to_apocentre: float
    mu: float
    about: object = None


def state_to_elements(mu, pos, vel, about=None):
    """Elements of the orbit of relative position pos and velocity vel ((2,) or (3,)) about a
    mass with mu = G (m_parent + m) [length^3 / time^2]. Refuses a radial (h = 0) orbit."""
    mu = check.scalar("mu", mu, positive=True)
    r = np.zeros(3)
    v = np.zeros(3)
    r[:len(pos)], v[:len(vel)] = pos, vel
    rn = portable.norm(r)
    h = np.cross(r, v)
    hn = portable.norm(h)
    if not (rn > 0.0 and hn > 0.0 and np.all(np.isfinite(h))):
        raise ValueError(f"pos = {list(pos)}, vel = {list(vel)}: no orbital plane (the body "
                         f"sits on the parent or moves straight toward or away from it)")
    ev = ((portable.dot(v, v) - mu / rn) * r - portable.dot(r, v) * v) / mu
    e = portable.norm(ev)
    p = hn * hn / mu
    energy = 0.5 * portable.dot(v, v) - mu / rn
    hat = h / hn
    i = libm.py.atan2(math.hypot(h[0], h[1]), h[2])      # not acos(h_z): exact near 0 and pi
    node = np.array([-h[1], h[0], 0.0])
    nn = portable.norm(node)
    if nn <= 1e-15 * hn:                       # equatorial: the node is the x axis
        Omega, node = 0.0, np.array([1.0, 0.0, 0.0])
    else:
        Omega = libm.py.atan2(node[1], node[0]) % (2 * math.pi)
        node /= nn
    ahead = np.cross(hat, node)                # 90 degrees ahead of the node, in the plane
    if e <= 1e-15:                             # circular: pericentre at the node
        omega, e, ev = 0.0, 0.0, node
    else:
        omega = libm.py.atan2(portable.dot(ev, ahead), portable.dot(ev, node)) % (2 * math.pi)
    ehat = ev / portable.norm(ev)
    f = libm.py.atan2(portable.dot(r, np.cross(hat, ehat)), portable.dot(r, ehat))
    q = p / (1.0 + e)
    if e < 1.0:
        a = -mu / (2.0 * energy)
        E = 2.0 * libm.py.atan2(math.sqrt(1 - e) * libm.py.sin(f / 2),
                                math.sqrt(1 + e) * libm.py.cos(f / 2))
        M = mean_anomaly(E, e)            # in (-pi, pi]: wrapped to [0, 2 pi) it would
        n = math.sqrt(mu / (a * a * a))   # lose digits just before pericentre
        period, apocentre = 2 * math.pi / n, a * (1.0 + e)
        to_peri = (-M if M <= 0.0 else 2 * math.pi - M) / n
        to_apo = (math.pi - M) / n
    else:
        if e == 1.0:
            a = math.inf
            D = libm.py.tan(f / 2)
            M = D + D * D * D / 3
            n = math.sqrt(mu / (2.0 * q * q * q))
        else:
            a = -mu / (2.0 * energy) if energy > 0.0 else -q / (e - 1.0)
            # on a near-radial hyperbola rounding can put f a hair past the asymptote
            x = math.sqrt((e - 1) / (e + 1)) * libm.py.tan(f / 2)
            F = 2.0 * libm.py.atanh(math.copysign(min(abs(x), math.nextafter(1.0, 0.0)), x))
            M = e * libm.py.sinh(F) - F
            n = math.sqrt(mu / -(a * a * a))
        period = apocentre = to_apo = math.inf
        to_peri = -M / n
    return Elements(float(a), e, i, Omega, omega, f, float(M), float(period), float(q),
                    float(apocentre), float(to_peri), float(to_apo), mu, about)


def period(mu, a):
    """Orbital period 2 pi sqrt(a^3 / mu) [time]."""
    return 2.0 * np.pi * np.sqrt(a * a * a / mu)


def kepler_state(mu, a, e, t, *, i=0.0, Omega=0.0, omega=0.0, M0=0.0):
    """Exact two-body position and velocity (3,) at time t for an orbit with mean anomaly M0 at t=0."""
    n = np.sqrt(mu / (a * a * a))
    return elements_to_state(mu, a, e, i, Omega, omega, M=M0 + n * t)


def hardest_pulling(world, rows):
    """(row (k,) int64, distance (k,), pulling): for each of the rows (k,), the row of the
    body pulling on it hardest (G m_j / d^2, the body itself left out; -1 where none does)
    and its distance (nan: none); how many bodies pull."""
    rows = np.asarray(rows, np.int64)
    pick, dist = np.empty(rows.size, np.int64), np.empty(rows.size)
    pos, mass, active = world.driver.view("pos", "mass", "active")
    pulling = markers.hardest(pos, mass, active, rows, pick, dist)
    return pick, dist, pulling


def _parent(world, body_id, about):
    """(row of the body, mu, parent position, parent velocity (3,), about id or None)."""
    i = world.index_of(body_id, "id")
    # a body that does not pull (a passive ship) is pulled without pulling back: mu = G m_parent
    G, m = world.G, float(world.mass[i]) if world.pulls[i] else 0.0
    if about is None and world.gravity == "central":
        c = np.zeros(3)
        c[:world.dim] = world.central_pos
        return i, G * (world.central_mass + m), c, np.zeros(3), None
    if world.gravity not in MUTUAL + ("central",):
        raise ValueError(f"no orbit to report with gravity={world.gravity!r}: give gravity "
                         f"'direct', 'tree' or 'central'")
    if about is None:
        j = int(hardest_pulling(world, [i])[0][0])
        if j < 0:
            raise ValueError(f"id = {body_id}: no body pulls on it, so it has no orbit")
    else:
        j = world.index_of(about, "about")
        if j == i:
            raise ValueError(f"about = {about}: a body does not orbit itself")
    if world.mass[j] <= 0.0:
        raise ValueError(f"about = {int(world.ids[j])}: a massless body has no orbit about it")
    parent = np.zeros((2, 3))
    parent[0, :world.dim], parent[1, :world.dim] = world.pos[j], world.vel[j]
    return i, G * (float(world.mass[j]) + m), parent[0], parent[1], int(world.ids[j])


def orbit_of(world, body_id, about=None):
    """World.elements: the Elements of a body's orbit about `about` (an id) or the body
    pulling on it hardest; about the field's centre with gravity="central"."""
    i, mu, x, v, about = _parent(world, body_id, about)
    return state_to_elements(mu, world.pos[i] - x[:world.dim], world.vel[i] - v[:world.dim],
                             about)


def put_on_orbit(world, body_id, about, elements):
    """World.set_orbit: place a body on the orbit the elements (keywords of
    elements_to_state) describe about `about` (see orbit_of for None)."""
    unknown = set(elements) - {"a", "e", "i", "Omega", "omega", "f", "M", "q"}
    if unknown:
        raise ValueError(f"{sorted(unknown)[0]}: not an orbital element; give a or q, e, i, "
                         f"Omega, omega, f or M")
    i, mu, x, v, _ = _parent(world, body_id, about)
    pos, vel = elements_to_state(mu, **elements)
    if world.dim == 2 and (abs(pos[2]) > 1e-12 * portable.norm(pos) or
                           abs(vel[2]) > 1e-12 * portable.norm(vel)):
        raise ValueError(f"i = {elements.get('i')}: a 2D World's orbits lie in its plane "
                         f"(i = 0, or pi for clockwise)")
    world.set_body(int(world.ids[i]), pos=(x + pos)[:world.dim], vel=(v + vel)[:world.dim])
