"""A World's state, defined once: every piece of it, where `World.state()` files it (the
format docs/runlog.md documents, version STATE_VERSION), and whether it moves.

A piece *moves* when steps or calls that keep the kernels' tables change it: the clock, the
bodies' columns, drag, the adaptive settings, the origin, queued launches, the pairs in touch,
the integrator's carried state. The others are the scene's *setup* (kinds, collision rules,
user forces and plans, the integrator, the seed...): changing one rebuilds the tables. So:

    state(w) / load(s)      every piece (World.state, World.from_state: files, checkpoints)
    Motion.take(w) / put(w) the moving pieces, into a World with the same setup: the copies a
                            prediction runs (predict.py) take them before each run, instead
                            of a new copy of the World
    Snapshot.take(w) / put  every piece, in memory, back into the same World (World.snapshot,
                            restore: rollback); the setup is taken once per change of a
                            setting (Setup) and shared by the snapshots taken until the next
    digest(w)               a 64-bit hash of every piece (World.digest)

A piece of World's own is one entry of WORLD (its key, whether it moves, how to read and set
it); a part of World (Bodies, ForceField, CollisionRules, Actors, the stepper) keeps its own
state and says which of it moves (`motion`, `set_motion`). World.copy() copies everything.
"""
import hashlib
import operator
import struct
from dataclasses import dataclass
from typing import Any, Callable

import numpy as np

from .collisions import CollisionRules
from .events import EVENT_DTYPE, upgrade
from .forces import ForceField
from .integrators import get_integrator
from .state import Bodies
from .steppers import stepper_for
from .units import get_units

STATE_VERSION = 2          # the version of World.state(), and of the files that hold it


@dataclass(frozen=True)
class Piece:
    """One piece of World's own state: get(w) -> its value (a copy), set(w, value); attr:
    the World's attribute that holds it, when it is one: a number, or an array (array)."""
    key: str
    moves: bool
    get: Callable[[Any], Any]
    set: Callable[[Any, Any], None]
    attr: str = None
    array: bool = False


def _events(w):
    return w._events[:w._event_count[0]].copy()


def _set_events(w, value):
    events = upgrade(value)
    w._events = np.zeros(max(256, 2 * events.size), EVENT_DTYPE)
    w._events[:events.size] = events
    w._event_count = np.array([events.size], np.int64)


def _set_integrator(w, name):
    w._spec = get_integrator(str(name))
    w._stepper = stepper_for(w._spec)


def _attr(name, convert):
    """get and set of the attribute `name`, set through `convert`; name."""
    return (lambda w: getattr(w, name)), (lambda w, v: setattr(w, name, convert(v))), name, \
        False


def _array(name):
    """get (a copy) and set of the float array `name`: in place when the World has it (its
    tables may share it), new in a World being made."""
    def set_(w, value):
        held = getattr(w, name, None)
        if held is None:
            setattr(w, name, np.array(value, np.float64))
        else:
            held[:] = value
    return (lambda w: getattr(w, name).copy()), set_, name, True


# World's own pieces, in the order from_state sets them (the integrator before the stepper's
# state, see PARTS)
WORLD = (
    Piece("dim", False, *_attr("_dim", int)),
    Piece("units", False, lambda w: w._units.name, lambda w, v: setattr(w, "_units",
                                                                      get_units(str(v)))),
    Piece("kinds", False, lambda w: list(w._kinds),
          lambda w, v: setattr(w, "_kinds", [str(k) for k in v])),
    Piece("integrator", False, lambda w: w._spec.name, _set_integrator),
    Piece("dt", True, *_attr("_dt", float)),
    Piece("t_base", True, *_attr("_t_base", float)),
    Piece("steps", True, *_attr("_steps", int)),
    Piece("accumulator", True, *_attr("_accumulator", float)),
    Piece("dropped_time", True, *_attr("_dropped", float)),
    Piece("max_substeps", False, *_attr("_max_substeps", int)),
    Piece("origin", True, *_array("_origin")),
    Piece("adaptive", True, *_array("_adaptive")),
    Piece("step_control", False, *_attr("_step_control", str)),
    Piece("threads", False, lambda w: w._threads.mode, lambda w, v: w._threads.set(str(v))),
    # the last call's events: what it reports, not state a step reads (the next call starts
    # afresh), so no copy takes them
    Piece("events", False, _events, _set_events),
)


def _watch(w):
    return {} if w._watch is None else dict(zip(("limit", "E0", "energies", "ids"), w._watch))


def _set_watch(w, s):
    w._watch = None if not s else (float(s["limit"]), float(s["E0"]),
                                   np.asarray(s["energies"], np.float64),
                                   np.asarray(s["ids"], np.int64))


# World's parts: the section of state() each fills, and how it is read and made again
PARTS = (
    ("bodies", lambda w: w._b.state(), lambda w, s: setattr(w, "_b", Bodies.from_state(s))),
    ("forces", lambda w: w._forces.state(),
     lambda w, s: setattr(w, "_forces", ForceField.from_state(w._dim, s))),
    ("collisions", lambda w: w._collisions.state(),
     lambda w, s: setattr(w, "_collisions", CollisionRules.from_state(s))),
    ("actors", lambda w: w._actors.state(), lambda w, s: w._actors.load(s)),
    ("stepper", lambda w: w._stepper.state(), lambda w, s: w._stepper.load(s)),
    ("watch", _watch, _set_watch),
)


def state(w):
    """The whole state of World w as named fields (dicts of arrays and numbers)."""
    s = {"version": STATE_VERSION, "world": {p.key: p.get(w) for p in WORLD}}
    for section, get, _ in PARTS:
        s[section] = get(w)
    return s


def load(w, s):
    """Set every piece of a bare World w (World.__new__, its transient attributes set) from
    state() s; ValueError for another version."""
    version = int(s.get("version", 1))
    if version != STATE_VERSION:
        raise ValueError(f"state version {version}: this spacephys reads version "
                         f"{STATE_VERSION}")
    for p in WORLD:
        p.set(w, s["world"][p.key])
    for section, _, set_ in PARTS:
        set_(w, s[section])


class Motion:
    """The moving state of a World: its moving pieces and its parts' (see the module), taken
    from one World and put into another with the same setup (the same bodies in the rows
    taken, the same tables)."""

    __slots__ = ("world", "bodies", "forces", "collisions", "actors", "carried")

    @classmethod
    def take(cls, w, rows=None, copy=True, carried=True):
        """w's moving state now: the bodies' columns of every row (or of `rows`, for a World
        holding just those bodies); copy=False: the World's own arrays where it can (to be
        put before w moves on); carried=False: not the integrator's carried state (a World
        with another integrator starts its own afresh)."""
        m = cls.__new__(cls)
        m.world = {p.key: p.get(w) for p in WORLD if p.moves}
        m.bodies = w._b.motion(rows, copy)
        m.forces = w._forces.motion()
        m.collisions = w._collisions.motion(w._plan)
        m.actors = w._actors.motion()
        m.carried = w._stepper.state() if carried else None
        return m

    def put(self, w):
        """Make World w's moving state this one (w's setup is the World's it was taken from:
        a change to its tables' setup would have made a new one)."""
        for p in WORLD:
            if p.moves:
                p.set(w, self.world[p.key])
        w._b.set_motion(self.bodies)
        held = w._forces.set_motion(self.forces)
        if not w._collisions.set_motion(self.collisions, w._plan) or not held:
            w._plan = None
        w._actors.set_motion(self.actors)
        if self.carried is None:
            w._stepper.reset(w)
        else:
            w._stepper.load(self.carried)


# ---------------------------------------------------------------- snapshots
MOVING = tuple(p for p in WORLD if p.moves)
# the moving numbers and arrays as World's attributes, read and set directly by snapshots and
# digest (a duel's rollback takes, restores and digests one every frame)
_NUMBERS = tuple(p.attr for p in MOVING if p.attr and not p.array)
_NUMBERS_FORMAT = "<%dd" % len(_NUMBERS)
_numbers = operator.attrgetter(*_NUMBERS)
_ARRAYS = tuple(p.attr for p in MOVING if p.array)
_OTHERS = tuple(p for p in MOVING if not p.attr)
# the settings a Setup keeps: the events are the last call's report, which a snapshot keeps
SETTINGS = tuple(p for p in WORLD if not p.moves and p.key != "events")


class Setup:
    """A World's setup (its settings, forces and collision rules but for their moving parts:
    drag and the pairs in touch) as it was when taken: what snapshots share until a setting
    changes (World._set_up)."""

    __slots__ = ("world", "forces", "user", "collisions", "hash")

    def __init__(self, w):
        self.world = {p.key: p.get(w) for p in SETTINGS}
        # the parts' states but for what moves (drag, the pairs in touch): a snapshot's own
        self.forces = {k: v for k, v in w._forces.state().items() if k != "drag"}
        self.user = [(fn, params.copy()) for fn, params in w._forces.user]
        self.collisions = {k: v for k, v in w._collisions.state().items() if k != "touching"}
        self.hash = None

    @classmethod
    def of(cls, w):
        """w's setup now: the one taken before if no setting changed since."""
        if w._setup is None:
            w._setup = cls(w)
        return w._setup

    def put(self, w):
        """Make w's settings, forces and collision rules these (their moving parts are the
        snapshot's to set); the tables will be built anew."""
        for p in SETTINGS:
            p.set(w, self.world[p.key])
        forces = ForceField.from_state(w._dim, dict(self.forces, drag=np.zeros(4),
                                                    user_functions=[], user_params=[]))
        forces.user = [(fn, params.copy()) for fn, params in self.user]
        w._forces = forces
        w._collisions = CollisionRules.from_state(self.collisions)
        w._setup = self
        w._plan = None

    def digest(self):
        """8 bytes hashing the setup (function forces by module and name), computed once."""
        if self.hash is None:
            h = hashlib.blake2b(digest_size=8)
            _feed(h, (self.world, self.forces, self.collisions))
            self.hash = h.digest()
        return self.hash


def _feed(h, value):
    """Hash `value` (dicts, sequences, arrays, numbers, text) into h, the same bytes on every
    machine."""
    if isinstance(value, dict):
        h.update(b"d%d" % len(value))
        for key in sorted(value):
            _feed(h, key)
            _feed(h, value[key])
    elif isinstance(value, (list, tuple)):
        h.update(b"l%d" % len(value))
        for item in value:
            _feed(h, item)
    elif isinstance(value, np.ndarray):
        h.update(b"a" + value.dtype.str.encode() + repr(value.shape).encode())
        h.update(np.ascontiguousarray(value).tobytes())
    elif isinstance(value, str):
        h.update(b"s%d:" % len(value) + value.encode())
    elif isinstance(value, (bool, np.bool_)):
        h.update(b"b1" if value else b"b0")
    elif isinstance(value, (int, np.integer)):
        h.update(b"i" + str(int(value)).encode())
    elif isinstance(value, (float, np.floating)):
        h.update(b"f" + struct.pack("<d", float(value)))
    elif value is None:
        h.update(b"n")
    else:                                   # a spec: its fields' exact repr
        h.update(b"r" + repr(value).encode())


_VERSION = []


def _version():
    if not _VERSION:
        from . import __version__   # the package's, set after its modules are imported
        _VERSION.append(__version__)
    return _VERSION[0]


class Snapshot:
    """World.snapshot(): every piece of one World's state, in memory, for World.restore.
    Opaque but for `t` (the World's time when taken) and `version` (spacephys's)."""

    __slots__ = ("owner", "version", "t", "setup", "plan", "events_buffer", "touch_buffer",
                 "block", "bodies", "numbers", "arrays", "others", "events", "drag", "touch",
                 "owners", "actors", "carried", "watch")

    def __reduce__(self):
        raise TypeError("a snapshot lives in memory, for the World it was taken of: "
                        "World.state() or World.save(path) give a state to keep or send")

    @classmethod
    def take(cls, w):
        s = cls.__new__(cls)
        s.owner, s.version, s.t = w._token, _version(), w.t
        s.setup = Setup.of(w)
        plan = s.plan = w._plan
        s.events_buffer, s.touch_buffer = w._events, w._collisions.touch
        s.block = w._b.block                 # the arrays the tables taken here point into
        s.bodies = w._b.snapshot()
        # World's moving pieces: its numbers in one call, copies of its arrays
        s.numbers = _numbers(w)
        s.arrays = [getattr(w, a).copy() for a in _ARRAYS]
        s.others = [p.get(w) for p in _OTHERS]
        # as bytes: numpy copies a structured array field by field (4 us for a few events)
        s.events = w._events[:w._event_count[0]].tobytes()
        s.drag = w._forces.motion()
        s.touch = w._collisions.touching()
        s.owners = None if plan is None or plan.owners is None else plan.owners.copy()
        s.actors = w._actors.snapshot()
        s.carried = w._stepper.state()
        s.watch = w._watch
        return s

    def put(self, w):
        """Make World w (the one taken from) as it was; checked before anything changes."""
        if self.version != _version():
            raise ValueError(f"restore: the snapshot was taken by spacephys "
                             f"{self.version}, this is {_version()}")
        if self.owner is not w._token:
            raise ValueError("restore: the snapshot was taken of another World (a snapshot "
                             "restores only the World it came from; copies and loaded "
                             "Worlds are others)")
        if w._log is not None:
            raise ValueError(f"restore: this World is being recorded into "
                             f"{w._log.path!r}, whose replay cannot jump back; record after "
                             f"the session, or record its inputs")
        same_setup = w._setup is self.setup
        if not same_setup:
            self.setup.put(w)
        in_place = w._b.restore(self.bodies)
        for name, value in zip(_NUMBERS, self.numbers):
            setattr(w, name, value)          # taken from w: of the types its pieces set
        for name, value in zip(_ARRAYS, self.arrays):
            np.copyto(getattr(w, name), value)
        for p, value in zip(_OTHERS, self.others):
            p.set(w, value)
        size = len(self.events)
        k = size // w._events.itemsize
        if k > w._events.size:
            WORLD[-1].set(w, np.frombuffer(self.events, w._events.dtype))
        else:
            if k:
                w._events.view(np.uint8)[:size] = np.frombuffer(self.events, np.uint8)
            w._event_count[0] = k
        held = w._forces.set_motion(self.drag)
        fits = w._collisions.set_touching(self.touch) and held
        w._actors.restore(self.actors)
        w._stepper.load(self.carried)
        w._watch = self.watch
        plan = self.plan
        # the tables taken with the snapshot hold views of these very arrays, unless the
        # bodies, the events or the pairs in touch moved to new ones since (a restore that
        # laid the bodies out anew gives them a new block, even in the snapshot's layout)
        if plan is not None and same_setup and in_place and fits and \
                w._b.block is self.block and w._events is self.events_buffer and \
                w._collisions.touch is self.touch_buffer:
            plan.alive[:] = True
            if self.owners is not None:
                plan.owners[:] = self.owners
            w._plan = plan
        else:
            w._plan = None


def digest(w):
    """A 64-bit hash of World w's whole state (an int in [0, 2**64)): the setup, the moving
    pieces, the events, the pairs in touch, the actors', the carried state, then the bodies'
    live rows and id slots (kernels/digest.py); equal states give equal digests on every
    machine."""
    h = hashlib.blake2b(Setup.of(w).digest(), digest_size=8)
    h.update(struct.pack(_NUMBERS_FORMAT, *_numbers(w)))
    for a in _ARRAYS:
        h.update(getattr(w, a))
    for p in _OTHERS:
        _feed(h, p.get(w))
    h.update(w._events[:w._event_count[0]])
    h.update(w._forces.drag)
    coasting = w._forces.rails.motion()
    if coasting is not None:
        _feed(h, coasting)
    h.update(w._collisions.touch[:w._collisions.ntouch[0]])
    w._actors.digest(h)
    carried = w._stepper.state()
    if carried:
        _feed(h, carried)
    if w._watch is not None:
        _feed(h, w._watch)
    return int(w._b.digest(h))
