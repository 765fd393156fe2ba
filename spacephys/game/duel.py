"""Spacewar! (1962): two ships around a star that pulls them, torpedoes launched from the
moving ships (they keep the ship's velocity), collisions with the star and each other,
explosions into debris, space that wraps around. 2 players, 1 against the computer, or 0."""
import math

import numpy as np

import spacephys as sp

from .modes import KEYS, Mode, TEAM_COLOURS, orbit_speed
from .pilot import Pilot

HALF = 512.0                 # half the width of the wrapping square [length]
STAR_MASS = 4e6              # G = 1
RESPAWN = 2.0                # [time] a destroyed ship waits before it comes back
SIDES = ("needle", "wedge")


class Duel(Mode):
    name = "duel"
    keys = (("W / up", "thrust"), ("A D / left right", "turn"),
            ("space / return", "fire a torpedo"), ("esc", "quit"))

    def build(self):
        w = sp.World(dim=2, dt=1 / 120, max_substeps=8, seed=self.seed)   # 2 steps a frame
        w.set_boundary("periodic", lo=(-HALF, -HALF), hi=(HALF, HALF))
        self.star = w.add_body(STAR_MASS, (0, 0), radius=16, kind="star", fixed=True)
        for a, b in (("missile", "ship"), ("ship", "ship"), ("missile", "missile")):
            w.set_collision(a, b, "destroy_both")
        w.set_collision("*", "star", "destroy_a")             # whatever falls in is gone
        self.hull = sp.ShipSpec(dry_mass=1, fuel_mass=1, max_thrust=60, exhaust_speed=3000,
                                turn_rate=3, radius=10,
                                explosion=sp.ExplosionSpec(count=60, speed=60, lifetime=1.5,
                                                           lifetime_spread=0.5))
        self.torpedo = sp.MissileSpec(mass=0.01, launch_speed=220, lifetime=2.5, radius=2,
                                      arming_delay=0.2,
                                      explosion=sp.ExplosionSpec(count=8, speed=40,
                                                                 lifetime=0.6))
        v = orbit_speed(STAR_MASS, 300.0)                     # a circular orbit at r = 300
        self.starts = [((-300.0, 0.0), (0.0, -v), -math.pi / 2),
                       ((300.0, 0.0), (0.0, v), math.pi / 2)]
        self.ships = [w.add_ship(self.hull, *start) for start in self.starts]
        self.score = [0, 0]
        self.dead_since = [None, None]
        self.next_fire = [0.0, 0.0]
        return w

    def start(self):
        self.pilots = [None, None]
        for k in range(self.players, 2):                      # the computer flies the rest
            self.pilots[k] = self.make_pilot(k)

    def make_pilot(self, k):
        """The computer's pilot of side k: its reload, range, lead, aim, reaction and the
        distance it keeps from the star drawn from (the World's seed, k), so the two differ
        (identical pilots on the mirrored starts die together every round) and a seed always
        plays the same match; nothing is drawn later, so a rollback has nothing to restore."""
        rng = np.random.default_rng([self.seed, k])
        return Pilot(self, self.ships[k], self.torpedo, hazards=("star", "ship"),
                     reload=rng.uniform(0.3, 0.8), range=rng.uniform(300.0, 480.0),
                     approach=rng.uniform(0.4, 0.8), lead=rng.uniform(0.6, 1.0),
                     tolerance=rng.uniform(0.04, 0.12), delay=rng.uniform(0.2, 1.2),
                     clear=(self.star, rng.uniform(70.0, 110.0)))

    def controls(self, held, pressed):
        fresh = self.respawn()
        flying = [p for p in self.pilots if p is not None]
        hits = dict(zip(map(id, flying), Pilot.look(flying)))     # one shapecast for both
        for k in range(2):
            if k not in fresh:
                self.fly(k, held, hit=hits.get(id(self.pilots[k]), False))

    def respawn(self):
        """Bring back the ships destroyed RESPAWN ago; returns their sides."""
        w = self.world
        fresh = set()
        for k in range(2):
            if self._due(k):
                self._back(k, w.add_ship(self.hull, *self.starts[k]))
                fresh.add(k)
        return fresh

    def _due(self, k):
        """Whether side k's ship is gone and has waited RESPAWN."""
        w = self.world
        return self.ships[k] not in w and self.dead_since[k] is not None and \
            w.t - self.dead_since[k] >= RESPAWN

    def _back(self, k, ship):
        self.ships[k] = ship
        self.dead_since[k] = None
        if self.pilots[k] is not None:
            self.pilots[k] = self.make_pilot(k)

    def adopt(self, ship):
        """A replayed respawn: respawn() brings back the sides due, needle first."""
        self._back(next(k for k in range(2) if self._due(k)), ship)

    def fly(self, k, held, keys=None, hit=False):
        """Side k's controls this frame: its pilot's (hit: its row of Pilot.look, False: it
        looks alone), or the keys held (its player's, or `keys`)."""
        w = self.world
        ship = self.ships[k]
        if ship not in w:
            return
        if self.pilots[k] is not None:
            self.pilots[k].fly(self.ships[1 - k], hit=hit)
        elif self.human(k, ship, held, keys) and w.t >= self.next_fire[k]:
            self.fire(ship, self.torpedo)
            self.next_fire[k] = w.t + 0.25

    # ------------------------------------------------------------------ over the network
    specs = property(lambda self: (self.torpedo,))

    def net_frame(self, world, number, inputs):
        """A frame of a networked duel (netplay.Session's frame): ships back, both sides'
        inputs, two steps, the events scored."""
        self.respawn()
        for inp in inputs:
            inp.apply(world)
        world.step(round(self.frame_time / world.dt))
        self.after(world.events)

    def save(self):
        """The duel's own state, which a rollback restores with the World."""
        return (list(self.ships), list(self.score), list(self.dead_since), self.message,
                list(self.pilots))

    def load(self, saved):
        ships, score, dead, self.message, pilots = saved
        self.ships, self.score, self.dead_since, self.pilots = (list(ships), list(score),
                                                                list(dead), list(pilots))

    def after(self, events):
        lost = []                                            # the sides destroyed this frame
        for e in events:
            if e["kind"] != sp.events.DESTROY:
                continue
            for k in range(2):
                if self.ships[k] in (e["a"], e["b"]) and self.dead_since[k] is None:
                    self.dead_since[k] = float(e["time"])
                    self.score[1 - k] += 1
                    lost.append(k)
        if lost:                     # both, when both went (a ram, or torpedoes crossing)
            said = [(SIDES[k], f"t = {self.dead_since[k]:.2f}") for k in lost]
            if len(said) == 2 and said[0][1] == said[1][1]:
                self.message = f"{said[0][0]} and {said[1][0]} destroyed at {said[0][1]}"
            else:
                self.message = ", ".join(f"{name} destroyed at {at}" for name, at in said)

    def hud(self):
        who = ["computer" if p is not None else f"keys {KEYS[k]['thrust']}"
               for k, p in enumerate(self.pilots)]
        net = self.net
        if net is not None:
            who[net.other] = "the other player"
            who[net.player] = "computer" if self.pilots[net.player] is not None else \
                f"keys {KEYS[0]['thrust']}"
        lines = [f"Spacewar!  needle {self.score[0]} : {self.score[1]} wedge    "
                 f"t = {self.world.t:6.2f}", f"needle: {who[0]}   wedge: {who[1]}"]
        if net is not None:
            ping = net.stats["ping_ms"]
            lines.append(f"ping {'-' if ping is None else f'{ping:.0f}'} ms   rollbacks "
                         f"{net.stats['rollbacks']}" +
                         ("   waiting for the other player" if net.waiting else "") +
                         (f"   DESYNC at frame {net.desync}" if net.desync is not None
                          else ""))
        return lines + [self.message]

    def colour(self, body_id):
        if body_id in self.ships:
            return TEAM_COLOURS[self.ships.index(body_id)]
        return (240, 240, 200)                               # a torpedo
