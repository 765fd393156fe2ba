"""The computer's pilot: flies any ship of a World with the public API only — queries
(shapecast, nearest), the missiles' own guidance, orbital elements and manoeuvre plans — so
what it does, a game's own AI can do."""
import math

import numpy as np

import spacephys as sp
from spacephys import portable


def _wrap_angle(a):
    return (a + math.pi) % (2.0 * math.pi) - math.pi


def intercept(d, u, speed, lead=1.0):
    """The unit direction to launch at `speed` (relative to the launcher) to meet a target at
    d (2,) moving at u (2,) relative to the launcher, on straight lines; d's own direction
    when the target cannot be caught. lead: the fraction of the target's motion until the
    meeting that is aimed ahead (1: the meeting point; 0: the target's position)."""
    a = portable.dot(u, u) - speed * speed
    b = 2.0 * portable.dot(d, u)
    c = portable.dot(d, d)
    t = -1.0
    if abs(a) < 1e-12:
        t = -c / b if b < 0 else -1.0
    else:
        disc = b * b - 4.0 * a * c
        if disc >= 0.0:
            roots = ((-b - math.sqrt(disc)) / (2 * a), (-b + math.sqrt(disc)) / (2 * a))
            positive = [r for r in roots if r > 0]
            t = min(positive) if positive else -1.0
    aim = d + lead * u * t if t > 0 else d
    norm = math.hypot(*aim)
    return aim / norm if norm > 0 else np.array([1.0, 0.0])


class Pilot:
    """Flies `ship` for `mode` (a game Mode: its World and steer()): keeps out of the bodies of
    kinds `hazards`, turns to where its weapon would meet the target and fires when on aim.

    weapon : a MissileSpec (guided ones are launched at the target and steer themselves;
    unguided ones are aimed ahead of it); reload [time] between launches, salvo missiles a
    launch fanned `spread` [rad] apart, at most `magazine` of its missiles alive; range
    [length] it fires from, closing in under thrust from beyond `approach` x range;
    lookahead [time] of the path it checks for hazards. Unguided weapons: `lead` (intercept's)
    and `tolerance` [rad] of the aim it fires at. delay [time] before its first launch (its
    reaction). clear: (a body id, a distance): it keeps its orbit's pericentre about that body
    beyond the distance (a straight-line shapecast misses a fall that gravity bends)."""

    def __init__(self, mode, ship, weapon, *, hazards=("star", "planet"), reload=0.5, salvo=1,
                 spread=0.0, magazine=8, range=400.0, lookahead=1.5, approach=0.6, lead=1.0,
                 tolerance=0.08, delay=0.0, clear=None):
        self.mode, self.ship, self.weapon = mode, ship, weapon
        self.hazards = [k for k in hazards if k in mode.world.kinds]
        self.reload, self.salvo, self.spread = reload, salvo, spread
        self.magazine, self.range, self.lookahead = magazine, range, lookahead
        self.approach, self.lead, self.tolerance, self.clear = approach, lead, tolerance, clear
        self.guided = weapon.guidance != "none"
        self.next_launch = mode.world.t + delay
        self.missiles = []

    def _offset(self, d):
        """d made the shortest way round a periodic box."""
        mode, lo, hi, _ = self.mode.world.boundary
        if mode == "periodic":
            size = (hi - lo)[:d.size]
            d = d - size * np.round(d / size)
        return d

    @staticmethod
    def look(pilots):
        """What each pilot's ship would meet of its hazards over its lookahead (one batched
        w.shapecast for all: a query costs its call, not its rays): a list of RayHits rows
        (None for a ship that is gone or at rest), for fly(..., hit=)."""
        if not pilots:
            return []
        w = pilots[0].mode.world
        flying = [p for p in pilots if p.ship in w and p.hazards]
        out = {}
        if flying:
            rows = [w.index_of(p.ship) for p in flying]
            move = w.vel[rows] * np.array([[p.lookahead] for p in flying])
            moving = np.flatnonzero(np.abs(move).sum(axis=1) > 0)
            if moving.size:
                hits = w.shapecast([flying[k].ship for k in moving], move[moving],
                                   kinds=flying[0].hazards, walls=False)
                out = {id(flying[k]): hits[q] for q, k in enumerate(moving)}
        return [out.get(id(p)) for p in pilots]

    def fly(self, target, hit=False):
        """One frame: the ship's controls, and launches at `target` (an id, or None); returns
        the ids launched. hit : this ship's row of Pilot.look (False: look alone)."""
        w = self.mode.world
        ship = self.ship
        if ship not in w:
            return []
        i = w.index_of(ship)
        p, v = w.pos[i].copy(), w.vel[i].copy()
        heading = w.heading(ship)
        aim, thrust = None, 0.0
        if hit is False:
            hit = Pilot.look([self])[0]
        if hit is not None and hit.ids.size:        # falling into something: climb out
            away = hit.normals[0] + v / portable.norm(v)     # (the normal points away)
            aim = portable.atan2(away[1], away[0])
            thrust = 1.0
        elif self.clear is not None:
            aim = self._climb(p, v)
            thrust = 0.0 if aim is None else 1.0
        launched = []
        if target is not None and target in w:
            j = w.index_of(target)
            d = self._offset(w.pos[j] - p)
            dist = math.hypot(*d)
            if self.guided:
                to = d / dist if dist > 0 else np.array([1.0, 0.0])
            else:
                to = intercept(d, w.vel[j] - v, self.weapon.launch_speed, self.lead)
            want = portable.atan2(to[1], to[0])
            if aim is None:
                aim = want
                thrust = 1.0 if dist > self.approach * self.range and \
                    abs(_wrap_angle(want - heading)) < 0.4 else 0.0
            on_aim = abs(_wrap_angle(want - heading)) < (0.5 if self.guided else self.tolerance)
            self.missiles = [m for m in self.missiles if m in w]
            if on_aim and dist < self.range and w.t >= self.next_launch and \
                    len(self.missiles) + self.salvo <= self.magazine:
                for k in range(self.salvo):
                    fan = heading + (k - (self.salvo - 1) / 2) * self.spread
                    launched.append(self.mode.fire(ship, self.weapon,
                                                   target=target if self.guided else None,
                                                   heading=fan))
                launched = [m for m in launched if m is not None]   # None: sent, not yet made
                self.missiles += launched
                self.next_launch = w.t + self.reload
        if aim is None:
            self.mode.steer(ship, 0.0, 0.0)
        else:
            self.mode.steer(ship, thrust, float(np.clip(3.0 * _wrap_angle(aim - heading),
                                                        -1.0, 1.0)))
        return launched

    def _climb(self, p, v):
        """The heading to burn along when falling towards `clear`'s body on an orbit whose
        pericentre is within its distance (along the orbit, and out): None when it is not."""
        w = self.mode.world
        body, distance = self.clear
        if body not in w:
            return None
        j = w.index_of(body)
        r, u = self._offset(p - w.pos[j]), v - w.vel[j]
        if portable.dot(r, u) >= 0.0 or w.elements(self.ship, about=body).pericentre >= distance:
            return None
        out = r / portable.norm(r)
        along = u - portable.dot(u, out) * out          # the velocity across the radius
        norm = portable.norm(along)
        along = along / norm if norm > 1e-9 else np.array([-out[1], out[0]])
        away = along + 0.3 * out
        return portable.atan2(away[1], away[0])

    def transfer(self, radius, about=None):
        """Plan a Hohmann transfer to a circular orbit of `radius` (sp.hohmann, flown by the
        World's autopilot); returns the burns."""
        burns = sp.hohmann(self.mode.world, self.ship, radius, about=about)
        self.mode.world.plan(self.ship, burns)
        return burns

    def match(self, target, gain=0.5):
        """Turn against the velocity relative to `target` and burn it off (proportionally,
        so it ends gently); returns that relative speed."""
        w = self.mode.world
        i, j = w.index_of(self.ship), w.index_of(target)
        rel = w.vel[i] - w.vel[j]
        speed = math.hypot(*rel)
        if speed < 1e-3:
            self.mode.steer(self.ship, 0.0, 0.0)
            return speed
        want = portable.atan2(-rel[1], -rel[0])
        err = _wrap_angle(want - w.heading(self.ship))
        throttle = float(min(1.0, gain * speed)) if abs(err) < 0.2 else 0.0
        self.mode.steer(self.ship, throttle, float(np.clip(3.0 * err, -1.0, 1.0)))
        return speed
