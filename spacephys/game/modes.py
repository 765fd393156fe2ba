"""What every game mode has: a World, the ships its players and the computer fly, the keys,
the HUD and the camera. The modes themselves: duel.py, orbit.py, arena.py; `Watch` draws a
World it is given (a replay)."""
import math

import numpy as np

# the keys of the two players on one keyboard (pygame's key names)
KEYS = ({"thrust": "w", "left": "a", "right": "d", "fire": "space"},
        {"thrust": "up", "left": "left", "right": "right", "fire": "return"})
TEAM_COLOURS = ((90, 200, 255), (255, 120, 90))


class Mode:
    """A game mode. Subclasses set `name`, build their World in `build()` and fly it in
    `controls()` (before each frame's physics) and `after()` (its events, after it).

    world : the World; warp : simulated time per frame over frame_time; message : a line
    the HUD shows (the last thing that happened)."""
    name = ""
    frame_time = 1 / 60                 # [time] simulated per frame at warp 1
    keys = ()                           # (key, what it does), for the help line and docs
    players_allowed = (0, 1, 2)

    def __init__(self, players=1, seed=0, watching=False):
        if players not in self.players_allowed:
            raise ValueError(f"players = {players!r}: {self.name} takes "
                             f"{', '.join(map(str, self.players_allowed))}")
        self.players = players
        self.seed = seed
        self.watching = watching        # a replay: the recording makes every call, not the mode
        self.frame = 0
        self.warp = 1
        self.message = ""
        self._held = {}                 # ship id -> (throttle, turn) last given to control()
        self.world = self.build()
        self.start()

    @property
    def command(self):
        """The command line that plays this match (kept with its recording, so that a
        replay draws it as this mode)."""
        return f"spacephys play {self.name} --players {self.players} --seed {self.seed}"

    # ------------------------------------------------------------------ subclasses
    def build(self):
        """The mode's World, its bodies and rules."""
        raise NotImplementedError

    def start(self):
        """After build(), with self.world set: the computer's pilots."""

    def controls(self, held, pressed):
        """This frame's inputs: held, pressed (sets of key names: down now, went down now)."""

    def after(self, events):
        """This frame's events (the World's, after its steps)."""

    def hud(self):
        """Lines of text for the top-left corner."""
        return [f"{self.name}  t = {self.world.t:7.2f}", self.message]

    def overlay(self):
        """What to draw over the bodies: {"paths": [((P, 2) positions, colour)],
        "markers": [((2,) position, colour, label)]}."""
        return {"paths": [], "markers": []}

    def camera(self, drawn):
        """(centre (2,), half height) of the view, given the drawn positions (n, 2): the
        wrapping box, or every body but debris about the origin (spacephys.draw.framing)."""
        from ..draw import framing
        return framing(self.world, drawn)

    def colour(self, body_id):
        """The colour of a ship or missile: its side's."""
        return TEAM_COLOURS[0]

    def flames(self):
        """The ids of the ships and missiles whose engine is lit (for the flames): read from
        the World, so that a replay shows them too."""
        w = self.world
        return w.ids[w.engines_lit]

    def adopt(self, ship):
        """A replay re-ran the add_ship of a ship this mode brought back (a respawn): take it
        as the mode's own (the mode made no call itself)."""

    def watch(self, world, events):
        """A replay re-ran a frame of this mode's recording in `world`: follow it (its events
        into after(), the frame counted) as if the mode had played it."""
        self.world = world
        self.after(events)
        self.frame += 1

    # ------------------------------------------------------------------ helpers
    # a netplay.Inputs that takes this frame's control() and launch() calls instead of the
    # World, in a game played over the network (loop.play with a session)
    outbox = None
    net = None                          # the netplay Session, in a game over the network

    def steer(self, ship, throttle, turn):
        """w.control(ship, ...) only when the command changes (each call is a journal entry
        when recorded, and costs a microsecond or two)."""
        if self._held.get(ship) != (throttle, turn):
            if self.outbox is None:
                self.world.control(ship, throttle=throttle, turn=turn)
            else:
                self.outbox.control(ship, throttle=throttle, turn=turn)
            self._held[ship] = (throttle, turn)

    def fire(self, ship, spec, target=None, heading=None):
        """w.launch(ship, spec, ...): the missile's id, or None when it goes into the
        outbox (over the network it is launched when the frame is stepped)."""
        if self.outbox is not None:
            self.outbox.launch(ship, spec, target, heading)
            return None
        return self.world.launch(ship, spec, target=target, heading=heading)

    def human(self, player, ship, held, keys=None):
        """Player's keys (KEYS[player], or `keys`) to the ship's controls; True if fire is
        held."""
        k = KEYS[player] if keys is None else keys
        turn = (1.0 if k["left"] in held else 0.0) - (1.0 if k["right"] in held else 0.0)
        self.steer(ship, 1.0 if k["thrust"] in held else 0.0, turn)
        return k["fire"] in held


class Watch(Mode):
    """A World to look at, with nobody flying it (a replay): the camera on the periodic box
    or on the bodies that are not debris."""
    name = "replay"
    players_allowed = (0,)

    def __init__(self, world):
        self._world = world
        self._ships = None              # ((t, n), ship ids in row order) of the frame drawn
        super().__init__(players=0)

    def build(self):
        return self._world

    def colour(self, body_id):
        w = self.world
        if self._ships is None or self._ships[0] != (w.t, w.n):   # once a frame, not a body
            ship = w.kind == w.kind_code("ship") if "ship" in w.kinds else np.zeros(w.n, bool)
            self._ships = ((w.t, w.n), w.ids[ship].tolist())
        ships = self._ships[1]
        return TEAM_COLOURS[ships.index(body_id) % 2] if body_id in ships else (230, 230, 230)


def orbit_speed(mu, r):
    """The circular speed at distance r about mu = G M."""
    return math.sqrt(mu / r)


def make_mode(name, players=1, seed=0, watching=False):
    """The mode called `name` ("duel", "orbit", "arena"); watching: to follow a replay of
    its recording (Mode.watch)."""
    if name not in MODES:
        raise ValueError(f"mode = {name!r}: choose one of {', '.join(MODES)}")
    module, cls = MODES[name]
    import importlib
    return getattr(importlib.import_module(f".{module}", __package__), cls)(players, seed,
                                                                            watching)


def mode_of(command):
    """(name, players, seed) from a Mode.command line, or None for any other text."""
    words = command.split()
    if len(words) != 7 or words[:2] != ["spacephys", "play"] or words[2] not in MODES or \
            words[3] != "--players" or words[5] != "--seed":
        return None
    try:
        return words[2], int(words[4]), int(words[6])
    except ValueError:
        return None


MODES = {"duel": ("duel", "Duel"), "orbit": ("orbit", "Orbit"), "arena": ("arena", "Arena")}


def autoplay(name, frames, seed=0):
    """The mode `name` with the computer flying every ship, played `frames` frames of its
    frame_time (no window, no pygame): for benchmarks that want a game in full swing."""
    mode = make_mode(name, players=0, seed=seed)
    w = mode.world
    for _ in range(frames):
        mode.controls(set(), set())
        w.advance(mode.frame_time)
        mode.after(w.events)
    return mode
