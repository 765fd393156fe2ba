"""Patched conics: when a coasting body (spacephys/coasting.py) next changes its sphere of
influence or comes down to its parent's surface, found by time, not by steps.

A coasting body is a body on Kepler rails (kernels/rails.py) about its dominant body P. Over a
window of time its next event is the first zero of one of these distances, each positive
before the event:
  exit     R_P (1 + 2 eps) - |r|            it leaves P's sphere of influence (radius R_P)
  enter k  |r - r_k| - R_k (1 - 2 eps)      it enters the sphere of k, a body on rails about P
  surface  |r| - (radius_P + radius + near)  it comes down to P (it returns to integration)
with r its place about P and r_k k's, both from their conics. eps = 1e-9 keeps the two
thresholds apart: a body that just left a sphere is 3 eps R outside it, and does not enter it
again at once.

Each is found by conservative advancement: a distance f(t) moves no faster than the bodies'
greatest speeds about P (the speed at pericentre, sqrt(mu (1 + e) / (a |1 - e|))), so no zero
lies within f / v of t; stepping by f / v approaches the first zero from before it, and
stops within eps R of it. Before any stepping, a conic's radial range [q, Q] (pericentre,
apocentre) that cannot reach the threshold rules the event out for ever: most bodies cost
nothing. The search runs over windows of a length fixed per body, from where the last one
ended, so the times found do not depend on how a run is cut into calls.
"""
import math

from .._jit import kernel
from .rails import A, ECC, N_HI, relative

EPS = 1e-9
NO_EVENT, EXIT, ENTER, SURFACE = 0, 1, 2, 3
MAX_ITERATIONS = 4000


@kernel(lean=True)
def _ranges(el):
    """(pericentre, apocentre (inf: a hyperbola), greatest speed) of an orbit."""
    e = el[ECC]
    a = el[A]
    q = a * abs(1.0 - e)
    Q = a * (1.0 + e) if e < 1.0 else math.inf
    return q, Q, el[N_HI] * a * math.sqrt((1.0 + e) / abs(1.0 - e))


@kernel(lean=True)
def _gap(kind, el, other, t, level):
    """The distance that reaches zero at the event (see the module)."""
    x, y, z, _, _, _ = relative(el, t)
    if kind == ENTER:
        u, v, w, _, _, _ = relative(other, t)
        x -= u
        y -= v
        z -= w
    d = math.sqrt(x * x + y * y + z * z)
    return level - d if kind == EXIT else d - level


@kernel(lean=True)
def _advance(kind, el, other, level, tol, speed, start, stop):
    """The first time in [start, stop) at which _gap is within tol of its zero, or the time
    the search reached (>= stop, or where it gave up) with found False: (time, found)."""
    t = start
    for _ in range(MAX_ITERATIONS):
        if t >= stop:
            return t, False
        f = _gap(kind, el, other, t, level)
        if f <= tol:
            return t, True
        t += f / speed
    return t, False


@kernel(lean=True)
def _earlier(best, kind, other, t, hit, k, o):
    """The earlier of (best, kind, other) and a search that stopped at t (an event of kind k
    with entry o if hit): an event wins a tie with a search that merely got that far."""
    if t < best or (t == best and hit and kind == NO_EVENT):
        return t, (k if hit else NO_EVENT), (o if hit else -1)
    return best, kind, other


@kernel
def search(elements, coasting, soi, parent, kids_start, kids, parent_soi, reach, window,
           until, due, kind, other):
    """Find each coasting body's next event before `until`.

    elements (R, ELEMENTS) the rails' orbits; coasting (C,) the coasting bodies' entries;
    soi (R,) each entry's sphere radius; parent (C,) each coasting body's parent's index in
    kids_start (P+1,) / kids (K,) (the entries on rails about that parent) and in
    parent_soi (P,) (inf: no sphere); reach (C,) the distance at which a body reaches its
    parent's surface (the two radii + near); window (C,) each body's search window. due (C,)
    in and out: the time up to which the body is known to have no event (-inf: from its
    orbit's epoch), or its event's time; kind (C,) (EXIT, ENTER, SURFACE, or NO_EVENT) and
    other (C,) (the entry entered, else -1) out. Bodies whose due is >= until, or who have an
    event, are left as they are.
    """
    for c in range(coasting.size):
        while due[c] < until and kind[c] == NO_EVENT:
            el = elements[coasting[c]]
            q, Q, v = _ranges(el)
            p = parent[c]
            start = due[c]
            stop = start + window[c]
            best, bkind, bother = math.inf, NO_EVENT, -1
            R = parent_soi[p]
            if Q > R * (1.0 + EPS):
                t, hit = _advance(EXIT, el, el, R * (1.0 + 2.0 * EPS), EPS * R, v, start,
                                  stop)
                best, bkind, bother = _earlier(best, bkind, bother, t, hit, EXIT, -1)
            if q < reach[c]:
                t, hit = _advance(SURFACE, el, el, reach[c], EPS * reach[c], v, start,
                                  min(stop, best))
                best, bkind, bother = _earlier(best, bkind, bother, t, hit, SURFACE, -1)
            for j in range(kids_start[p], kids_start[p + 1]):
                k = kids[j]
                ok = elements[k]
                qk, Qk, vk = _ranges(ok)
                Rk = soi[k]
                if Q < qk - Rk or q > Qk + Rk:
                    continue                  # their radial ranges never meet
                t, hit = _advance(ENTER, el, ok, Rk * (1.0 - 2.0 * EPS), EPS * Rk, v + vk,
                                  start, min(stop, best))
                best, bkind, bother = _earlier(best, bkind, bother, t, hit, ENTER, k)
            due[c] = best                     # inf: nothing can ever happen on this conic
            kind[c] = bkind
            other[c] = bother


@kernel
def conic_states(elements, entries, t, out):
    """Place and velocity (x, y, z, vx, vy, vz) about its parent of each entry (k,) at time
    t into out (k, 6)."""
    for j in range(entries.size):
        r = relative(elements[entries[j]], t)
        for c in range(6):
            out[j, c] = r[c]


@kernel
def gaps(pos, vel, radius, coasting, parents, near, others, out):
    """How long each coasting body (rows (C,)) surely stays more than `near` from the
    surfaces of the bodies `others` (rows (O,): those integrated, fixed or on an ephemeris)
    but its parent (rows (C,): its conic finds that surface): each gap over twice the sum of
    their speeds (which bounds their closing speed, with a margin for their accelerations),
    0 where a gap is already closed; out (C,)."""
    for c in range(coasting.size):
        i = coasting[c]
        best = math.inf
        for j in others:
            if j == i or j == parents[c]:
                continue
            dx = pos[j, 0] - pos[i, 0]
            dy = pos[j, 1] - pos[i, 1]
            dz = pos[j, 2] - pos[i, 2]
            gap = math.sqrt(dx * dx + dy * dy + dz * dz) - radius[i] - radius[j] - near
            if gap <= 0.0:
                best = 0.0
                break
            vi = math.sqrt(vel[i, 0] ** 2 + vel[i, 1] ** 2 + vel[i, 2] ** 2)
            vj = math.sqrt(vel[j, 0] ** 2 + vel[j, 1] ** 2 + vel[j, 2] ** 2)
            speed = 2.0 * (vi + vj)
            if speed > 0.0:
                best = min(best, gap / speed)
        out[c] = best
