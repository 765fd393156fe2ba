"""Bodies on rails (World.set_rails; its checks are in editing.py): a body moved along the
Kepler orbit of its state about a parent body, never integrated (the kernels:
kernels/rails.py). This module turns a state into an orbit's elements and keeps the World's
rails (in its ForceField).

The elements (kernels/rails.ELEMENTS) are computed once, when the body is put on rails, from
its place and velocity relative to its parent and mu = G (m_parent + m_body) then (G m_parent
about a fixed parent). The mean
motion n = sqrt(mu / |a|^3) is computed to 40 digits (the decimal module: exact from the
doubles given) and kept as a double-double, so that the phase after 10^6 periods is right to
rounding; the rest of the geometry is float64 from kernels/libm (the same bits everywhere).
"""
import math
from decimal import Decimal, localcontext

import numpy as np

from .kernels import rails as krails
from .kernels.libm import py as libm
from . import portable

RAILS_DTYPE = np.dtype([("id", np.int64), ("about", np.int64), ("a", np.float64),
                        ("e", np.float64), ("period", np.float64), ("coasting", np.bool_)])

# how near a parabola an orbit may be (|1 - e|): nearer, the conic's a and b lose their digits
PARABOLIC = 1e-9


def _mean_motion(r, v, mu):
    """(n_hi, n_lo, alpha): the mean motion sqrt(mu |alpha|^3) as a double-double, and
    alpha = 2/|r| - |v|^2/mu = 1/a, from the doubles r, v (3,) and mu, to 40 digits."""
    with localcontext() as ctx:
        ctx.prec = 40
        R = sum(Decimal(float(x)) ** 2 for x in r).sqrt()
        V2 = sum(Decimal(float(x)) ** 2 for x in v)
        M = Decimal(float(mu))
        alpha = 2 / R - V2 / M
        n = (M * abs(alpha) ** 3).sqrt()
        hi = float(n)
        return hi, float(n - Decimal(hi)), float(alpha)


def elements(r, v, mu, t0):
    """The orbit (krails.ELEMENTS,) of relative place r and velocity v (3,) about a parent of
    gravitational parameter mu, at time t0. ValueError for a radial or a near-parabolic orbit
    (field 'id')."""
    r = np.asarray(r, float)
    v = np.asarray(v, float)
    h = np.cross(r, v)
    hn = portable.norm(h)
    rn = portable.norm(r)
    if rn == 0.0 or hn <= 1e-12 * rn * (portable.norm(v) + 1e-300):
        raise ValueError("a radial orbit (no angular momentum about its parent): rails need a "
                         "conic with a plane")
    n_hi, n_lo, alpha = _mean_motion(r, v, mu)
    evec = np.cross(v, h) / mu - r / rn
    e = portable.norm(evec)
    if abs(1.0 - e) < PARABOLIC:
        raise ValueError(f"an orbit of eccentricity {e!r}: within {PARABOLIC} of a parabola, "
                         f"which rails do not hold; change its speed slightly")
    what = h / hn
    P = evec / e if e > 1e-13 else r / rn        # a circle: the pericentre where it is now
    Q = np.cross(what, P)
    a = abs(1.0 / alpha)
    x, y = portable.dot(r, P), portable.dot(r, Q)
    if e < 1.0:
        b = a * math.sqrt(1.0 - e * e)        # sqrt is correctly rounded everywhere
        E = libm.atan2(y / b, x / a + e)
        M0 = E - e * libm.sin(E)
    else:
        b = a * math.sqrt(e * e - 1.0)
        H = libm.asinh(y / b)
        M0 = e * libm.sinh(H) - H
    out = np.zeros(krails.ELEMENTS)
    out[[krails.T0, krails.ECC, krails.A, krails.B]] = t0, e, a, b
    out[krails.PX:krails.PX + 3] = P
    out[krails.QX:krails.QX + 3] = Q
    out[[krails.N_HI, krails.N_LO, krails.M0, krails.MU]] = n_hi, n_lo, M0, mu
    return out


class Rails:
    """The World's bodies on rails (kept by its ForceField): ids (R, 2) [body id, parent id]
    and their orbits (R, ELEMENTS), in the order they were put on rails; coast (R,) whether
    each is a coasting body (spacephys/coasting.py: it changes parent at spheres of influence),
    and for those the search's progress (kernels/coast.search): due (R,) and event (R, 2)
    [kind, the entry entered]."""

    def __init__(self, ids=None, orbits=None, ephemerides=None, coast=None, due=None,
                 event=None):
        self.ids = np.zeros((0, 2), np.int64) if ids is None else \
            np.array(ids, np.int64).reshape(-1, 2)
        self.orbits = np.zeros((0, krails.ELEMENTS)) if orbits is None else \
            np.array(orbits, np.float64).reshape(-1, krails.ELEMENTS)
        R = len(self.ids)
        self.coast = np.zeros(R, bool) if coast is None else np.array(coast, bool).reshape(R)
        self.due = self.orbits[:, krails.T0].copy() if due is None else \
            np.array(due, np.float64).reshape(R)
        self.event = np.zeros((R, 2), np.int64) if event is None else \
            np.array(event, np.int64).reshape(R, 2)
        self.clock = np.zeros(2)        # [time base, steps]: the driver sets it per call
        # the bodies on ephemerides: id -> (their E_* row (ELEMENTS,), coef (count, 3, terms))
        self.ephemerides = dict(ephemerides or {})
        self.built = None               # the last table (RailsArrays) and its entries' order
        self.near = 0.0                 # World.coast_near
        self.version = 0                # changed by every change of the entries (touch)
        self.coasting = bool(self.coast.any())   # anything coasts
        self.active = self.coasting             # anything coasts, or may (auto)
        self.auto = False               # World.coast_auto

    def __len__(self):
        return len(self.ids)

    def __getstate__(self):
        state = self.__dict__.copy()
        state["built"] = None                 # the tables': a copy builds its own
        return state

    @property
    def kepler(self):
        """(R,) bool: the entries on Kepler rails (not coasting, not on an ephemeris)."""
        return ~self.coast & (self.ids[:, 1] >= 0)

    def parent_of(self, body):
        """The parent id of a body on rails (-1: on an ephemeris), or None."""
        hit = np.flatnonzero(self.ids[:, 0] == body)
        return int(self.ids[hit[0], 1]) if hit.size else None

    def entry(self, body):
        """The index of a body's entry, or None."""
        hit = np.flatnonzero(self.ids[:, 0] == body)
        return int(hit[0]) if hit.size else None

    def touch(self):
        """Something the coasting bodies' next events depend on changed (coasting.py keeps
        what it found until then)."""
        self.version += 1
        self.coasting = bool(self.coast.any())
        self.active = self.auto or self.coasting

    def put(self, body, parent, orbit, coast=False):
        self.drop(body)
        self.ids = np.vstack([self.ids, [[body, parent]]])
        self.orbits = np.vstack([self.orbits, orbit[None]])
        self.coast = np.append(self.coast, bool(coast))
        self.due = np.append(self.due, orbit[krails.T0])
        self.event = np.vstack([self.event, np.zeros((1, 2), np.int64)])
        self.built = None
        self.touch()

    def switch(self, k, parent, parent_row, orbit):
        """Entry k (a coasting body's) about a new parent from now on: in the table built too
        (coasting bodies come last in it, so the order stays parents first)."""
        self.touch()
        self.ids[k, 1] = parent
        self.orbits[k] = orbit
        self.due[k] = orbit[krails.T0]
        self.event[k] = 0
        if self.built is not None:
            table, order = self.built
            at = int(np.flatnonzero(order == k)[0])
            table.elements[at] = orbit
            table.parents[at] = parent_row

    def put_ephemeris(self, body, row, coef):
        """Body on an ephemeris: its E_* row and coefficients (count, 3, terms)."""
        self.put(body, -1, row)
        self.ephemerides[int(body)] = coef

    def drop(self, body):
        keep = self.ids[:, 0] != body
        if keep.all():
            return
        self.ids, self.orbits = self.ids[keep], self.orbits[keep]
        self.coast, self.due, self.event = self.coast[keep], self.due[keep], self.event[keep]
        self.ephemerides.pop(int(body), None)
        self.built = None
        self.touch()

    @property
    def until(self):
        """The last time every ephemeris flown covers (None: none flown)."""
        ends = [row[krails.E_START] + row[krails.E_COUNT] * row[krails.E_LENGTH]
                for row, parent in zip(self.orbits, self.ids[:, 1]) if parent < 0]
        return min(ends) if ends else None

    def table(self, lookup, pulls=None):
        """krails.RailsArrays for the rows lookup(ids) gives (-1: gone), parents before their
        children and coasting bodies last, those that pull (pulls (n,) bool by row) before
        those that do not; None without rails. A body whose parent is gone is dropped (it
        returns to integration), as is a gone body's entry."""
        if not len(self):
            return None
        rows = lookup(self.ids[:, 0])
        on_ephemeris = self.ids[:, 1] < 0
        parents = np.where(on_ephemeris, -1, lookup(np.maximum(self.ids[:, 1], 0)))
        keep = (rows >= 0) & ((parents >= 0) | on_ephemeris)
        if not keep.all():
            for body in self.ids[~keep, 0]:
                self.drop(int(body))
            return self.table(lookup, pulls)
        quiet = self.coast & (~pulls[rows] if pulls is not None else False)
        order = self._parents_first(quiet)
        orbits = self.orbits[order].copy()
        terms = max([c.shape[2] for c in self.ephemerides.values()], default=1)
        blocks = []
        first = 0
        for k, body in enumerate(self.ids[order, 0]):
            coef = self.ephemerides.get(int(body))
            if coef is not None:
                orbits[k, krails.E_FIRST] = first
                block = np.zeros((coef.shape[0], 3, terms))
                block[:, :, :coef.shape[2]] = coef
                blocks.append(block)
                first += coef.shape[0]
        coef = np.concatenate(blocks) if blocks else np.zeros((0, 3, 1))
        table = krails.RailsArrays(rows[order].astype(np.int64),
                                   parents[order].astype(np.int64),
                                   np.ascontiguousarray(orbits), coef, self.clock,
                                   np.array([len(self) - int(quiet.sum())], np.int64))
        self.built = (table, order)
        return table

    def _parents_first(self, quiet):
        """The entries' order with every parent on rails before its children, the coasting
        bodies (which no body is on rails about) after them, the `quiet` ones (R,) bool last."""
        depth = np.zeros(len(self), np.int64)
        index = {int(b): k for k, b in enumerate(self.ids[:, 0])}
        for k in np.flatnonzero(~self.coast):
            p = int(self.ids[k, 1])
            while p in index:
                depth[k] += 1
                p = int(self.ids[index[p], 1])
        depth[self.coast] = len(self) + 1
        depth[quiet] = len(self) + 2
        return np.argsort(depth, kind="stable")

    def listing(self):
        """World.rails: a RAILS_DTYPE row per body on rails."""
        out = np.zeros(len(self), RAILS_DTYPE)
        out["id"], out["about"], out["coasting"] = self.ids[:, 0], self.ids[:, 1], self.coast
        kepler = self.ids[:, 1] >= 0
        e = np.where(kepler, self.orbits[:, krails.ECC], np.nan)
        a = self.orbits[:, krails.A]
        out["e"] = e
        out["a"] = np.where(kepler, np.where(e < 1.0, a, -a), np.nan)
        n = self.orbits[:, krails.N_HI]
        with np.errstate(divide="ignore", invalid="ignore"):
            out["period"] = np.where(kepler & (e < 1.0), 2.0 * np.pi / n,
                                     np.where(kepler, np.inf, np.nan))
        return out

    def state(self):
        bodies = sorted(self.ephemerides)
        coef = [self.ephemerides[b] for b in bodies]
        terms = max([c.shape[2] for c in coef], default=1)
        flat = np.concatenate([np.pad(c, ((0, 0), (0, 0), (0, terms - c.shape[2])))
                               for c in coef]) if coef else np.zeros((0, 3, 1))
        return {"rails_ids": self.ids.copy(), "rails_orbits": self.orbits.copy(),
                "rails_ephemeris_ids": np.array(bodies, np.int64),
                "rails_ephemeris_coef": flat, "rails_coast": self.coast.copy(),
                "rails_due": self.due.copy(), "rails_event": self.event.copy(),
                "coast_near": self.near, "coast_auto": self.auto}

    def motion(self):
        """What changes as coasting bodies change parent (worldstate.Motion); None without
        them."""
        if not self.coasting:
            return None
        return (self.ids.copy(), self.orbits.copy(), self.coast.copy(), self.due.copy(),
                self.event.copy())

    def set_motion(self, m):
        """Back to motion m; whether the tables built still hold (the same bodies about the
        same parents: their orbits are written into the table in place)."""
        if m is None:
            return not self.coasting
        ids, orbits, coast, due, event = m
        same = self.built is not None and np.array_equal(self.ids, ids) and \
            np.array_equal(self.coast, coast)
        self.ids, self.orbits, self.coast = ids.copy(), orbits.copy(), coast.copy()
        self.due, self.event = due.copy(), event.copy()
        self.touch()
        if not same:
            self.built = None
            return False
        table, order = self.built
        table.elements[:] = self.orbits[order]
        return True

    @classmethod
    def from_state(cls, s):
        r = cls(s.get("rails_ids"), s.get("rails_orbits"), coast=s.get("rails_coast"),
                due=s.get("rails_due"), event=s.get("rails_event"))
        r.near, r.auto = float(s.get("coast_near", 0.0)), bool(s.get("coast_auto", False))
        r.touch()
        bodies = np.array(s.get("rails_ephemeris_ids", np.zeros(0)), np.int64).reshape(-1)
        flat = np.array(s.get("rails_ephemeris_coef", np.zeros((0, 3, 1))), np.float64)
        first = 0
        for body in bodies:
            k = int(np.flatnonzero(r.ids[:, 0] == body)[0])
            count, terms = int(r.orbits[k, krails.E_COUNT]), int(r.orbits[k, krails.E_TERMS])
            r.ephemerides[int(body)] = flat[first:first + count, :, :terms].copy()
            first += count
        return r
