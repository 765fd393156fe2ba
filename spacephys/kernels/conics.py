"""Elliptic orbits from their elements, written once for Python and for kernels: orbits.py
calls the Python twins (`py.solve_kepler` etc., the same source run by Python: the same
operations in the same order, the same bits), a scenario's ring of thousands of bodies the
kernel `elliptic_states`, compiled (2 001 bodies placed in Python took 0.1 s of a warm
start). Conventions as in orbits.py; the trigonometry is kernels/libm.py's.
"""
import math

from .._jit import kernel
from . import libm


@kernel
def sign(x):
    """numpy's sign of x: -1.0, 1.0, 0.0 for either zero, NaN for NaN."""
    if x > 0.0:
        return 1.0
    if x < 0.0:
        return -1.0
    return x if x != x else 0.0


@kernel
def mean_anomaly(E, e):
    """E - e sin E, as (1 - e) E + e (E - sin E): near e = 1 and E = 0 the plain form loses
    the digits that (1 - e) E keeps (E - sin E by its series below |E| = 0.5)."""
    if abs(E) < 0.5:
        E2, term, rest = E * E, E, 0.0
        for k in range(3, 26, 2):                # E^3/3! - E^5/5! + ...: 1e-19 at k = 25
            term *= -E2 / ((k - 1) * k) if k > 3 else E2 / 6.0
            rest += term
        return (1.0 - e) * E + e * rest
    return E - e * libm.sin(E)


@kernel
def solve_kepler(M, e):
    """Eccentric anomaly E with E - e sin E = M, for 0 <= e < 1; to full double precision.

    Newton's method from the start E = M + 0.85 e sign(sin M) (Danby 1988), which converges for
    every M and e < 1; M is reduced to [-pi, pi] first.
    """
    if not -math.pi <= M <= math.pi:        # (M + pi) - pi would cost a small M its digits
        # (% on floats, in Python and in numba, is numpy's remainder: fmod, then moved
        # into [0, 2 pi))
        M = (M + math.pi) % (2 * math.pi) - math.pi
    E = M + 0.85 * e * sign(libm.sin(M))
    for _ in range(50):
        f = mean_anomaly(E, e) - M
        step = f / (1.0 - e * libm.cos(E))
        E -= step
        if abs(step) <= 4e-16 * max(1.0, abs(E)):
            break
    return E


@kernel
def elliptic_anomaly(M, e):
    """The true anomaly f from the mean anomaly M, for 0 <= e < 1."""
    E = solve_kepler(M, e)
    return 2.0 * libm.atan2(math.sqrt(1 + e) * libm.sin(E / 2), math.sqrt(1 - e) * libm.cos(E / 2))


@kernel
def state(mu, p, e, i, Omega, omega, f):
    """Position and velocity relative to the parent, (x, y, z, vx, vy, vz), of the conic of
    semi-latus rectum p at true anomaly f (orbits.elements_to_state checks the elements)."""
    cO, sO, co, so = libm.cos(Omega), libm.sin(Omega), libm.cos(omega), libm.sin(omega)
    ci, si = libm.cos(i), libm.sin(i)
    # P toward pericentre, Q 90 degrees ahead in the plane
    P0, P1, P2 = cO * co - sO * so * ci, sO * co + cO * so * ci, so * si
    Q0, Q1, Q2 = -cO * so - sO * co * ci, -sO * so + cO * co * ci, co * si
    cf, sf = libm.cos(f), libm.sin(f)
    r = p / (1.0 + e * cf)
    s = math.sqrt(mu / p)
    return (r * (cf * P0 + sf * Q0), r * (cf * P1 + sf * Q1), r * (cf * P2 + sf * Q2),
            s * (-sf * P0 + (e + cf) * Q0), s * (-sf * P1 + (e + cf) * Q1),
            s * (-sf * P2 + (e + cf) * Q2))


@kernel
def elliptic_states(mu, a, e, i, Omega, omega, M, pos, vel):
    """The states of k elliptic orbits (every argument (k,) but pos, vel (k, 3), written):
    orbits.elements_to_state of each row, bit for bit (the caller checks the elements)."""
    for j in range(mu.size):
        f = elliptic_anomaly(M[j], e[j])
        x, y, z, vx, vy, vz = state(mu[j], a[j] * (1.0 - e[j] * e[j]), e[j], i[j], Omega[j],
                                    omega[j], f)
        pos[j, 0], pos[j, 1], pos[j, 2] = x, y, z
        vel[j, 0], vel[j, 1], vel[j, 2] = vx, vy, vz


py = libm.twins(globals(), ["sign", "mean_anomaly", "solve_kepler", "elliptic_anomaly",
                            "state"], libm=libm.py)
