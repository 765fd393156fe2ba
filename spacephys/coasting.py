"""Patched conics (World.coast, World(coast="auto")): a coasting body moves on the Kepler
conic of its dominant body, as a body on rails does (spacephys/rails.py), and changes parent
where it crosses a sphere of influence; time passes without steps when nothing is integrated
(World.advance's warp). A part of World: it reads the World's bodies and rails.

Spheres of influence: a body on Kepler rails about P (and not itself coasting) has Laplace's
radius a (m / m_P)^(2/5), a its orbit's semi-major axis; the bodies the rails hang from (a
parent not itself on rails, or a body on an ephemeris) have no bound. A coasting body's
dominant body is, of those, the one pulling on it hardest, then, going down, the innermost
sphere it is inside. Its conic is that of its place and velocity about it, mu = G (m_P + m)
(G m_P about a fixed P).

Its events are found by time (kernels/coast.py): leaving its parent's sphere (event
soi_exit, b the parent left; it goes on about the parent's parent), entering the sphere of a
body on rails about its parent (soi_enter, b the body entered), both at the time found, the
body placed on its new conic from then; coming down to its parent's surface (its radius plus
`near`) returns it to integration before the step that would reach it. It also returns to
integration when it thrusts (World.control, a plan's burn starting), or comes within `near`
of the surface of a body that is integrated, fixed or on an ephemeris (checked again after
each gap / (2 (|v| + |v_other|)), a bound on when it may close). Two coasting bodies do not see
each other.

A kernel call stops at the step holding the next event, so a change of parent is applied at
most a step late in an integrated scene; when nothing is integrated (every body that moves is
on rails or coasting, no ship turns), time passes in one jump (kernels/rails.jump) and the
events in between are applied at their own times.
"""
import math

import numpy as np

from .events import EVENT_DTYPE
from .kernels import coast as kcoast
from .kernels import libm
from .kernels import rails as krails
from .kernels.codes import EV_SOI_ENTER, EV_SOI_EXIT
from .editing import pair_mu
from .rails import elements as conic
from . import portable

# the exponent of Laplace's sphere of influence
LAPLACE = 0.4


class Coasting:
    """World w's coasting bodies (see the module); their state is its rails' (Rails.coast,
    .due, .event, .near, .auto)."""

    def __init__(self, world):
        self.w = world
        # what the last full look found: nothing happens before `quiet` while the rails and
        # the tables are those of `key`
        self.key = None
        self.quiet = -math.inf
        self.layout = None             # (key, what the search reads): _layout

    def __getstate__(self):
        return {"w": self.w, "key": None, "quiet": -math.inf,     # (the keys hold tables)
                "layout": None}

    @property
    def rails(self):
        return self.w._forces.rails

    # ---------------------------------------------------------------- World.coast
    def coast(self, ids, on=True):
        """World.coast: checked for every body first, then done."""
        w = self.w
        rows = np.array([w.index_of(i, "ids") for i in np.atleast_1d(np.asarray(ids))],
                        np.int64)
        rails = self.rails
        bodies = w._b.ids[rows].astype(np.int64)
        if not on:
            for body in bodies:
                self.release(body)
            return
        why = [self.why_not(i) for i in rows]
        for body, reason in zip(bodies, why):
            if reason:
                raise ValueError(f"ids: {body} cannot coast: {reason}")
        orbits = []
        for i, body in zip(rows, bodies):
            parent = self.dominant(i)
            try:
                orbits.append((parent, self._orbit(i, w.index_of(parent, "about"), w.t)))
            except ValueError as e:
                raise ValueError(f"ids: {body} cannot coast about {parent}: {e}") from None
        for body, (parent, orbit) in zip(bodies, orbits):
            rails.put(int(body), int(parent), orbit, coast=True)
        w._set_up()

    def why_not(self, i):
        """Why the body at row i cannot coast ('' if it can)."""
        w = self.w
        b = w._b
        body = int(b.ids[i])
        rails = self.rails
        k = rails.entry(body)
        if k is not None and not rails.coast[k]:
            return "it is on rails (set_rails(id, None) first)"
        if b.fixed[i]:
            return "it is fixed"
        if any(int(body) in (int(a), int(c)) for _, a, c in w._forces.tether_ids):
            return "it is tethered (a tether's pull is not a conic)"
        if w._actors.is_actor(i):
            if b.launcher.item(i) >= 0:
                return "it is a missile (it flies its guidance)"
            if b.throttle.item(i) > 0.0:
                return f"it thrusts (throttle {b.throttle.item(i)})"
        if body in rails.ids[:, 1]:
            return "a body is on rails about it"
        if not self.tops().size:
            return "nothing pulls it (no body of mass to coast about)"
        return ""

    def _orbit(self, i, p, t):
        """The conic of the body at row i about the body at row p, at time t."""
        b = self.w._b
        mu = pair_mu(self.w, i, p)
        if not mu > 0.0:
            raise ValueError("no mass to orbit")
        return conic(b.pos[i] - b.pos[p], b.vel[i] - b.vel[p], mu, t)

    # ---------------------------------------------------------------- spheres
    def tops(self):
        """(rows,) the bodies of mass a coasting body may hang from at the top: the parents
        of Kepler rails not on rails themselves and the bodies on ephemerides; without rails,
        every body of mass that is not coasting."""
        w = self.w
        b = w._b
        rails = self.rails
        on = set(int(x) for x in rails.ids[:, 0])
        tops = {int(p) for p in rails.ids[rails.kepler, 1] if int(p) not in on}
        tops |= {int(x) for x in rails.ids[rails.ids[:, 1] < 0, 0]}
        if not tops:
            n = b.n
            tops = {int(x) for x in b.ids[:n][b.mass[:n] > 0]} - \
                {int(x) for x in rails.ids[rails.coast, 0]}
        rows = w._b.lookup(np.array(sorted(tops), np.int64))
        return rows[(rows >= 0)]

    def spheres(self):
        """(R,) each rails entry's sphere of influence radius (inf for none: coasting,
        on an ephemeris)."""
        w = self.w
        rails = self.rails
        out = np.full(len(rails), np.inf)
        kepler = np.flatnonzero(rails.kepler)
        if kepler.size:
            m = w._b.mass[w._b.lookup(rails.ids[kepler, 0])]
            M = w._b.mass[w._b.lookup(rails.ids[kepler, 1])]
            a = rails.orbits[kepler, krails.A]
            with np.errstate(divide="ignore"):
                out[kepler] = a * np.array([libm.py.pow(float(x), LAPLACE) for x in m / M])
        return out

    def dominant(self, i):
        """The id of the dominant body of the body at row i (see the module)."""
        w = self.w
        b = w._b
        tops = self.tops()
        d2 = ((b.pos[tops] - b.pos[i]) ** 2).sum(axis=1)
        pull = np.where(d2 > 0, b.mass[tops] / np.where(d2 > 0, d2, 1.0), -np.inf)
        parent = int(b.ids[tops[int(np.argmax(pull))]])
        rails = self.rails
        soi = self.spheres()
        kepler = rails.kepler
        while True:
            kids = np.flatnonzero(kepler & (rails.ids[:, 1] == parent))
            inside = [(soi[k], int(rails.ids[k, 0])) for k in kids
                      if np.sum((b.pos[w.index_of(int(rails.ids[k, 0]), "id")] - b.pos[i]) ** 2)
                      < soi[k] * soi[k]]
            if not inside:
                return parent
            parent = min(inside)[1]

    # ---------------------------------------------------------------- the driver's calls
    def chunk(self, nsteps, jumping=False):
        """Before a kernel call of up to nsteps steps: bodies set to coast by coast="auto",
        coasting bodies that must be integrated from now released; returns how many steps to
        take before the next event (>= 1). jumping: time passes in one jump (nothing is
        integrated), and the changes of parent within it are made first, each at its own
        time: only a return to integration ends it."""
        w = self.w
        dt = w._dt
        t = w.t
        end = t + nsteps * dt
        if self.key == (self.rails.version, w._plan, jumping) and end <= self.quiet:
            return nsteps
        rails = self.rails
        quiet = math.inf
        if rails.auto:
            quiet = self._auto(t)
        if not rails.coast.any():
            self._keep(quiet, jumping)
            return nsteps
        limit = nsteps
        safe = self._safe(t, dt)
        if not rails.coast.any():
            self._keep(quiet, jumping)
            return nsteps
        if safe is not None:
            limit = min(limit, max(int(safe // dt), 1))
            quiet = min(quiet, t + safe)
        if jumping:           # nothing integrated: the changes within the jump made first
            self._apply(end, False)
            if not rails.coast.any():
                self._keep(quiet, jumping)
                return nsteps
        entries, kinds = self._search(end)
        due = rails.due[entries]
        quiet = min(quiet, float(due.min()))
        soon = np.flatnonzero((kinds != kcoast.NO_EVENT) & (due < end))
        if soon.size:
            j = soon[np.argmin(due[soon])]         # the first event
            if kinds[j] == kcoast.SURFACE:         # integrated before the step that lands
                steps = int(math.floor((due[j] - t) / dt))
                if steps <= 0:
                    self._release(int(rails.ids[entries[j], 0]))
                    return self.chunk(nsteps, jumping)
            else:                                  # the step holding the change of parent
                steps = max(int(math.ceil((due[j] - t) / dt)), 1)
            limit = min(limit, steps)
        self._keep(quiet, jumping)
        return max(int(limit), 1)

    def _keep(self, quiet, jumping):
        self.key = (self.rails.version, self.w._plan or self.w.tables(), jumping)
        self.quiet = quiet

    def caught_up(self):
        """After a kernel call: the changes of parent due by now, each at its own time (a
        body's second change in the same call too), and their events."""
        w = self.w
        rails = self.rails
        t = w.t
        if self.key is not None and self.key[:2] == (rails.version, w._plan) and \
                t < self.quiet or not rails.coast.any():
            return
        if self._apply(t, True):
            self.place()

    def _apply(self, until, surfaces):
        """Apply the changes of parent (and with `surfaces` the returns to integration) due
        at or before `until`, in time order, searching again after each; whether any
        coasting body moved to a new conic."""
        rails = self.rails
        moved = False
        while rails.coast.any():
            entries, kinds = self._search(until)
            due = rails.due[entries]
            now = (kinds != kcoast.NO_EVENT) & (due <= until)
            if not surfaces:
                now &= kinds != kcoast.SURFACE
            if not now.any():
                break
            order = np.argsort(due[now], kind="stable")
            for k in entries[now][order]:
                moved |= self._change(int(k))
        return moved

    def place(self):
        """Every body on rails where its orbit has it now (after a change of parent)."""
        w = self.w
        table = w._plan.rails if w._plan is not None else None
        if table is None or self.rails.built is None or self.rails.built[0] is not table:
            return                  # the next tables' build places nothing: the step will
        b = w._b
        rails = self.rails
        rails.clock[0], rails.clock[1] = w._t_base, w._steps
        krails.jump(table, 0, w._dt, b.pos, b.vel, b.prev)

    def why_integrated(self):
        """Why a warped frame integrates steps (World.advance), or None: time may pass in
        jumps. coast="auto" sets the ships that may coast coasting first."""
        w = self.w
        if self.rails.auto:
            self._auto(w.t)
        plan = w._plan or w.tables()
        reason = self.blocker(plan)
        if reason is None and plan.rails is None:
            return "no body is on rails or coasting"
        return reason

    def blocker(self, plan):
        """Why time cannot pass in one jump (a body is integrated, a ship turns), or None."""
        w = self.w
        if plan.free.size:
            return f"{w.named(plan.free[:1])} is integrated"
        if plan.actors is not None:
            b = w._b
            rows = w._actors.rows()
            spin = b.turn[rows] != 0
            if "omega" in b.columns:
                spin |= b.omega[rows] != 0
            turning = rows[spin.any(axis=1)]
            if turning.size:
                return f"{w.named(turning[:1])} turns"
        return None

    # ---------------------------------------------------------------- inside
    def _layout(self):
        """What the search and the gaps read besides the progress, kept while the rails and
        tables are those it was made for: (entries (C,), soi (R,), parent (C,), kids_start,
        kids, parent_soi, reach (C,), window (C,), the coasting bodies' rows (C,), their
        parents' rows (C,), the rows of the bodies whose gaps are watched)."""
        w = self.w
        rails = self.rails
        plan = w._plan or w.tables()        # (first: a build drops the entries of the gone)
        key = (rails.version, plan)
        if self.layout is not None and self.layout[0] == key:
            return self.layout[1]
        entries = np.flatnonzero(rails.coast).astype(np.int64)
        b = w._b
        parents = rails.ids[entries, 1]
        keys, parent = np.unique(parents, return_inverse=True)
        kepler = rails.kepler
        soi = self.spheres()
        kids = [np.flatnonzero(kepler & (rails.ids[:, 1] == p)) for p in keys]
        kids_start = np.zeros(len(keys) + 1, np.int64)
        kids_start[1:] = np.cumsum([len(k) for k in kids])
        flat = np.concatenate(kids).astype(np.int64) if kids else np.zeros(0, np.int64)
        own = [rails.entry(int(p)) for p in keys]
        parent_soi = np.array([np.inf if k is None else soi[k] for k in own])
        reach = b.radius[b.lookup(parents)] + b.radius[b.lookup(rails.ids[entries, 0])] + \
            rails.near
        n = rails.orbits[entries, krails.N_HI]
        window = np.where(rails.orbits[entries, krails.ECC] < 1.0, 0.25 * 2.0 * np.pi / n,
                          1.0 / n)
        kepler = rails.ids[kepler, 0]
        still = np.flatnonzero(b.fixed[:b.n])
        if kepler.size and still.size:
            still = still[~np.isin(still, b.lookup(kepler))]
        ephem = b.lookup(rails.ids[rails.ids[:, 1] < 0, 0])
        others = np.concatenate([plan.free, still, ephem]).astype(np.int64)
        got = (entries, soi, parent.astype(np.int64), kids_start, flat, parent_soi, reach,
               window, b.lookup(rails.ids[entries, 0]).astype(np.int64),
               b.lookup(parents).astype(np.int64), others)
        self.layout = (key, got)
        return got

    def _search(self, until):
        """Run the search for every coasting body up to `until`: (entries (C,), kinds (C,))."""
        rails = self.rails
        entries, soi, parent, kids_start, kids, parent_soi, reach, window = \
            self._layout()[:8]
        due = rails.due[entries]
        kind = rails.event[entries, 0]
        other = rails.event[entries, 1]
        kcoast.search(rails.orbits, entries, soi, parent, kids_start, kids, parent_soi, reach,
                      window, float(until), due, kind, other)
        rails.due[entries] = due
        rails.event[entries, 0] = kind
        rails.event[entries, 1] = other
        return entries, kind

    def _change(self, k):
        """Entry k's change of parent at its due time (its event recorded); False when the
        new conic cannot be held (it returns to integration)."""
        w = self.w
        rails = self.rails
        te = float(rails.due[k])
        kind, other = int(rails.event[k, 0]), int(rails.event[k, 1])
        body, old = int(rails.ids[k, 0]), int(rails.ids[k, 1])
        if kind == kcoast.SURFACE:
            self._release(body)
            return False
        mine = self._conic(k, te)
        if kind == kcoast.EXIT:
            kp = rails.entry(old)
            rel = mine + self._conic(kp, te)
            new, code, sphere = int(rails.ids[kp, 1]), EV_SOI_EXIT, old
        else:
            rel = mine - self._conic(other, te)
            new = int(rails.ids[other, 0])
            code, sphere = EV_SOI_ENTER, new
        b = w._b
        i, p = w.index_of(body, "id"), w.index_of(new, "id")
        mu = pair_mu(w, i, p)
        at = self._absolute(k, te)
        s = w.index_of(sphere, "id")
        where = self._absolute(rails.entry(sphere), te) if rails.entry(sphere) is not None \
            else np.concatenate([b.pos[s], b.vel[s]])
        try:
            orbit = conic(rel[:3], rel[3:], mu, te)
        except ValueError:
            self._release(body)
            return False
        rails.switch(k, new, p, orbit)
        self.w._setup = None
        self._record(code, body, sphere, te, at, where, self.spheres()[rails.entry(sphere)]
                     if rails.entry(sphere) is not None else np.inf)
        return True

    def _conic(self, k, t):
        out = np.zeros((1, 6))
        kcoast.conic_states(self.rails.orbits, np.array([k], np.int64), float(t), out)
        return out[0]

    def _absolute(self, k, t):
        """(6,) place and velocity at time t of the body of entry k: its conics up the chain
        to a body not on Kepler rails (its place now: fixed, or an ephemeris's at t)."""
        w = self.w
        rails = self.rails
        acc = np.zeros(6)
        while k is not None and rails.ids[k, 1] >= 0:
            acc += self._conic(k, t)
            top = int(rails.ids[k, 1])
            k = rails.entry(top)
        if k is None:
            r = w.index_of(top, "id")
            return acc + np.concatenate([w._b.pos[r], w._b.vel[r]])
        row = rails.orbits[k].copy()
        row[krails.E_FIRST] = 0                # the body's own coefficients, not the table's
        out = np.zeros((1, 6))
        krails.chebyshev_many(rails.ephemerides[int(rails.ids[k, 0])], row, np.array([t]), out)
        return acc + out[0]

    def _record(self, code, a, b, t, at, where, radius):
        """An event (kind code, bodies a and b) at time t: a's place at (6,), b's where (6,)."""
        w = self.w
        count = int(w._event_count[0])
        if count >= w._events.shape[0]:
            grown = np.zeros(max(256, 2 * w._events.shape[0]), EVENT_DTYPE)
            grown[:count] = w._events[:count]
            w._events = grown
            w._plan = None
        e = w._events[count]
        e["kind"], e["a"], e["b"], e["time"] = code, a, b, t
        step = w._dt
        e["t_in_step"] = t - (w._t_base + math.floor((t - w._t_base) / step) * step)
        e["x"], e["y"], e["z"] = at[:3]
        d = where[:3] - at[:3]
        dn = portable.norm(d)
        if dn > 0:
            e["nx"], e["ny"], e["nz"] = d / dn
        u = where[3:] - at[3:]
        e["speed"] = portable.norm(u)
        e["distance"] = radius
        e["circle_a"] = e["circle_b"] = -1
        w._event_count[0] = count + 1
        w.driver._name_bodies(count)

    def release(self, body):
        """The body integrated from now if it coasts, from its conic's state (its place
        now)."""
        k = self.rails.entry(int(body))
        if k is not None and self.rails.coast[k]:
            self._release(body)

    def _release(self, body):
        self.rails.drop(int(body))
        self.w._set_up()

    def _safe(self, t, dt):
        """Release the coasting bodies within a step of the surface of another body (near
        included) or of a planned burn; the time the others are safe for (None: no limit)."""
        w = self.w
        rails = self.rails
        b = w._b
        layout = self._layout()
        entries, coasting, parents, others = layout[0], layout[8], layout[9], layout[10]
        limit = None
        release = []
        if others.size:
            out = np.empty(coasting.size)
            kcoast.gaps(b.pos, b.vel, b.radius, coasting, parents, float(rails.near), others,
                        out)
            release = [int(x) for x in rails.ids[entries[out < dt], 0]]
            rest = out[out >= dt]
            if rest.size and rest.min() < math.inf:
                limit = float(rest.min())
        for ship, burns in w._actors.plans.items():
            k = rails.entry(int(ship))
            if k is None or not rails.coast[k]:
                continue
            ahead = burns[burns[:, 2] > t, 1]
            if ahead.size:
                start = float(ahead.min()) - t
                if start < dt:
                    release.append(int(ship))
                else:
                    limit = start if limit is None else min(limit, start)
        for body in release:
            self._release(body)
        return limit

    def _auto(self, t):
        """coast="auto": every ship that does not thrust, has no burn coming within a step,
        and may coast (why_not), coasts; returns when a planned burn ends next (a ship may
        coast from then)."""
        w = self.w
        b = w._b
        if "actor" not in b.columns:
            return math.inf
        rails = self.rails
        rows = w._actors.rows()
        ships = rows[(b.launcher[rows] < 0) & (b.throttle[rows] == 0.0) & ~b.fixed[rows]]
        on = set(int(x) for x in rails.ids[:, 0])
        fresh = [int(i) for i in ships if int(b.ids[i]) not in on]
        planned = set()
        wake = math.inf
        for ship, burns in w._actors.plans.items():
            going = burns[:, 2] > t
            if going.any():
                wake = min(wake, float(burns[going, 2].min()))
                if (burns[going, 1] < t + 2 * w._dt).any():
                    planned.add(int(ship))
        ok = [i for i in fresh if int(b.ids[i]) not in planned and not self.why_not(i)]
        if ok:
            self.coast(b.ids[ok])
        return wake
