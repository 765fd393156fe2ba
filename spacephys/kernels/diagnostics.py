"""Energy sums for the diagnostics; compensated (Neumaier) so they resolve errors near 1e-16.

Compiled without fastmath: reassociation would optimise the compensation away.
"""
import numpy as np

from .._jit import kernel
from .codes import CENTRAL, DIRECT, UNIFORM


@kernel
def _add(s, c, x):
    """Neumaier's compensated addition: returns the new sum and compensation."""
    t = s + x
    if abs(s) >= abs(x):
        c += (s - t) + x
    else:
        c += (x - t) + s
    return t, c


@kernel
def kinetic_energy(vel, mass):
    """sum 1/2 m |v|^2 over (n, 3) vel and (n,) mass [mass length^2 / time^2]."""
    s = 0.0
    c = 0.0
    for i in range(mass.size):
        v2 = vel[i, 0] * vel[i, 0] + vel[i, 1] * vel[i, 1] + vel[i, 2] * vel[i, 2]
        s, c = _add(s, c, 0.5 * mass[i] * v2)
    return s + c


@kernel
def _pair_potential(xi, yi, zi, mi, xj, yj, zj, mj, eps2):
    dx = xj - xi
    dy = yj - yi
    dz = zj - zi
    r2 = dx * dx + dy * dy + dz * dz + eps2
    # coincident points exert no force (gravity.py), so they hold no pair energy either
    return -mi * mj / np.sqrt(r2) if r2 > 0.0 else 0.0


@kernel
def potential_energy(f, pos, mass, passive):
    """Potential energy of the state pos (n, 3) under the gravity model of the Forces table f,
    with the masses mass (n,) (f.mass, or those of the pulling bodies only).

    DIRECT: -G m_i m_j / sqrt(r^2 + eps2) over pairs of sources (f.src), and over (passive,
    source) pairs for the rows `passive`: a passive body sits in the sources' field. CENTRAL:
    each body in the fixed body's field. UNIFORM: -m g.x. NONE: 0. The immovable bodies'
    potential counts.
    """
    model, src, G, eps2 = f.model, f.src, f.G, f.eps2
    field, field_mass = f.field, f.field_mass
    s = 0.0
    c = 0.0
    if model == DIRECT:
        for a in range(src.size):
            i = src[a]
            for b in range(a + 1, src.size):
                j = src[b]
                s, c = _add(s, c, _pair_potential(pos[i, 0], pos[i, 1], pos[i, 2], mass[i],
                                                  pos[j, 0], pos[j, 1], pos[j, 2], mass[j], eps2))
        for a in range(passive.size):
            i = passive[a]
            if mass[i] == 0.0:
                continue
            for b in range(src.size):
                j = src[b]
                s, c = _add(s, c, _pair_potential(pos[i, 0], pos[i, 1], pos[i, 2], mass[i],
                                                  pos[j, 0], pos[j, 1], pos[j, 2], mass[j], eps2))
        return G * (s + c)
    if model == CENTRAL:
        for i in range(mass.size):
            s, c = _add(s, c, _pair_potential(pos[i, 0], pos[i, 1], pos[i, 2], mass[i],
                                              field[0], field[1], field[2], field_mass, eps2))
        return G * (s + c)
    if model == UNIFORM:
        for i in range(mass.size):
            g_dot_x = field[0] * pos[i, 0] + field[1] * pos[i, 1] + field[2] * pos[i, 2]
            s, c = _add(s, c, -mass[i] * g_dot_x)
        return s + c
    return 0.0


@kernel
def body_energies(f, pos, vel, mass, out):
    """Each body's share of the energy into out (n,): 1/2 m |v|^2 plus, under DIRECT, half
    of each pair potential among the sources src (other bodies get their kinetic energy
    only: give them mass 0 to leave them out); under CENTRAL and UNIFORM, its potential in
    the field. Sums to the total energy, to rounding: used to name the bodies whose energy
    changed when the total went wrong. f : the Forces table (its model and sources)."""
    model, src, G, eps2 = f.model, f.src, f.G, f.eps2
    field, field_mass = f.field, f.field_mass
    for i in range(mass.size):
        v2 = vel[i, 0] * vel[i, 0] + vel[i, 1] * vel[i, 1] + vel[i, 2] * vel[i, 2]
        out[i] = 0.5 * mass[i] * v2
        if model == CENTRAL:
            out[i] += G * _pair_potential(pos[i, 0], pos[i, 1], pos[i, 2], mass[i],
                                          field[0], field[1], field[2], field_mass, eps2)
        elif model == UNIFORM:
            out[i] -= mass[i] * (field[0] * pos[i, 0] + field[1] * pos[i, 1]
                                 + field[2] * pos[i, 2])
    if model == DIRECT:
        for a in range(src.size):
            i = src[a]
            for b in range(a + 1, src.size):
                j = src[b]
                half = 0.5 * G * _pair_potential(pos[i, 0], pos[i, 1], pos[i, 2], mass[i],
                                                 pos[j, 0], pos[j, 1], pos[j, 2], mass[j], eps2)
                out[i] += half
                out[j] += half
