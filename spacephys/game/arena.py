"""Arena: ten ships in two sides about a planet, each flown by the computer (or one by the
player), firing salvos of guided (PN) missiles at the nearest enemy (w.nearest); missiles
and ships explode into debris, which fall onto the planet or fade. Hundreds of missiles and
thousands of debris at once."""
import math

import numpy as np

import spacephys as sp
from spacephys import portable

from .modes import Mode, TEAM_COLOURS, orbit_speed
from .pilot import Pilot

HALF = 1500.0                # half the width of the wrapping square [length]
PLANET_MASS = 2e6            # G = 1
SHIPS = 10
RESPAWN = 3.0                # [time]


class Arena(Mode):
    name = "arena"
    players_allowed = (0, 1)
    keys = (("W", "thrust"), ("A D", "turn"), ("space", "fire a salvo"), ("esc", "quit"))

    def build(self):
        w = sp.World(dim=2, dt=1 / 60, max_substeps=4, seed=self.seed)
        w.set_boundary("periodic", lo=(-HALF, -HALF), hi=(HALF, HALF))
        self.planet = w.add_body(PLANET_MASS, (0, 0), radius=60, kind="planet", fixed=True)
        w.set_collision("missile", "ship", "destroy_both")
        w.set_collision("ship", "ship", "destroy_both")
        w.set_collision("*", "planet", "destroy_a")
        self.hull = sp.ShipSpec(dry_mass=10, fuel_mass=10, max_thrust=300, exhaust_speed=2000,
                                turn_rate=3, radius=8,
                                explosion=sp.ExplosionSpec(count=300, speed=60, lifetime=8.0,
                                                           lifetime_spread=0.5))
        self.warhead = sp.MissileSpec(mass=0.2, fuel_mass=0.3, thrust=60, exhaust_speed=400,
                                      guidance="pn", turn_rate=4, launch_speed=40,
                                      lifetime=8.0, arming_delay=0.4, fuse_radius=10,
                                      radius=1.5,
                                      explosion=sp.ExplosionSpec(count=40, speed=40,
                                                                 lifetime=5.0,
                                                                 lifetime_spread=0.5))
        self.rng = np.random.default_rng(self.seed)
        self.side = {}                                   # ship id -> 0 or 1
        self.slots = [None] * SHIPS                      # slot -> ship id
        self.dead_since = [None] * SHIPS
        self.kills = [0, 0]
        for k in range(SHIPS):
            self._spawn(w, k)
        return w

    def start(self):
        self.pilots = [None] * SHIPS
        for k in range(SHIPS):
            if not (self.players == 1 and k == 0):
                self.pilots[k] = self._pilot(k)

    def _spawn(self, w, k):
        """Slot k's ship on a circular orbit (side 0 one way round, side 1 the other)."""
        r = self.rng.uniform(300.0, 900.0)
        a = self.rng.uniform(-math.pi, math.pi)
        v = orbit_speed(PLANET_MASS, r) * (1 if k % 2 == 0 else -1)
        c, s = portable.cos(a), portable.sin(a)
        pos, vel = (r * c, r * s), (-v * s, v * c)
        ship = w.add_ship(self.hull, pos, vel, heading=a + math.copysign(math.pi / 2, v))
        self.slots[k] = ship
        self.side[ship] = k % 2
        return ship

    def adopt(self, ship):
        """A replayed respawn: controls() brings back, slot by slot in order, the ships
        due."""
        k = next(k for k in range(SHIPS) if self._due(k))
        self.slots[k] = ship
        self.side[ship] = k % 2
        self.dead_since[k] = None

    def _due(self, k):
        """Whether slot k's ship is gone and waited long enough to come back."""
        return self.slots[k] not in self.world and self.dead_since[k] is not None and \
            self.world.t - self.dead_since[k] >= RESPAWN

    def _pilot(self, k):
        return Pilot(self, self.slots[k], self.warhead, hazards=("planet",), reload=0.6,
                     salvo=4, spread=0.5, magazine=40, range=1200.0)

    def _enemies(self):
        """{ship: the nearest ship of the other side, or None}, for every live ship: one
        batched w.nearest over the ships."""
        w = self.world
        ships = [s for s in self.slots if s in w]
        if not ships:
            return {}
        ids, _ = w.nearest(w.pos[[w.index_of(s) for s in ships]], k=SHIPS, kinds=["ship"])
        out = {}
        for q, ship in enumerate(ships):
            out[ship] = next((int(o) for o in ids[q] if o >= 0 and o != ship and
                              self.side.get(int(o)) != self.side[ship]), None)
        return out

    def controls(self, held, pressed):
        w = self.world
        enemies = self._enemies()
        flying = [p for p in self.pilots if p is not None]
        hits = dict(zip(map(id, flying), Pilot.look(flying)))
        for k in range(SHIPS):
            ship = self.slots[k]
            if ship not in w:
                if self._due(k):
                    self._spawn(w, k)
                    self.dead_since[k] = None
                    if self.pilots[k] is not None:
                        self.pilots[k] = self._pilot(k)
                continue
            if self.pilots[k] is not None:
                self.pilots[k].fly(enemies[ship], hit=hits.get(id(self.pilots[k])))
            else:                                        # the player: slot 0
                fire = self.human(0, ship, held)
                enemy = enemies[ship]
                if fire and "space" in pressed and enemy is not None:
                    for j in range(4):
                        w.launch(ship, self.warhead, target=enemy,
                                 heading=w.heading(ship) + (j - 1.5) * 0.5)

    def after(self, events):
        for e in events:
            if e["kind"] != sp.events.DESTROY:
                continue
            for k in range(SHIPS):
                ship = self.slots[k]
                if ship in (e["a"], e["b"]) and self.dead_since[k] is None:
                    self.dead_since[k] = float(e["time"])
                    self.kills[1 - self.side[ship]] += 1

    def hud(self):
        w = self.world
        count = np.bincount(w.kind, minlength=len(w.kinds)) if w.n else np.zeros(len(w.kinds))
        n = {name: int(count[w.kind_code(name)]) for name in ("ship", "missile", "debris")}
        return [f"arena  t = {w.t:7.2f}   blue {self.kills[0]} : {self.kills[1]} red",
                f"ships {n['ship']}   missiles {n['missile']}   debris {n['debris']}"]

    def colour(self, body_id):
        side = self.side.get(body_id)
        return TEAM_COLOURS[side] if side is not None else (255, 255, 200)
