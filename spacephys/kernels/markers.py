"""A predicted path's markers (spacephys/predict.py): the dominant body at each sample, and the
extrema of the distance between two paths (apsides, closest approaches), refined between
samples on the cubic Hermite interpolant of the relative motion (positions and velocities at
both ends of an interval: error O(h^4) in position).
"""
import math

import numpy as np

from .._jit import kernel
from . import libm


@kernel
def paths(samples, rows, dest, out):
    """out[dest[k], j] = samples[j, rows[k]]: samples (P, m, 3) as a prediction captures
    them, the paths of rows (K,) into out (., P, 3)."""
    P = samples.shape[0]
    for j0 in range(0, P, 32):          # in blocks of samples: a block's rows stay in cache
        j1 = min(j0 + 32, P)
        for k in range(rows.size):
            r, d = rows[k], dest[k]
            for j in range(j0, j1):
                out[d, j, 0] = samples[j, r, 0]
                out[d, j, 1] = samples[j, r, 1]
                out[d, j, 2] = samples[j, r, 2]


@kernel
def hardest(pos, mass, active, rows, pick, dist):
    """For each of rows (k,): pick[k] the row of the body pulling on it hardest (largest
    m / d^2 among the active bodies with mass, the body itself left out; the first of equals),
    -1 where none does; dist[k] the distance to it (nan: none). pos (n, 3), mass (n,), active
    (n,) bool. Returns how many bodies pull (active, with mass)."""
    pulling = 0
    for i in range(mass.size):
        if active[i] and mass[i] > 0.0:
            pulling += 1
    for k in range(rows.size):
        r = rows[k]
        best, j, far = 0.0, -1, math.nan
        for i in range(mass.size):
            if i == r or not active[i] or not mass[i] > 0.0:
                continue
            d2 = 0.0
            for x in range(3):
                d = pos[i, x] - pos[r, x]
                d2 += d * d
            if d2 > 0.0 and mass[i] / d2 > best:
                best, j, far = mass[i] / d2, i, d2
        pick[k] = j
        dist[k] = math.sqrt(far)
    return pulling


@kernel
def dominant(pos, cs, csel, cmass, same, out):
    """out[k, j] = the candidate pulling hardest (largest m_c / d^2) on path k at sample j, -1
    where the path has ended (NaN); pos (K, P, 3); the candidates' positions cs[:, csel[c]]
    (cs (P, m, 3): the samples as a prediction takes them), cmass (C,); same (K,) the
    candidate that is path k itself (-1: none)."""
    K, P = pos.shape[0], pos.shape[1]
    for k in range(K):
        for j in range(P):
            best, pick = 0.0, -1
            if pos[k, j, 0] == pos[k, j, 0]:
                for c in range(cmass.size):
                    if c == same[k]:
                        continue
                    d2 = 0.0
                    for x in range(3):
                        d = cs[j, csel[c], x] - pos[k, j, x]
                        d2 += d * d
                    if d2 > 0.0 and cmass[c] / d2 > best:
                        best, pick = cmass[c] / d2, c
            out[k, j] = pick


@kernel(inline=True)
def _hermite(p0, v0, p1, v1, h, s):
    """Position and velocity at s in [0, 1] of the cubic through (p0, v0) and (p1, v1) over an
    interval of length h (one component)."""
    s2 = s * s
    s3 = s2 * s
    p = ((2 * s3 - 3 * s2 + 1) * p0 + (s3 - 2 * s2 + s) * h * v0 + (-2 * s3 + 3 * s2) * p1
         + (s3 - s2) * h * v1)
    v = ((6 * s2 - 6 * s) * p0 / h + (3 * s2 - 4 * s + 1) * v0 + (-6 * s2 + 6 * s) * p1 / h
         + (3 * s2 - 2 * s) * v1)
    return p, v


@kernel
def _radial(rp, rv, j, h, s):
    """(r . v, |r|) of the interpolated relative motion at s in interval j."""
    rr, rd = 0.0, 0.0
    for x in range(3):
        p, v = _hermite(rp[j, x], rv[j, x], rp[j + 1, x], rv[j + 1, x], h, s)
        rr += p * p
        rd += p * v
    return rd, math.sqrt(rr)


@kernel
def _bisect(rp, rv, j, h, kind, bits):
    """s in [0, 1] where r . v of interval j's Hermite interpolant changes sign (from
    negative if kind < 0), to 2^-bits of the interval."""
    lo, hi = 0.0, 1.0
    for _ in range(bits):
        mid = 0.5 * (lo + hi)
        g, _r = _radial(rp, rv, j, h, mid)
        if (g < 0.0) == (kind < 0.0):
            lo = mid
        else:
            hi = mid
        if mid == lo and mid == hi:
            break
    return 0.5 * (lo + hi)


@kernel
def extrema(t, rp, rv, use, out, bits):
    """The local minima and maxima of the distance |rp| of a relative motion sampled at t (P,),
    rp, rv (P, 3), over the intervals j with use[j] (both ends valid and the same reference):
    where r . v changes sign, refined by bisection on the Hermite interpolant to 2^-bits of
    the interval (60: below rounding). Writes rows [kind (-1 minimum, +1 maximum), time,
    distance, interval, s] into out (M, 5); returns the count (at most M)."""
    count = 0
    P = t.size
    for j in range(P - 1):
        if not use[j] or count >= out.shape[0]:
            continue
        g0 = rp[j, 0] * rv[j, 0] + rp[j, 1] * rv[j, 1] + rp[j, 2] * rv[j, 2]
        g1 = (rp[j + 1, 0] * rv[j + 1, 0] + rp[j + 1, 1] * rv[j + 1, 1]
              + rp[j + 1, 2] * rv[j + 1, 2])
        if g0 < 0.0 <= g1:
            kind = -1.0
        elif g0 > 0.0 >= g1:
            kind = 1.0
        else:
            continue
        h = t[j + 1] - t[j]
        s = _bisect(rp, rv, j, h, kind, bits)
        g, r = _radial(rp, rv, j, h, s)
        out[count, 0] = kind
        out[count, 1] = t[j] + s * h
        out[count, 2] = r
        out[count, 3] = j
        out[count, 4] = s
        count += 1
    return count


@kernel
def interpolate(t, pos, vel, j, s, out_p, out_v):
    """The Hermite-interpolated position and velocity of a path (P, 3) at s in interval j."""
    h = t[j + 1] - t[j]
    for x in range(3):
        p, v = _hermite(pos[j, x], vel[j, x], pos[j + 1, x], vel[j + 1, x], h, s)
        out_p[x] = p
        out_v[x] = v


@kernel
def equal_pulls(t, pos, vel, apos, avel, ma, bpos, bvel, mb, j):
    """The time in interval j where bodies a (mass ma) and b pull equally on a path (all
    sampled (P, 3) with velocities), on the Hermite-interpolated positions, the pull of a the
    stronger at the interval's start: the root of g(s) = ma |b - p|^2 - mb |a - p|^2 by the
    Illinois method (regula falsi that halves a stale end's value: superlinear, and never
    leaves the bracket), to the last bits of s."""
    h = t[j + 1] - t[j]
    lo, hi = 0.0, 1.0
    glo = _pull_balance(pos, vel, apos, avel, ma, bpos, bvel, mb, j, h, lo)
    ghi = _pull_balance(pos, vel, apos, avel, ma, bpos, bvel, mb, j, h, hi)
    side = 0
    best = 0.5                                  # the last point tried: the root's estimate
    for _ in range(100):
        if not (glo > 0.0 and ghi <= 0.0):      # no sign change left (or a NaN): done
            break
        s = hi - ghi * (hi - lo) / (ghi - glo)
        if not lo < s < hi:
            s = 0.5 * (lo + hi)
        if s == lo or s == hi:                  # no room left between the ends
            break
        best = s
        g = _pull_balance(pos, vel, apos, avel, ma, bpos, bvel, mb, j, h, s)
        if g == 0.0:
            break
        if g > 0.0:                             # a still pulls harder
            lo, glo = s, g
            if side == 1:
                ghi *= 0.5
            side = 1
        else:
            hi, ghi = s, g
            if side == -1:
                glo *= 0.5
            side = -1
    return t[j] + best * h


@kernel(inline=True)
def _pull_balance(pos, vel, apos, avel, ma, bpos, bvel, mb, j, h, s):
    """ma |b - p|^2 - mb |a - p|^2 at s in interval j: > 0 while a pulls harder."""
    da, db = 0.0, 0.0
    for x in range(3):
        p, _v = _hermite(pos[j, x], vel[j, x], pos[j + 1, x], vel[j + 1, x], h, s)
        q, _w = _hermite(apos[j, x], avel[j, x], apos[j + 1, x], avel[j + 1, x], h, s)
        r, _u = _hermite(bpos[j, x], bvel[j, x], bpos[j + 1, x], bvel[j + 1, x], h, s)
        da += (q - p) * (q - p)
        db += (r - p) * (r - p)
    return ma * db - mb * da


@kernel
def _conic(rp, rv, j, mu, peri):
    """The apsis (pericentre if peri) of the conic osculating at sample j of a relative
    motion: (time from sample j, relative position (3,)); time NaN when it has none (near
    circular, an apocentre of an open orbit, no angular momentum)."""
    rx, ry, rz = rp[j, 0], rp[j, 1], rp[j, 2]
    vx, vy, vz = rv[j, 0], rv[j, 1], rv[j, 2]
    hx, hy, hz = ry * vz - rz * vy, rz * vx - rx * vz, rx * vy - ry * vx
    h2 = hx * hx + hy * hy + hz * hz
    r = math.sqrt(rx * rx + ry * ry + rz * rz)
    ex = (vy * hz - vz * hy) / mu - rx / r
    ey = (vz * hx - vx * hz) / mu - ry / r
    ez = (vx * hy - vy * hx) / mu - rz / r
    e = math.sqrt(ex * ex + ey * ey + ez * ez)
    if e < 1e-6 or (not peri and e >= 1.0) or h2 == 0.0:
        return math.nan, 0.0, 0.0, 0.0
    ux, uy, uz = ex / e, ey / e, ez / e
    p = h2 / mu
    # the true anomaly: the angle from u to r about h
    cx, cy, cz = uy * rz - uz * ry, uz * rx - ux * rz, ux * ry - uy * rx
    f = libm.atan2((cx * hx + cy * hy + cz * hz) / math.sqrt(h2), ux * rx + uy * ry + uz * rz)
    if e < 1.0:
        E = 2.0 * libm.atan2(math.sqrt(1.0 - e) * libm.sin(0.5 * f),
                             math.sqrt(1.0 + e) * libm.cos(0.5 * f))
        M = E - e * libm.sin(E)
        n = math.sqrt(mu / (p / (1.0 - e * e)) ** 3)
        if peri:
            dt = -M / n
        else:
            dt = ((math.pi if M >= 0.0 else -math.pi) - M) / n
    else:
        x = math.sqrt((e - 1.0) / (e + 1.0)) * libm.tan(0.5 * f)
        x = min(max(x, -0.9999999999999999), 0.9999999999999999)   # rounding past the asymptote
        F = 2.0 * libm.atanh(x)
        n = math.sqrt(mu / (p / (e * e - 1.0)) ** 3)
        dt = -(e * libm.sinh(F) - F) / n
    d = p / (1.0 + e) if peri else -p / (1.0 - e)      # along u at pericentre, -u at apocentre
    return dt, d * ux, d * uy, d * uz


@kernel
def apsides(t, rp, rv, cpos, cvel, mu, rows, out):
    """For each extremum row of `extrema` (M, 5) on the relative motion rp, rv (P, 3) about a
    body sampled at cpos, cvel: out[m] = [time, distance, x, y, z], the apsis on the conic
    osculating at the interval's nearer end (exact for two bodies), at the body's
    interpolated position; the Hermite extremum (refined fully here: the rows' own s need only
    tell the nearer end) where the conic has no apsis within an interval of the one found."""
    P = t.size
    for m in range(rows.shape[0]):
        j0 = int(rows[m, 3])
        j = j0 + 1 if rows[m, 4] > 0.5 else j0
        dt, ax, ay, az = _conic(rp, rv, j, mu, rows[m, 0] < 0.0)
        when = t[j] + dt
        if not (t[max(j0 - 1, 0)] <= when <= t[min(j0 + 2, P - 1)]):
            h = t[j0 + 1] - t[j0]
            s = _bisect(rp, rv, j0, h, rows[m, 0], 60)
            when = t[j0] + s * h
            for x in range(3):
                p, _v = _hermite(rp[j0, x], rv[j0, x], rp[j0 + 1, x], rv[j0 + 1, x], h, s)
                if x == 0:
                    ax = p
                elif x == 1:
                    ay = p
                else:
                    az = p
        # the body's position then (Hermite in the interval holding `when`)
        k = j0
        while k > 0 and when < t[k]:
            k -= 1
        while k < P - 2 and when > t[k + 1]:
            k += 1
        h = t[k + 1] - t[k]
        s = (when - t[k]) / h
        out[m, 0] = when
        out[m, 1] = math.sqrt(ax * ax + ay * ay + az * az)
        rel = (ax, ay, az)
        for x in range(3):
            c, _v = _hermite(cpos[k, x], cvel[k, x], cpos[k + 1, x], cvel[k + 1, x], h, s)
            out[m, 2 + x] = c + rel[x]


@kernel
def changes(t, pos, vel, cs, cv, csel, cmass, dom):
    """Every change of dominant body on paths pos, vel (K, P, 3) with dom (K, P) from
    `dominant` (the candidates' samples cs, cv, csel as there): rows [path k, time, candidate
    before, candidate after] (M, 4), by path then time; the time where the two pulls are
    equal (equal_pulls)."""
    K, P = dom.shape[0], dom.shape[1]
    count = 0
    for k in range(K):
        for j in range(P - 1):
            if dom[k, j] >= 0 and dom[k, j + 1] >= 0 and dom[k, j] != dom[k, j + 1]:
                count += 1
    out = np.empty((count, 4))
    m = 0
    for k in range(K):
        for j in range(P - 1):
            a, b = dom[k, j], dom[k, j + 1]
            if a >= 0 and b >= 0 and a != b:
                out[m, 0] = k
                out[m, 1] = equal_pulls(t, pos[k], vel[k], cs[:, csel[a]], cv[:, csel[a]],
                                        cmass[a], cs[:, csel[b]], cv[:, csel[b]], cmass[b], j)
                out[m, 2] = a
                out[m, 3] = b
                m += 1
    return out


@kernel
def all_apsides(t, pos, vel, cs, cv, csel, mu, dom):
    """The apsides of paths pos, vel (K, P, 3) about their dominant bodies (dom (K, P) from
    `dominant`, the candidates' samples cs, cv, csel as there), each taken over the intervals
    where one candidate dominates at both ends:
    rows [path k, kind (-1 pericentre, +1 apocentre), time, distance, x, y, z, candidate]
    (M, 8), by path, candidate, time. mu (K, C): G (m_candidate + m_path) per pair."""
    K, P = dom.shape[0], dom.shape[1]
    C = csel.size
    rp = np.empty((P, 3))
    rv = np.empty((P, 3))
    use = np.empty(max(P - 1, 0), np.bool_)
    rows = np.empty((max(P - 1, 1), 5))
    found = np.empty((max(P - 1, 1), 5))
    present = np.empty(C, np.bool_)
    out = np.empty((16, 8))
    m = 0
    for k in range(K):
        present[:] = False
        for j in range(P - 1):
            if dom[k, j] >= 0 and dom[k, j] == dom[k, j + 1]:
                present[dom[k, j]] = True
        for c in range(C):
            if not present[c]:
                continue
            for j in range(P - 1):
                use[j] = dom[k, j] == c and dom[k, j + 1] == c
            for j in range(P):
                for x in range(3):
                    rp[j, x] = pos[k, j, x] - cs[j, csel[c], x]
                    rv[j, x] = vel[k, j, x] - cv[j, csel[c], x]
            n = extrema(t, rp, rv, use, rows, 12)    # the nearer end is all apsides needs
            apsides(t, rp, rv, cs[:, csel[c]], cv[:, csel[c]], mu[k, c], rows[:n], found[:n])
            if m + n > out.shape[0]:
                grown = np.empty((2 * (m + n), 8))
                grown[:m] = out[:m]
                out = grown
            for r in range(n):
                out[m, 0] = k
                out[m, 1] = rows[r, 0]
                for x in range(5):
                    out[m, 2 + x] = found[r, x]
                out[m, 7] = c
                m += 1
    return out[:m]
