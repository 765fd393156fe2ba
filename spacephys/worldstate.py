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

A piece of World's own is one entry of WORLD (its key, whether it moves, how to read and set
it); a part of World (Bodies, ForceField, CollisionRules, Actors, the stepper) keeps its own
state and says which of it moves (`motion`, `set_motion`). World.copy() copies everything.
"""
from dataclasses import dataclass
from typing import Any, Callable

import numpy as np

from .collisions import CollisionRules
from .events import EVENT_DTYPE
from .forces import ForceField
from .integrators import get_integrator
from .state import Bodies
from .steppers import stepper_for
from .units import get_units

STATE_VERSION = 2          # the version of World.state(), and of the files that hold it


@dataclass(frozen=True)
class Piece:
    """One piece of World's own state: get(w) -> its value (a copy), set(w, value)."""
    key: str
    moves: bool
    get: Callable[[Any], Any]
    set: Callable[[Any, Any], None]


def _events(w):
    return w._events[:w._event_count[0]].copy()


def _set_events(w, value):
    events = np.array(value, EVENT_DTYPE).reshape(-1)
    w._events = np.zeros(max(256, 2 * events.size), EVENT_DTYPE)
    w._events[:events.size] = events
    w._event_count = np.array([events.size], np.int64)


def _set_integrator(w, name):
    w._spec = get_integrator(str(name))
    w._stepper = stepper_for(w._spec)


def _attr(name, convert):
    """get and set of the attribute `name`, set through `convert`."""
    return (lambda w: getattr(w, name)), (lambda w, v: setattr(w, name, convert(v)))


def _array(name):
    """get (a copy) and set of the float array `name`: in place when the World has it (its
    tables may share it), new in a World being made."""
    def set_(w, value):
        held = getattr(w, name, None)
        if held is None:
            setattr(w, name, np.array(value, np.float64))
        else:
            held[:] = value
    return (lambda w: getattr(w, name).copy()), set_


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
        w._forces.set_motion(self.forces)
        if not w._collisions.set_motion(self.collisions, w._plan):
            w._plan = None
        w._actors.set_motion(self.actors)
        if self.carried is None:
            w._stepper.reset(w)
        else:
            w._stepper.load(self.carried)
