"""Ready-made user forces for World.add_force, and the pattern to write your own.

A user force is a numba function fn(t, pos, vel, mass, ids, params, out) that adds every
body's acceleration [length/time^2] into out (n, 3): t the time of the force evaluation, pos
and vel (n, 3) the bodies' positions and velocities at that stage, mass (n,), ids (n,) int64
body ids (find a body's row by its id: rows move when bodies are removed), params (p,) the
float64 array given to add_force. It runs inside the step kernels, at every force evaluation
of every integrator: no Python per step. Define it at the top level of a module (save, load
and replay find it by module and name) and decorate it with @numba.njit(cache=True) so it is
compiled once per machine.

    w.add_force(spacephys.userforces.j2, [planet_id, J2 * G * M * R**2])
"""
import math

import numba

from .cache import ENABLED as CACHING     # False only where no folder can be written


@numba.njit(cache=CACHING)
def row_of(ids, target):
    """The row of body id `target` among ids (n,), -1 when it is not alive: a user force
    finds its bodies by id (rows move when bodies are removed)."""
    for i in range(ids.size):
        if ids[i] == target:
            return i
    return -1


@numba.njit(cache=CACHING)
def j2(t, pos, vel, mass, ids, params, out):
    """Oblateness of a planet spinning about z: the J2 term of its gravity field.

    params = [planet id, J2 mu R^2] (mu = G M of the planet, R its equatorial radius). For
    a body at d = (x, y, z) from the planet, r = |d|:
        a = -3/2 J2 mu R^2 / r^5 (x (1 - 5 z^2/r^2), y (1 - 5 z^2/r^2), z (3 - 5 z^2/r^2))
    (Montenbruck & Gill, Satellite Orbits, 2000, eq. 3.17 ff.); the planet takes the
    reaction -m a / M of every body with mass, so momentum is conserved. Does nothing if the
    planet is not alive.
    """
    planet = row_of(ids, int(params[0]))
    if planet < 0:
        return
    k = params[1]
    m_planet = mass[planet]
    for i in range(pos.shape[0]):
        if i == planet:
            continue
        x = pos[i, 0] - pos[planet, 0]
        y = pos[i, 1] - pos[planet, 1]
        z = pos[i, 2] - pos[planet, 2]
        r2 = x * x + y * y + z * z
        if r2 == 0.0:
            continue
        s = 5.0 * z * z / r2
        c = -1.5 * k / (r2 * r2 * r2 ** 0.5)
        ax = c * x * (1.0 - s)
        ay = c * y * (1.0 - s)
        az = c * z * (3.0 - s)
        out[i, 0] += ax
        out[i, 1] += ay
        out[i, 2] += az
        if m_planet > 0.0 and mass[i] > 0.0:
            w = mass[i] / m_planet
            out[planet, 0] -= w * ax
            out[planet, 1] -= w * ay
            out[planet, 2] -= w * az


@numba.njit(cache=CACHING)
def gr(t, pos, vel, mass, ids, params, out):
    """General relativity's first post-Newtonian correction to a dominant body's pull (the
    Schwarzschild field of the Sun, as JPL's ephemerides and REBOUNDx's `gr` effect take it
    for the planets).

    params = [sun id, mu = G M of the Sun, c, the speed of light]. For a body at r, moving at
    v, both relative to the Sun (r = |r|):
        a = mu / (c^2 r^3) ((4 mu / r - v.v) r + 4 (r.v) v)
    (Anderson, Esposito, Martin, Thornton & Muhleman 1975, ApJ 200, 221; Newhall, Standish
    & Williams 1983, A&A 125, 150, in the one-body limit); the Sun takes the reaction
    -m a / M of every body with mass. It turns Mercury's perihelion by 43" a century.
    """
    sun = row_of(ids, int(params[0]))
    if sun < 0:
        return
    mu = params[1]
    c2 = params[2] * params[2]
    m_sun = mass[sun]
    for i in range(pos.shape[0]):
        if i == sun:
            continue
        x = pos[i, 0] - pos[sun, 0]
        y = pos[i, 1] - pos[sun, 1]
        z = pos[i, 2] - pos[sun, 2]
        u = vel[i, 0] - vel[sun, 0]
        v = vel[i, 1] - vel[sun, 1]
        w = vel[i, 2] - vel[sun, 2]
        r2 = x * x + y * y + z * z
        if r2 == 0.0:
            continue
        r = math.sqrt(r2)
        f = mu / (c2 * r2 * r)
        radial = 4.0 * mu / r - (u * u + v * v + w * w)
        along = 4.0 * (x * u + y * v + z * w)
        ax = f * (radial * x + along * u)
        ay = f * (radial * y + along * v)
        az = f * (radial * z + along * w)
        out[i, 0] += ax
        out[i, 1] += ay
        out[i, 2] += az
        if m_sun > 0.0 and mass[i] > 0.0:
            k = mass[i] / m_sun
            out[sun, 0] -= k * ax
            out[sun, 1] -= k * ay
            out[sun, 2] -= k * az
