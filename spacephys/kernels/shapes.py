"""Compound hitboxes in the collision pass: circles (spheres in 3D) fixed in a body's frame,
turning with its orientation (spacephys.Circles; the World's `shape` column names each body's
shape in the library, -1 for a round body, which is one circle of its radius at its centre).

Over a step a body's orientation goes from q0, held at fraction ts of the step (its start, or
its last contact), to its end orientation `quat` (the actors' turn); in between it is their
normalised linear interpolation. For the time of impact each circle moves on the chord from
where it is at the pair's t_lo to where it is at the step's end: a straight line, as the
centres move (kernels/impact.py), off the true arc by at most |offset| (angle turned)^2 / 8.
A contact is between the two circles closest to touching; its impulse turns the bodies by
their moments of inertia (a ship's, or mass x the shape's gyration for a rotor; none for a
fixed body, an arcade ship, which turns as commanded, or a round body).
"""
import math
from collections import namedtuple

import numpy as np

from .._jit import kernel
from .impact import meet, wall_hit
from .rotations import normalised, qexp, qmul, rotate
from .rules import wrap

Shapes = namedtuple("Shapes", (
    "shape",      # (n,) int64: each body's shape in the library, -1 round
    "rows",       # (S, 2) int64: the first circle and the count of each shape
    "circles",    # (C, 4) float64: offset x, y, z in the body's frame, radius
    "gyration",   # (S,) float64: k^2, a rotor's moment of inertia per unit mass [length^2]
    "quat",       # (n, 4): orientations at the step's end (the actors' column, shared)
    "omega",      # (n, 3): body-frame angular velocities (the actors' column, shared)
    "inertia",    # (n,): the actors' moments of inertia (inf: a rotor, 0: arcade turning)
    "q0",         # (n, 4): orientations at ts (scratch)
    "ts",         # (n,): where each body's orientation line starts in the step (scratch)
    "picked",     # (4,) int64: rows i, j and circles ki, kj of the last contact (scratch)
    "arms",       # (2, 3): the last contact's lever arms, point - centre of i and j (scratch)
))


def make(shape, rows, circles, gyration, quat, omega, inertia):
    """The pass's Shapes for n bodies (arrays shared, scratch new)."""
    n = shape.size
    return Shapes(shape, rows, circles, gyration, quat, omega, inertia, np.zeros((n, 4)),
                  np.zeros(n), np.full(4, -1, np.int64), np.zeros((2, 3)))


@kernel
def keep_start(shapes):
    """Each compound body's orientation at the step's start (before the actors turn)."""
    if shapes is None:
        return
    for i in range(shapes.shape.size):
        if shapes.shape[i] >= 0:
            for c in range(4):
                shapes.q0[i, c] = shapes.quat[i, c]
            shapes.ts[i] = 0.0


@kernel
def orientation(shapes, i, t):
    """Body i's orientation at fraction t of the step (see the module)."""
    a0, a1, a2, a3 = shapes.q0[i, 0], shapes.q0[i, 1], shapes.q0[i, 2], shapes.q0[i, 3]
    b0, b1, b2, b3 = shapes.quat[i, 0], shapes.quat[i, 1], shapes.quat[i, 2], shapes.quat[i, 3]
    if a0 * b0 + a1 * b1 + a2 * b2 + a3 * b3 < 0.0:
        b0, b1, b2, b3 = -b0, -b1, -b2, -b3
    ts = shapes.ts[i]
    f = 1.0 if ts >= 1.0 else min(max((t - ts) / (1.0 - ts), 0.0), 1.0)
    g = 1.0 - f
    return normalised(g * a0 + f * b0, g * a1 + f * b1, g * a2 + f * b2, g * a3 + f * b3)


@kernel
def circles_of(shapes, i):
    """(first row in the library, count) of body i's circles; (-1, 1) for a round body."""
    s = shapes.shape[i]
    if s < 0:
        return -1, 1
    return shapes.rows[s, 0], shapes.rows[s, 1]


@kernel
def circle(shapes, radius, i, first, k, q):
    """Circle k of body i turned by orientation q: (offset x, y, z in the world frame,
    radius)."""
    if first < 0:
        return 0.0, 0.0, 0.0, radius[i]
    row = first + k
    c = shapes.circles
    x, y, z = rotate(q[0], q[1], q[2], q[3], c[row, 0], c[row, 1], c[row, 2])
    return x, y, z, c[row, 3]


@kernel
def _orient(shapes, i, t):
    """Body i's orientation at t as a 4-tuple (identity for a round body)."""
    if shapes.shape[i] < 0:
        return 1.0, 0.0, 0.0, 0.0
    return orientation(shapes, i, t)


@kernel
def pair_time(shapes, A, B, i, j, radius, t_lo, L, overlap_counts):
    """impact.pair_time for bodies with compound shapes: the earliest t in [t_lo, 1] at
    which a circle of i touches a circle of j, each on its chord (see the module); -1 if
    none does."""
    fi, ni = circles_of(shapes, i)
    fj, nj = circles_of(shapes, j)
    qi0 = _orient(shapes, i, t_lo)
    qi1 = _orient(shapes, i, 1.0)
    qj0 = _orient(shapes, j, t_lo)
    qj1 = _orient(shapes, j, 1.0)
    span = 1.0 - t_lo
    P = np.empty(3)
    E = np.empty(3)
    for c in range(3):
        E[c] = B[j, c] - B[i, c]
        P[c] = wrap(A[j, c] - A[i, c], L[c]) + E[c] * t_lo
    best = -1.0
    for a in range(ni):
        x0, y0, z0, ra = circle(shapes, radius, i, fi, a, qi0)
        x1, y1, z1, _ = circle(shapes, radius, i, fi, a, qi1)
        for b in range(nj):
            u0, v0, w0, rb = circle(shapes, radius, j, fj, b, qj0)
            u1, v1, w1, _ = circle(shapes, radius, j, fj, b, qj1)
            e0, e1, e2 = E[0], E[1], E[2]
            if span > 0.0:
                e0 += ((u1 - u0) - (x1 - x0)) / span
                e1 += ((v1 - v0) - (y1 - y0)) / span
                e2 += ((w1 - w0) - (z1 - z0)) / span
            t = meet(P[0] + u0 - x0, P[1] + v0 - y0, P[2] + w0 - z0, e0, e1, e2, ra + rb,
                     t_lo, overlap_counts)
            if t >= 0.0 and (best < 0.0 or t < best):
                best = t
    return best


@kernel
def wall_time(shapes, A, B, i, radius, wall, t_lo):
    """impact.wall_time for a compound body: (t, normal x, y, z, the circle) of its first
    circle to touch the wall row, t = -1 if none does."""
    first, count = circles_of(shapes, i)
    q0 = orientation(shapes, i, t_lo)
    q1 = orientation(shapes, i, 1.0)
    span = 1.0 - t_lo
    best = (-1.0, 0.0, 0.0, 0.0)
    which = -1
    for k in range(count):
        x0, y0, z0, r = circle(shapes, radius, i, first, k, q0)
        x1, y1, z1, _ = circle(shapes, radius, i, first, k, q1)
        b0, b1, b2 = B[i, 0], B[i, 1], B[i, 2]
        if span > 0.0:
            b0 += (x1 - x0) / span
            b1 += (y1 - y0) / span
            b2 += (z1 - z0) / span
        # the circle's line a + b t through its place at t_lo
        a0 = A[i, 0] + B[i, 0] * t_lo + x0 - b0 * t_lo
        a1 = A[i, 1] + B[i, 1] * t_lo + y0 - b1 * t_lo
        a2 = A[i, 2] + B[i, 2] * t_lo + z0 - b2 * t_lo
        hit = wall_hit(a0, a1, a2, b0, b1, b2, r, wall, t_lo)
        if hit[0] >= 0.0 and (best[0] < 0.0 or hit[0] < best[0]):
            best = hit
            which = k
    return best[0], best[1], best[2], best[3], which


@kernel
def centres(shapes, radius, i, t, p, out):
    """The world centres (k, 3) and radii (k,) of body i's circles at t, its centre at p."""
    first, count = circles_of(shapes, i)
    q = _orient(shapes, i, t)
    for k in range(count):
        x, y, z, r = circle(shapes, radius, i, first, k, q)
        out[k, 0] = p[0] + x
        out[k, 1] = p[1] + y
        out[k, 2] = p[2] + z
        out[k, 3] = r
    return count


@kernel
def _world_spin(shapes, i, t):
    """Body i's angular velocity in the world frame at t [rad/time] (0 for a round body)."""
    if shapes.shape[i] < 0:
        return 0.0, 0.0, 0.0
    q = orientation(shapes, i, t)
    return rotate(q[0], q[1], q[2], q[3], shapes.omega[i, 0], shapes.omega[i, 1],
                  shapes.omega[i, 2])


@kernel
def contact(shapes, i, j, t, pi, pj, ui, uj, radius, n, point):
    """The contact of compound bodies i, j (centres pi, pj, velocities ui, uj at t): the two
    circles closest to touching. Writes the unit normal n (i -> j), the point on i's circle,
    the lever arms point - centre (shapes.arms) and picks (rows, circles) for the events.
    Returns (the circles' centre distance, the closing speed of the points, < 0 approaching)."""
    ci = np.empty((circles_of(shapes, i)[1], 4))
    cj = np.empty((circles_of(shapes, j)[1], 4))
    centres(shapes, radius, i, t, pi, ci)
    centres(shapes, radius, j, t, pj, cj)
    best = np.inf
    ka = 0
    kb = 0
    for a in range(ci.shape[0]):
        for b in range(cj.shape[0]):
            d2 = 0.0
            for c in range(3):
                d2 += (cj[b, c] - ci[a, c]) ** 2
            gap = math.sqrt(d2) - ci[a, 3] - cj[b, 3]
            if gap < best:
                best = gap
                ka = a
                kb = b
    arms = shapes.arms
    dist = 0.0
    for c in range(3):
        n[c] = cj[kb, c] - ci[ka, c]
        dist += n[c] * n[c]
    dist = math.sqrt(dist)
    for c in range(3):
        if dist > 0.0:
            n[c] /= dist
        point[c] = ci[ka, c] + n[c] * ci[ka, 3]
        arms[0, c] = point[c] - pi[c]
        arms[1, c] = point[c] - pj[c]
    wi = _world_spin(shapes, i, t)
    wj = _world_spin(shapes, j, t)
    closing = 0.0
    for c in range(3):
        c1 = (c + 1) % 3
        c2 = (c + 2) % 3
        vi = ui[c] + wi[c1] * arms[0, c2] - wi[c2] * arms[0, c1]
        vj = uj[c] + wj[c1] * arms[1, c2] - wj[c2] * arms[1, c1]
        closing += (vj - vi) * n[c]
    shapes.picked[0] = i
    shapes.picked[1] = j
    shapes.picked[2] = ka if shapes.shape[i] >= 0 else -1
    shapes.picked[3] = kb if shapes.shape[j] >= 0 else -1
    return dist, closing


@kernel
def inverse_inertia(shapes, mass, fixed, i):
    """1 / body i's moment of inertia for contacts (see the module); 0: contacts do not
    turn it."""
    s = shapes.shape[i]
    if fixed[i] or s < 0:
        return 0.0
    inertia = shapes.inertia[i]
    if inertia == np.inf:                      # a rotor: its mass spread over its circles
        inertia = mass[i] * shapes.gyration[s]
    return 1.0 / inertia if inertia > 0.0 else 0.0


@kernel
def _turn(shapes, i, t, dt, sign, J, kinv, arm, n):
    """Turn body i by the angular impulse sign J (arm x n) at t: its body-frame angular
    velocity, and its orientation line from t (q0, ts) to a new end orientation."""
    if kinv == 0.0:
        return
    q = orientation(shapes, i, t)
    f = sign * J * kinv
    wx = f * (arm[1] * n[2] - arm[2] * n[1])
    wy = f * (arm[2] * n[0] - arm[0] * n[2])
    wz = f * (arm[0] * n[1] - arm[1] * n[0])
    bx, by, bz = rotate(q[0], -q[1], -q[2], -q[3], wx, wy, wz)     # into the body's frame
    shapes.omega[i, 0] += bx
    shapes.omega[i, 1] += by
    shapes.omega[i, 2] += bz
    e = qexp(shapes.omega[i, 0], shapes.omega[i, 1], shapes.omega[i, 2], (1.0 - t) * dt)
    r0, r1, r2, r3 = qmul(q[0], q[1], q[2], q[3], e[0], e[1], e[2], e[3])
    end = normalised(r0, r1, r2, r3)
    for c in range(4):
        shapes.q0[i, c] = q[c]
        shapes.quat[i, c] = end[c]
    shapes.ts[i] = t


@kernel
def _inverse_mass(m, fixed, light):
    """A body's share weight: 0 fixed; with a massless body in the pair (light) 1 for the
    massless ones and 0 for the rest; else 1 / m."""
    if fixed:
        return 0.0
    if light:
        return 1.0 if m == 0.0 else 0.0
    return 1.0 / m


@kernel
def bounce(shapes, i, j, t, e, n, closing, mass, fixed, A, B, D, tb, pi, pj, dt):
    """A bounce of compound bodies with restitution e at t: the impulse along n that turns
    the points' closing speed into -e times it, shared by the masses and the moments of
    inertia. Returns the kinetic energy lost."""
    light = (mass[i] == 0.0 and not fixed[i]) or (mass[j] == 0.0 and not fixed[j])
    wi = _inverse_mass(mass[i], fixed[i], light)
    wj = _inverse_mass(mass[j], fixed[j], light)
    ki = 0.0 if light else inverse_inertia(shapes, mass, fixed, i)
    kj = 0.0 if light else inverse_inertia(shapes, mass, fixed, j)
    ai = shapes.arms[0]
    aj = shapes.arms[1]
    ci2 = 0.0
    cj2 = 0.0
    for c in range(3):
        c1 = (c + 1) % 3
        c2 = (c + 2) % 3
        ci2 += (ai[c1] * n[c2] - ai[c2] * n[c1]) ** 2
        cj2 += (aj[c1] * n[c2] - aj[c2] * n[c1]) ** 2
    denom = wi + wj + ki * ci2 + kj * cj2
    if denom == 0.0:
        return 0.0
    J = -(1.0 + e) * closing / denom
    for c in range(3):
        di = -J * wi * n[c]
        dj = J * wj * n[c]
        D[i, c] += di
        D[j, c] += dj
        B[i, c] += di * dt
        B[j, c] += dj * dt
        A[i, c] = pi[c] - B[i, c] * t
        A[j, c] = pj[c] - B[j, c] * t
    tb[i] = t
    tb[j] = t
    _turn(shapes, i, t, dt, -1.0, J, ki, ai, n)
    _turn(shapes, j, t, dt, 1.0, J, kj, aj, n)
    return 0.5 * (1.0 - e * e) * closing * closing / denom


@kernel
def bounce_wall(shapes, i, k, t, e, n, A, B, D, V0, V1, radius, mass, fixed, dt, point):
    """Compound body i's circle k reflected off a wall (normal n toward the body) with
    restitution e at t, turning it. Returns (the normal speed of the point, < 0 into the
    wall; the energy lost); nothing changes when the point leaves the wall."""
    p = np.empty(3)
    u = np.empty(3)
    for c in range(3):
        p[c] = A[i, c] + B[i, c] * t
        u[c] = V0[i, c] + t * (V1[i, c] - V0[i, c]) + D[i, c]
    first, _ = circles_of(shapes, i)
    q = orientation(shapes, i, t)
    x, y, z, r = circle(shapes, radius, i, first, k, q)
    arm = np.array([x - r * n[0], y - r * n[1], z - r * n[2]])
    w = _world_spin(shapes, i, t)
    un = 0.0
    for c in range(3):
        c1 = (c + 1) % 3
        c2 = (c + 2) % 3
        un += (u[c] + w[c1] * arm[c2] - w[c2] * arm[c1]) * n[c]
        point[c] = p[c] + arm[c]
    if un >= 0.0 or fixed[i]:
        return un, 0.0
    wi = 1.0 if mass[i] == 0.0 else 1.0 / mass[i]
    kinv = 0.0 if mass[i] == 0.0 else inverse_inertia(shapes, mass, fixed, i)
    cross2 = 0.0
    for c in range(3):
        c1 = (c + 1) % 3
        c2 = (c + 2) % 3
        cross2 += (arm[c1] * n[c2] - arm[c2] * n[c1]) ** 2
    denom = wi + kinv * cross2
    J = -(1.0 + e) * un / denom
    for c in range(3):
        d = J * wi * n[c]
        D[i, c] += d
        B[i, c] += d * dt
        A[i, c] = p[c] - B[i, c] * t
    _turn(shapes, i, t, dt, 1.0, J, kinv, arm, n)
    shapes.picked[0] = i
    shapes.picked[1] = -1
    shapes.picked[2] = k
    shapes.picked[3] = -1
    return un, 0.5 * (1.0 - e * e) * un * un / denom


@kernel
def gap(shapes, A, B, i, j, t, L, radius):
    """The smallest gap between a circle of i and one of j at t (the lines extended past
    the step's end, the orientations held there) [length]; < 0 overlapping."""
    pi = np.empty(3)
    pj = np.empty(3)
    for c in range(3):
        pi[c] = A[i, c] + B[i, c] * t
        pj[c] = pi[c] + wrap(A[j, c] + B[j, c] * t - pi[c], L[c])
    ci = np.empty((circles_of(shapes, i)[1], 4))
    cj = np.empty((circles_of(shapes, j)[1], 4))
    centres(shapes, radius, i, min(t, 1.0), pi, ci)
    centres(shapes, radius, j, min(t, 1.0), pj, cj)
    best = np.inf
    for a in range(ci.shape[0]):
        for b in range(cj.shape[0]):
            d2 = 0.0
            for c in range(3):
                d2 += (cj[b, c] - ci[a, c]) ** 2
            best = min(best, math.sqrt(d2) - ci[a, 3] - cj[b, 3])
    return best


@kernel
def exit_time(shapes, A, B, tb, i, j, slop, t_in, L, radius):
    """impact.exit_time for compound bodies: the last t in [t_lo, 1] at which i and j are
    within slop of touching (bisection on the gap: 50 halvings)."""
    lo = max(tb[i], tb[j], t_in)
    if gap(shapes, A, B, i, j, lo, L, radius) > slop:
        return lo
    hi = 1.0
    if gap(shapes, A, B, i, j, hi, L, radius) <= slop:
        return hi
    for _ in range(50):
        mid = 0.5 * (lo + hi)
        if gap(shapes, A, B, i, j, mid, L, radius) <= slop:
            lo = mid
        else:
            hi = mid
    return lo


@kernel
def name(shapes, state, first):
    """Name the circles of the last contact (picked) in the events recorded since `first`:
    circle_a, circle_b by the ids a and b."""
    if shapes is None:
        return
    i, j = shapes.picked[0], shapes.picked[1]
    if i < 0:
        return
    ids = state.ids
    for e in range(first, state.count[0]):
        ev = state.events[e]
        if ev.a == ids[i]:
            ev.circle_a = shapes.picked[2]
        elif j >= 0 and ev.a == ids[j]:
            ev.circle_a = shapes.picked[3]
        if ev.b == ids[i] and j >= 0:
            ev.circle_b = shapes.picked[2]
        elif j >= 0 and ev.b == ids[j]:
            ev.circle_b = shapes.picked[3]
    shapes.picked[0] = -1
