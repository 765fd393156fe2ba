"""Time of impact: when, within a step, two bodies' swept spheres (or a body and a wall) first
touch, and when a pair in touch parts. Over a step each body moves on the straight line from
its start to its end position, p(t) = A + B t, t in [0, 1] of the step; the earliest t with
|dA + dB t| = r1 + r2 comes from squared distances (one square root per real contact, none
per rejected pair). Compiled without fastmath: the roots need exact rounding.
"""
import math

from .._jit import kernel
from .codes import PLANE
from .rules import wrap


@kernel(lean=True)
def pair_time(A, B, i, j, R, t_lo, L, overlap_counts):
    """Earliest t in [t_lo, 1] at which bodies i and j, on p = A + B t, are R apart; -1 if
    they do not touch, or touch only while separating. With overlap_counts (merges, destroys)
    bodies already overlapping at t_lo meet at t_lo whichever way they move. Squared
    distances until a root is certain."""
    d0 = wrap(A[j, 0] - A[i, 0], L[0])
    d1 = wrap(A[j, 1] - A[i, 1], L[1])
    d2 = wrap(A[j, 2] - A[i, 2], L[2])
    e0 = B[j, 0] - B[i, 0]
    e1 = B[j, 1] - B[i, 1]
    e2 = B[j, 2] - B[i, 2]
    return meet(d0 + e0 * t_lo, d1 + e1 * t_lo, d2 + e2 * t_lo, e0, e1, e2, R, t_lo,
                overlap_counts)


@kernel(lean=True)
def meet(p0, p1, p2, e0, e1, e2, R, t_lo, overlap_counts):
    """pair_time from the relative position p at t_lo and the relative motion e per step:
    the quadratic |p + e s|^2 = R^2 in s = t - t_lo."""
    a = e0 * e0 + e1 * e1 + e2 * e2
    b = p0 * e0 + p1 * e1 + p2 * e2
    c = p0 * p0 + p1 * p1 + p2 * p2 - R * R
    if c <= 0.0 and (b < 0.0 or overlap_counts):
        return t_lo                       # overlapping (and approaching): contact now
    if b >= 0.0:
        return -1.0                       # not approaching: no contact ahead
    disc = b * b - a * c
    if disc < 0.0:
        return -1.0
    s = c / (-b + math.sqrt(disc))        # the smaller root, without cancellation
    if t_lo + s > 1.0:
        return -1.0
    return t_lo + s


@kernel(lean=True)
def wall_time(A, B, i, r, wall, t_lo):
    """Earliest t in [t_lo, 1] at which body i (radius r) touches the wall row; -1 if never.
    Returns (t, nx, ny, nz) with n the wall's normal toward the body at contact."""
    return wall_hit(A[i, 0], A[i, 1], A[i, 2], B[i, 0], B[i, 1], B[i, 2], r, wall, t_lo)


@kernel(lean=True)
def wall_hit(a0, a1, a2, b0, b1, b2, r, wall, t_lo):
    """wall_time for a circle of radius r on the line a + b t."""
    if wall[0] == PLANE:
        q0, q1, q2 = wall[1], wall[2], wall[3]
        n0, n1, n2 = wall[4], wall[5], wall[6]
        s0 = (a0 + b0 * t_lo - q0) * n0 + (a1 + b1 * t_lo - q1) * n1 \
            + (a2 + b2 * t_lo - q2) * n2 - r
        rate = b0 * n0 + b1 * n1 + b2 * n2
        if rate >= 0.0:
            return -1.0, n0, n1, n2
        if s0 <= 0.0:
            return t_lo, n0, n1, n2
        t = t_lo - s0 / rate
        return (t if t <= 1.0 else -1.0), n0, n1, n2
    # segment: the earliest touch of the capsule of radius r around it, from its side faces
    # (a moving point against a cylinder: a quadratic) or its two end caps (point vs sphere)
    best = -1.0
    bn0 = 0.0
    bn1 = 0.0
    bn2 = 0.0
    u0, u1, u2 = wall[4] - wall[1], wall[5] - wall[2], wall[6] - wall[3]
    uu = u0 * u0 + u1 * u1 + u2 * u2
    for end in range(3):
        if end < 2:
            # end caps: body centre vs a sphere of radius r at the end point
            o = 1 if end == 0 else 4
            d0 = a0 - wall[o]
            d1 = a1 - wall[o + 1]
            d2 = a2 - wall[o + 2]
            e0, e1, e2 = b0, b1, b2
        else:
            # side: the components perpendicular to the segment
            d0 = a0 - wall[1]
            d1 = a1 - wall[2]
            d2 = a2 - wall[3]
            e0, e1, e2 = b0, b1, b2
            k = (d0 * u0 + d1 * u1 + d2 * u2) / uu
            d0, d1, d2 = d0 - k * u0, d1 - k * u1, d2 - k * u2
            k = (e0 * u0 + e1 * u1 + e2 * u2) / uu
            e0, e1, e2 = e0 - k * u0, e1 - k * u1, e2 - k * u2
        p0 = d0 + e0 * t_lo
        p1 = d1 + e1 * t_lo
        p2 = d2 + e2 * t_lo
        a = e0 * e0 + e1 * e1 + e2 * e2
        b = p0 * e0 + p1 * e1 + p2 * e2
        c = p0 * p0 + p1 * p1 + p2 * p2 - r * r
        if b >= 0.0:
            continue
        if c <= 0.0:
            s = 0.0
        else:
            disc = b * b - a * c
            if disc < 0.0:
                continue
            s = c / (-b + math.sqrt(disc))
        t = t_lo + s
        if t > 1.0:
            continue
        # where along the segment is the contact? the side only counts between the ends
        x0 = a0 + b0 * t - wall[1]
        x1 = a1 + b1 * t - wall[2]
        x2 = a2 + b2 * t - wall[3]
        k = (x0 * u0 + x1 * u1 + x2 * u2) / uu
        if end == 2 and not (0.0 <= k <= 1.0):
            continue
        if best < 0.0 or t < best:
            k = min(max(k, 0.0), 1.0)
            m0, m1, m2 = x0 - k * u0, x1 - k * u1, x2 - k * u2
            norm = math.sqrt(m0 * m0 + m1 * m1 + m2 * m2)
            if norm > 0.0:
                best = t
                bn0, bn1, bn2 = m0 / norm, m1 / norm, m2 / norm
    return best, bn0, bn1, bn2


@kernel(lean=True)
def exit_time(A, B, tb, i, j, R, t_in, L):
    """When rows i and j, on their lines at the step's end, are last within R of each other:
    the later root of |d + e t| = R on [max(tb), 1], not before t_in (the pair's meeting)."""
    t_lo = max(tb[i], tb[j], t_in)
    d0 = wrap(A[j, 0] + B[j, 0] * t_lo - A[i, 0] - B[i, 0] * t_lo, L[0])
    d1 = wrap(A[j, 1] + B[j, 1] * t_lo - A[i, 1] - B[i, 1] * t_lo, L[1])
    d2 = wrap(A[j, 2] + B[j, 2] * t_lo - A[i, 2] - B[i, 2] * t_lo, L[2])
    e0 = B[j, 0] - B[i, 0]
    e1 = B[j, 1] - B[i, 1]
    e2 = B[j, 2] - B[i, 2]
    a = e0 * e0 + e1 * e1 + e2 * e2
    b = d0 * e0 + d1 * e1 + d2 * e2
    c = d0 * d0 + d1 * d1 + d2 * d2 - R * R
    disc = b * b - a * c
    if c > 0.0 or a == 0.0 or disc < 0.0:
        return t_lo                       # apart already (their lines changed), or resting
    root = math.sqrt(disc)
    s = -c / (b + root) if b > 0.0 else (root - b) / a     # the later root, cancellation-free
    return min(t_lo + s, 1.0)
