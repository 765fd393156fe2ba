"""Orbit: a ship about a planet with a moon, steered by its predicted path (w.predict: the
path, its apsides, the closest approach to a station to rendezvous with, the moon's sphere of
influence entered and left), a HUD of its orbital elements, fuel and delta-v, and time warp
from x1 to x10^6. The moon and the station are on rails and the ship coasts on patched conics
whenever it does not thrust (coast="auto"), so time passes in jumps at any warp; while it
thrusts, the integrator and step are what sp.recommend measures for warps up to x1000, and
beyond that the warp is capped to the frame's steps (the HUD says so)."""
import math
import queue
import threading
import time

import numpy as np

import spacephys as sp
from spacephys import portable

from .modes import Mode, orbit_speed
from .pilot import Pilot

PLANET_MASS, PLANET_RADIUS = 4e5, 40.0       # G = 1
SHIP_ORBIT, STATION_ORBIT, MOON_ORBIT, MOON_RADIUS = 120.0, 200.0, 600.0, 12.0
WARPS = (1, 10, 100, 1000, 10 ** 4, 10 ** 5, 10 ** 6)
MEASURED = 1000            # the warps up to this one have their integrator measured...
ERROR = 1e-6               # ...at the orbit error sp.recommend is asked for...
SESSION = 60.0             # ...over this much play [s of wall time] at that warp
FRAME_BUDGET = 2e-3        # [s] of physics a frame (spacephys bench play)
RENDEZVOUS = (8.0, 1.0)    # within this distance and relative speed of the station
HORIZON = 2000.0           # the longest prediction [time]: 2 moon orbits


def _circular(w, mass, distance, angle, **kw):
    """A body on a circular orbit of `distance` about the planet, `angle` [rad] along it."""
    v = orbit_speed(PLANET_MASS, distance)
    return w.add_body(mass, (distance * portable.cos(angle), distance * portable.sin(angle)),
                      (-v * portable.sin(angle), v * portable.cos(angle)), **kw)


class Orbit(Mode):
    name = "orbit"
    players_allowed = (0, 1)
    keys = (("W", "thrust"), ("A D", "turn"), (", .", "time warp"),
            ("H", "Hohmann transfer to the station's orbit"), ("M", "match its velocity"),
            ("Z", "zoom"), ("esc", "quit"))

    def build(self):
        w = sp.World(dim=2, dt=1 / 60, integrator="leapfrog", seed=self.seed, coast="auto")
        self.planet = w.add_body(PLANET_MASS, (0, 0), radius=PLANET_RADIUS, kind="planet",
                                 fixed=True)
        self.moon = _circular(w, 2e3, MOON_ORBIT, 0.0, radius=MOON_RADIUS, kind="moon")
        w.add_kind("station")
        self.station = _circular(w, 0.0, STATION_ORBIT, math.radians(100), radius=4,
                                 kind="station")
        w.set_rails(self.moon, self.planet)
        w.set_rails(self.station, self.planet)
        self.hull = sp.ShipSpec(dry_mass=10, fuel_mass=5, max_thrust=20, exhaust_speed=100,
                                turn_rate=2, radius=3)
        v = orbit_speed(PLANET_MASS, SHIP_ORBIT)
        self.start_state = ((SHIP_ORBIT, 0.0), (0.0, v), math.pi / 2)
        self.ship = w.add_ship(self.hull, *self.start_state)
        w.set_collision("ship", "planet", "destroy_a")
        w.set_collision("ship", "moon", "destroy_a")
        self.prediction = None
        self._pending = None               # the prediction running on its thread
        self._predicted = -10              # the frame it started
        self.met = False
        self.choices = {}                  # warp -> sp.Recommendation, once measured
        self._requested = set()
        self.wanted = 1
        self.zoomed = False                # the view: the whole system, or (Z) the ship's
        return w

    def start(self):
        self.pilot = Pilot(self, self.ship, sp.MissileSpec(mass=0.01), hazards=("planet",))
        self.planned = False
        self._asked = queue.Queue()
        self._chooser = None
        if self.watching:                  # a replay: the recording holds the warps chosen
            return
        # sp.recommend measures on a copy for seconds (x1: 2-5 s, x1000: about a minute): on
        # a thread, while the game runs (the kernels release the GIL), each warp the first
        # time it is asked for; until then the HUD says so and the warp stays
        # measured with the ship integrated, as it flies when it thrusts: coasting, any
        # step would do
        copy = self.world.copy()
        copy.coast_auto = False
        if len(copy.coasting):
            copy.coast(copy.coasting, False)
        self._chooser = threading.Thread(target=self._choose, args=(copy,), daemon=True)
        self._chooser.start()
        self._ask(1)

    def _ask(self, warp):
        if warp <= MEASURED and warp not in self.choices and warp not in self._requested:
            self._requested.add(warp)
            self._asked.put(warp)

    def _choose(self, copy):
        while (warp := self._asked.get()) is not None:
            self.choices[warp] = sp.recommend(
                copy, ERROR, budget=FRAME_BUDGET / (warp * self.frame_time),
                duration=SESSION * warp)

    def wait_for_choice(self, warp, timeout=None):
        """Ask for `warp` and block until sp.recommend has chosen for it (tests,
        benchmarks); whether it has."""
        self._ask(warp)
        deadline = None if timeout is None else time.monotonic() + timeout
        while warp not in self.choices and self._chooser.is_alive():
            if deadline is not None and time.monotonic() > deadline:
                break
            time.sleep(0.05)
        return warp in self.choices

    def close(self):
        """Stop the measuring thread: after the warp it is measuring, if any; the warps asked
        for after it are dropped."""
        if self._chooser is not None:
            while True:                    # the warps asked for and not yet begun: dropped
                try:
                    self._asked.get_nowait()
                except queue.Empty:
                    break
            self._asked.put(None)
            self._chooser.join()

    def adopt(self, ship):
        """A replayed new ship (after a crash): the one to follow."""
        self.ship = self.pilot.ship = ship

    def watch(self, world, events):
        """A replayed frame: followed as played, and the path ahead predicted as in play."""
        super().watch(world, events)
        if self.ship in world:
            self._predict()

    def _set_warp(self):
        if self.wanted > MEASURED:         # coasting jumps; thrust keeps the last steps
            self.warp = self.wanted
            return
        choice = self.choices.get(self.wanted)
        if choice is None or self.warp == self.wanted and self.world.dt == choice.dt:
            return
        w = self.world
        choice.apply(w)
        # the steps of a frame at this warp, and one more for the accumulator's remainder
        w.max_substeps = math.ceil(self.wanted * self.frame_time / w.dt) + 1
        self.warp = self.wanted

    def controls(self, held, pressed):
        w = self.world
        if "z" in pressed:
            self.zoomed = not self.zoomed
        if "." in pressed:
            self.wanted = WARPS[min(WARPS.index(self.wanted) + 1, len(WARPS) - 1)]
        if "," in pressed:
            self.wanted = WARPS[max(WARPS.index(self.wanted) - 1, 0)]
        self._ask(self.wanted)
        self._set_warp()
        if self.ship not in w:
            self.ship = w.add_ship(self.hull, *self.start_state)
            self.pilot.ship = self.ship
            self.planned = False
            self.message = "a new ship"
            return
        if self.players == 0:                              # the computer's flight
            if not self.planned:
                self.pilot.transfer(STATION_ORBIT)
                self.planned = True
            elif not w.planned(self.ship) and self._distance() < 40.0:
                self.pilot.match(self.station)
        else:
            if "h" in pressed:
                burns = self.pilot.transfer(STATION_ORBIT)
                self.message = (f"Hohmann transfer planned: burns at t = "
                                f"{burns[0].start:.1f} and {burns[1].start:.1f}")
            if "m" in held:
                self.pilot.match(self.station)
            elif not w.planned(self.ship):
                self.human(0, self.ship, held)
        self._predict()

    def _distance(self):
        w = self.world
        i, j = w.index_of(self.ship), w.index_of(self.station)
        return math.dist(w.pos[i], w.pos[j])

    def _predict(self):
        """The path ahead, on a worker thread (w.predict_async: the frame pays only for the
        state it takes, 0.2-1.3 ms, not the 1.5-10 ms of the prediction): the last one
        finished is drawn, a new one starts when it is done, at most every 10 frames."""
        w = self.world
        if self._pending is not None:
            if not self._pending.done():
                return
            self.prediction = self._pending.result()
            self._pending = None
        if self.frame - self._predicted < 10:
            return
        el = w.elements(self.ship, about=self.planet)
        horizon = min(1.2 * el.period, 200.0) if el.e < 1 else 60.0
        horizon = min(max(horizon, 3 * self.warp * self.frame_time), HORIZON)
        self._pending = w.predict_async(self.ship, horizon, points=240, target=self.station)
        self._predicted = self.frame

    def finish_prediction(self):
        """Wait for the prediction running, if any, and draw it (tests, screenshots)."""
        if self._pending is not None:
            self.prediction = self._pending.result()
            self._pending = None

    def after(self, events):
        w = self.world
        for e in events:
            if e["kind"] == sp.events.DESTROY and e["a"] == self.ship:
                self.message = f"the ship crashed at t = {e['time']:.1f}"
        if self.ship in w and not self.met:
            i, j = w.index_of(self.ship), w.index_of(self.station)
            speed = math.dist(w.vel[i], w.vel[j])
            if self._distance() < RENDEZVOUS[0] and speed < RENDEZVOUS[1]:
                self.met = True
                self.message = f"rendezvous with the station at t = {w.t:.1f}"

    def hud(self):
        w = self.world
        lines = [f"orbit  t = {w.t:9.1f}   warp x{self.warp}"
                 + ("" if self.wanted == self.warp else f" (x{self.wanted}: sp.recommend "
                                                         f"is measuring)")
                 + ("" if w.warp is None or w.warp.reason is None else
                    f" (x{w.warp.granted:.3g} granted: {w.warp.reason})")
                 + f"   {w.integrator}, dt {w.dt:.4g}"
                 + ("" if self.warp not in self.choices or self.choices[self.warp].met else
                    f" (the closest to {ERROR:g} within the frame budget: "
                    f"{self.choices[self.warp].error:.1g})")]
        if self.ship in w:
            el = w.elements(self.ship, about=self.planet)
            lines.append(f"from the planet's centre (radius {PLANET_RADIUS:.0f}): a {el.a:8.1f}"
                         f"   periapsis {el.pericentre:7.1f}   apoapsis {el.apocentre:7.1f}"
                         f"   e {el.e:.4f}   period {el.period:6.1f}")
            lines.append(f"fuel {w.fuel(self.ship):5.2f}   delta-v {w.delta_v(self.ship):6.2f}")
            line = f"station: distance {self._distance():7.1f}"
            if self.prediction is not None and self.prediction.approaches:
                a = self.prediction.approaches[0]
                line += f"   closest approach {a.distance:6.1f} in {a.t - w.t:6.1f}"
            lines.append(line)
        lines.append(self.message)
        return lines

    def overlay(self):
        p = self.prediction
        if p is None or self.ship not in self.world:
            return {"paths": [], "markers": []}
        markers = [(a.pos[:2], (255, 255, 120), "Pe" if a.kind == "pericentre" else "Ap")
                   for a in p.apsides]
        for a in p.approaches:
            k = min(range(len(p.t)), key=lambda q: abs(p.t[q] - a.t))
            markers.append((p.pos[0, k], (150, 255, 150), f"closest {a.distance:.1f}"))
        for e in p.events:                 # the moon's sphere of influence, entered and left
            if e["kind"] in (sp.events.SOI_ENTER, sp.events.SOI_EXIT) and e["a"] == self.ship:
                label = "SOI in" if e["kind"] == sp.events.SOI_ENTER else "SOI out"
                markers.append((np.array([e["x"], e["y"]]), (255, 170, 90), label))
        return {"paths": [(p.pos[0], (120, 160, 255))], "markers": markers}

    def camera(self, drawn):
        """Centred on the planet: the whole system, the moon's orbit in view; zoomed (Z), the
        ship's surroundings: the station's orbit, and the ship wherever it is."""
        w = self.world
        centre = drawn[w.index_of(self.planet)]
        if not self.zoomed:
            return centre, 1.1 * (MOON_ORBIT + MOON_RADIUS)
        reach = STATION_ORBIT
        if self.ship in w:
            reach = max(reach, math.dist(drawn[w.index_of(self.ship)], centre))
        return centre, 1.25 * reach
