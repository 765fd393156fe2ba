"""What a contact does: the responses (bounce, elastic, merge, destroy, break, sensor) of a pair
and of a body at a wall, at the fraction t of the step where they touch: back up to contact,
respond, move on along the new line for the rest of the step. Responses work with mass
fractions m_j / (m_i + m_j) computed from the ratio of the masses, so very different masses
do not lose the light body's velocity to round-off. Compiled without fastmath: the exact
velocity swap of equal masses needs exact rounding.
"""
import math

import numpy as np
from numba import types

from .._jit import kernel
from . import libm
from .codes import (BODIES_GONE, BOUNCE, BREAK_A, DEFLECTED, DESTROY_A, DESTROY_B,
                    DESTROY_BOTH, ELASTIC, EV_BOUNCE, EV_DESTROY, EV_MERGE, EV_WALL, MERGE,
                    REFLECTING, SENSOR, UNTOUCHED)
from . import shapes as kshapes
from .rules import wrap
from .state import record


@kernel
def _fractions(m_i, m_j, fixed_i, fixed_j):
    """Shares of the exchanged normal velocity taken by i and j: m_j/(m_i+m_j), m_i/(m_i+m_j),
    from the mass ratio so that 1e-12 against 1e12 keeps both; immovable = infinite mass."""
    if fixed_i and fixed_j:
        return 0.0, 0.0
    if fixed_i:
        return 0.0, 1.0
    if fixed_j:
        return 1.0, 0.0
    if m_i == 0.0 and m_j == 0.0:
        return 0.5, 0.5
    if m_i >= m_j:
        q = m_j / m_i
        return q / (1.0 + q), 1.0 / (1.0 + q)
    q = m_i / m_j
    return 1.0 / (1.0 + q), q / (1.0 + q)


@kernel(lean=True)
def _velocity_at(V0, V1, D, k, t, out):
    """Body k's velocity at fraction t of the step: the integrator's, interpolated between the
    step's start and end, plus the impulses of this step's earlier contacts."""
    for c in range(3):
        out[c] = V0[k, c] + t * (V1[k, c] - V0[k, c]) + D[k, c]


@kernel(by_address=True, returns=types.int64)
def respond(i, j, t, resp, e, A, B, tb, V0, V1, D, mass, radius, alive, ids, rules, dt, t0,
             L, state, shapes):
    """Apply response resp to the contact of i and j at time t of the step. Returns
    UNTOUCHED when nothing changed a trajectory, DEFLECTED when velocities changed,
    BODIES_GONE when a body was removed or merged (the caller must refresh what depends on
    the set of bodies)."""
    pi = np.empty(3)
    pj = np.empty(3)
    n = np.empty(3)
    for c in range(3):
        pi[c] = A[i, c] + B[i, c] * t
        pj[c] = pi[c] + wrap(A[j, c] + B[j, c] * t - pi[c], L[c])
        n[c] = pj[c] - pi[c]
    dist = math.sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2])
    if dist > 0.0:
        for c in range(3):
            n[c] /= dist
    else:
        # centres coincide: push along the relative motion, else along x
        rel = np.empty(3)
        for c in range(3):
            rel[c] = B[j, c] - B[i, c]
        rn = math.sqrt(rel[0] * rel[0] + rel[1] * rel[1] + rel[2] * rel[2])
        for c in range(3):
            n[c] = -rel[c] / rn if rn > 0.0 else (1.0 if c == 0 else 0.0)
    point = np.empty(3)
    for c in range(3):
        point[c] = pi[c] + n[c] * radius[i]
    ui = np.empty(3)
    uj = np.empty(3)
    _velocity_at(V0, V1, D, i, t, ui)
    _velocity_at(V0, V1, D, j, t, uj)
    closing = 0.0
    for c in range(3):
        closing += (uj[c] - ui[c]) * n[c]             # < 0 when approaching
    if shapes is not None:
        if shapes.shape[i] >= 0 or shapes.shape[j] >= 0:
            dist, closing = kshapes.contact(shapes, i, j, t, pi, pj, ui, uj, radius, n, point)
    fixed_i = rules.fixed[i]
    fixed_j = rules.fixed[j]
    when = t0 + t * dt
    if resp == SENSOR:
        meet(rules, i, j, t)            # its begin and end are found at the step's end
        return UNTOUCHED
    if resp in REFLECTING:
        if closing >= 0.0:
            return UNTOUCHED
        fi, fj = _fractions(mass[i], mass[j], fixed_i, fixed_j)
        if resp == ELASTIC:
            e = 1.0
        lost = -1.0
        if shapes is not None:
            if shapes.shape[i] >= 0 or shapes.shape[j] >= 0:
                lost = kshapes.bounce(shapes, i, j, t, e, n, closing, mass, rules.fixed, A, B,
                                      D, tb, pi, pj, dt)
        if lost < 0.0:
            for c in range(3):
                if resp == ELASTIC and mass[i] == mass[j] and not fixed_i and not fixed_j:
                    # equal masses swap their normal velocities exactly (Laird & Jamin, Basic
                    # Game Physics: identical balls swap velocities): u_i - (u_i.n) n
                    # + (u_j.n) n, which is u_j itself head-on
                    ni = ui[0] * n[0] + ui[1] * n[1] + ui[2] * n[2]
                    nj = uj[0] * n[0] + uj[1] * n[1] + uj[2] * n[2]
                    di = (ui[c] - ni * n[c] + nj * n[c]) - ui[c]
                    dj = (uj[c] - nj * n[c] + ni * n[c]) - uj[c]
                else:
                    di = (1.0 + e) * fi * closing * n[c]
                    dj = -(1.0 + e) * fj * closing * n[c]
                D[i, c] += di
                D[j, c] += dj
                B[i, c] += di * dt
                B[j, c] += dj * dt
            for c in range(3):
                A[i, c] = pi[c] - B[i, c] * t
                A[j, c] = pj[c] - B[j, c] * t
            tb[i] = t
            tb[j] = t
            if fixed_i or fixed_j:
                reduced = mass[j] if fixed_i else mass[i]
            else:
                reduced = mass[i] * fj          # m_i m_j / (m_i + m_j)
            lost = 0.5 * (1.0 - e * e) * reduced * closing * closing
        record(state, EV_BOUNCE, ids[i], ids[j], when, t * dt, point, n, -closing, lost, dist)
        if resp == ELASTIC or resp == BOUNCE:
            meet(rules, i, j, t)        # a contact may begin
            return DEFLECTED
        # a break: the bounce happened (the other body keeps its rebound), then the broken
        # one is destroyed where it stood (the brick of Laird & Jamin, Basic Game Physics)
        k = i if resp == BREAK_A else j
        p = pi if k == i else pj
        for c in range(3):
            A[k, c] = p[c]
            B[k, c] = 0.0
        alive[k] = False
        mass[k] = 0.0
        tb[k] = t                        # when it went (its pairs in touch end then)
        record(state, EV_DESTROY, ids[k], ids[j if k == i else i], when, t * dt, point,
                n, -closing, 0.0, dist)
        return BODIES_GONE
    if resp == MERGE:
        # the heavier (or the immovable) one survives, with the pair's mass and momentum
        s, o = i, j
        if fixed_j and not fixed_i or (fixed_i == fixed_j and mass[j] > mass[i]):
            s, o = j, i
        M = mass[s] + mass[o]
        ws = mass[s] / M if M > 0.0 else 0.5
        wo = 1.0 - ws
        ps = pi if s == i else pj
        po = pj if s == i else pi
        rel2 = 0.0
        for c in range(3):
            rel2 += (uj[c] - ui[c]) ** 2
        if rules.fixed[s]:
            ws, wo = 1.0, 0.0
        for c in range(3):
            centre = ws * ps[c] + wo * po[c]
            # momentum-weighted: every part of the velocity (start, end, impulses) alike
            V0[s, c] = ws * V0[s, c] + wo * V0[o, c]
            V1[s, c] = ws * V1[s, c] + wo * V1[o, c]
            D[s, c] = ws * D[s, c] + wo * D[o, c]
            B[s, c] = ws * B[s, c] + wo * B[o, c]
            A[s, c] = centre - B[s, c] * t
            A[o, c] = po[c] - B[o, c] * t
        tb[s] = t
        if rules.dim == 3:
            radius[s] = libm.cbrt(radius[s] ** 3 + radius[o] ** 3)
        else:
            radius[s] = math.sqrt(radius[s] ** 2 + radius[o] ** 2)
        # the kinetic energy of the relative motion, m_s m_o / M |u_o - u_s|^2 / 2, is lost
        lost = 0.5 * (mass[s] * mass[o] / M if M > 0.0 else 0.0) * rel2
        mass[s] = M
        mass[o] = 0.0
        alive[o] = False
        tb[o] = t
        for c in range(3):
            B[o, c] = 0.0
            A[o, c] = po[c]
        record(state, EV_MERGE, ids[s], ids[o], when, t * dt, point, n, -closing, lost,
                dist)
        return BODIES_GONE
    # destroy one or both: frozen where they met, no mass, out of the game
    lost = 0.0
    for which in range(2):
        k = i if which == 0 else j
        other = j if which == 0 else i
        if (which == 0 and resp in (DESTROY_A, DESTROY_BOTH)) or \
                (which == 1 and resp in (DESTROY_B, DESTROY_BOTH)):
            p = pi if k == i else pj
            u = ui if k == i else uj
            lost = 0.5 * mass[k] * (u[0] * u[0] + u[1] * u[1] + u[2] * u[2])
            for c in range(3):
                A[k, c] = p[c]
                B[k, c] = 0.0
            alive[k] = False
            mass[k] = 0.0
            tb[k] = t
            record(state, EV_DESTROY, ids[k], ids[other], when, t * dt, point, n,
                    -closing, lost, dist)
    return BODIES_GONE


@kernel(by_address=True, returns=types.int64)
def respond_wall(i, t, n0, n1, n2, e, A, B, tb, V0, V1, D, mass, radius, ids, rules, dt, t0,
                  state, k, shapes):
    """Reflect body i off a wall (immovable) with restitution e: v -= (1 + e) (v . n) n
    (a compound body's circle k: its point, turning it)."""
    n = np.array([n0, n1, n2])
    if shapes is not None:
        if k >= 0:
            point = np.empty(3)
            un, lost = kshapes.bounce_wall(shapes, i, k, t, e, n, A, B, D, V0, V1, radius, mass,
                                           rules.fixed, dt, point)
            if un >= 0.0 or rules.fixed[i]:
                return UNTOUCHED
            tb[i] = t
            record(state, EV_WALL, ids[i], -1, t0 + t * dt, t * dt, point, -n, -un, lost,
                   radius[i])
            return DEFLECTED
    u = np.empty(3)
    _velocity_at(V0, V1, D, i, t, u)
    un = u[0] * n[0] + u[1] * n[1] + u[2] * n[2]
    if un >= 0.0 or rules.fixed[i]:
        return UNTOUCHED
    p = np.empty(3)
    for c in range(3):
        p[c] = A[i, c] + B[i, c] * t
        d = -(1.0 + e) * un * n[c]
        D[i, c] += d
        B[i, c] += d * dt
        A[i, c] = p[c] - B[i, c] * t
    tb[i] = t
    point = np.empty(3)
    normal = np.empty(3)
    for c in range(3):
        point[c] = p[c] - radius[i] * n[c]
        normal[c] = -n[c]
    # the wall does not move: a restitution e takes (1 - e^2) of the normal kinetic energy
    lost = 0.5 * (1.0 - e * e) * mass[i] * un * un
    record(state, EV_WALL, ids[i], -1, t0 + t * dt, t * dt, point, normal, -un, lost,
            radius[i])
    return DEFLECTED


@kernel(lean=True)
def survivor(merged_into, i):
    """The body i has merged into, following chains (with path halving)."""
    while merged_into[i] != i:
        merged_into[i] = merged_into[merged_into[i]]
        i = merged_into[i]
    return i


@kernel
def meet(rules, i, j, t):
    """Note that rows i and j met at fraction t of the step (a sensor overlap, a bounce)."""
    k = rules.nfound[0]
    if k >= rules.found_t.size:
        grown = np.empty((2 * k + 16, 2), np.int64)
        grown_t = np.empty(2 * k + 16)
        for q in range(k):
            grown[q, 0] = rules.found[q, 0]
            grown[q, 1] = rules.found[q, 1]
            grown_t[q] = rules.found_t[q]
        rules.found = grown
        rules.found_t = grown_t
    rules.found[k, 0] = min(i, j)
    rules.found[k, 1] = max(i, j)
    rules.found_t[k] = t
    rules.nfound[0] = k + 1


@kernel
def met(rules, i, j):
    """Whether rows i and j met already in this step."""
    a, b = min(i, j), max(i, j)
    for k in range(rules.nfound[0]):
        if rules.found[k, 0] == a and rules.found[k, 1] == b:
            return True
    return False
