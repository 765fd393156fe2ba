"""Orbital elements <-> state vectors for bound (elliptic) two-body orbits, and Kepler's equation.

Conventions as in Murray & Dermott, Solar System Dynamics (1999), ch. 2: a semi-major axis,
e eccentricity, i inclination, Omega longitude of the ascending node, omega argument of
pericentre, f true anomaly, M mean anomaly; angles in radians; mu = G (m_parent + m).
"""
import numpy as np

from . import _validate as check


def solve_kepler(M, e):
    """Eccentric anomaly E with E - e sin E = M, for 0 <= e < 1; to full double precision.

    Newton's method from the start E = M + 0.85 e sign(sin M) (Danby 1988), which converges for
    every M and e < 1; M is reduced to [-pi, pi] first.
    """
    M = float(np.remainder(M + np.pi, 2 * np.pi) - np.pi)
    E = M + 0.85 * e * np.sign(np.sin(M))
    for _ in range(50):
        f = E - e * np.sin(E) - M
        step = f / (1.0 - e * np.cos(E))
        E -= step
        if abs(step) <= 4e-16 * max(1.0, abs(E)):
            break
    return E


def _rotation(i, Omega, omega):
    """Columns: the unit vectors toward pericentre (P) and 90 degrees ahead in the plane (Q)."""
    cO, sO, co, so, ci, si = np.cos(Omega), np.sin(Omega), np.cos(omega), np.sin(omega), np.cos(i), np.sin(i)
    P = np.array([cO * co - sO * so * ci, sO * co + cO * so * ci, so * si])
    Q = np.array([-cO * so - sO * co * ci, -sO * so + cO * co * ci, co * si])
    return P, Q


def elements_to_state(mu, a, e, i=0.0, Omega=0.0, omega=0.0, *, f=None, M=None):
    """Position and velocity (3,) relative to the parent for an elliptic orbit.

    mu > 0 [length^3 / time^2]; a > 0 [length]; 0 <= e < 1; give exactly one of f or M.
    """
    mu = check.scalar("mu", mu, positive=True)
    a = check.scalar("a", a, positive=True)
    e = check.scalar("e", e, minimum=0.0)
    if e >= 1.0:
        raise ValueError(f"e = {e}: elements_to_state handles bound orbits, e < 1")
    if (f is None) == (M is None):
        raise ValueError("give exactly one of f (true anomaly) or M (mean anomaly)")
    if f is None:
        E = solve_kepler(check.scalar("M", M), e)
        f = 2.0 * np.arctan2(np.sqrt(1 + e) * np.sin(E / 2), np.sqrt(1 - e) * np.cos(E / 2))
    f = check.scalar("f", f)
    p = a * (1.0 - e * e)
    r = p / (1.0 + e * np.cos(f))
    P, Q = _rotation(check.scalar("i", i), check.scalar("Omega", Omega), check.scalar("omega", omega))
    pos = r * (np.cos(f) * P + np.sin(f) * Q)
    vel = np.sqrt(mu / p) * (-np.sin(f) * P + (e + np.cos(f)) * Q)
    return pos, vel


def period(mu, a):
    """Orbital period 2 pi sqrt(a^3 / mu) [time]."""
    return 2.0 * np.pi * np.sqrt(a ** 3 / mu)


def kepler_state(mu, a, e, t, *, i=0.0, Omega=0.0, omega=0.0, M0=0.0):
    """Exact two-body position and velocity (3,) at time t for an orbit with mean anomaly M0 at t=0."""
    n = np.sqrt(mu / a ** 3)
    return elements_to_state(mu, a, e, i, Omega, omega, M=M0 + n * t)
