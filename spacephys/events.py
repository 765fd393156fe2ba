"""What happened during a step: the event dtype and the names of its kinds (the codes are
defined once, in kernels/codes.py)."""
import numpy as np

from .kernels.codes import EVENT_KINDS
from .kernels.codes import EV_BOUNCE as BOUNCE, EV_MERGE as MERGE, EV_DESTROY as DESTROY
from .kernels.codes import EV_SENSOR_BEGIN as SENSOR_BEGIN, EV_SENSOR_END as SENSOR_END
from .kernels.codes import EV_CONTACT_BEGIN as CONTACT_BEGIN, EV_CONTACT_END as CONTACT_END
from .kernels.codes import EV_WALL as WALL, EV_LAUNCH as LAUNCH
from .kernels.codes import EV_BURNOUT as BURNOUT, EV_FUEL_EMPTY as FUEL_EMPTY
from .kernels.codes import EV_DETONATION as DETONATION, EV_EXPIRY as EXPIRY
from .kernels.codes import EV_TETHER_BREAK as TETHER_BREAK
from .kernels.codes import EV_SOI_ENTER as SOI_ENTER, EV_SOI_EXIT as SOI_EXIT

__all__ = ["EVENT_DTYPE", "EVENT_KINDS", "upgrade", "BOUNCE", "MERGE", "DESTROY", "SENSOR_BEGIN",
           "SENSOR_END", "CONTACT_BEGIN", "CONTACT_END", "WALL", "LAUNCH", "BURNOUT",
           "FUEL_EMPTY", "DETONATION", "EXPIRY", "TETHER_BREAK", "SOI_ENTER", "SOI_EXIT",
           "kind_name"]

EVENT_DTYPE = np.dtype([
    ("kind", np.int16),          # one of EVENT_KINDS
    ("a", np.int64),             # id of the first body (the survivor of a merge)
    ("b", np.int64),             # id of the second body; -1 for a wall or a boundary
    ("time", np.float64),        # simulation time of the contact [time]
    ("t_in_step", np.float64),   # time since the start of its step [time]
    ("x", np.float64), ("y", np.float64), ("z", np.float64),       # contact point [length]
    ("nx", np.float64), ("ny", np.float64), ("nz", np.float64),    # unit normal, from a to b
    ("speed", np.float64),       # closing speed along the normal [length/time]
    ("energy_lost", np.float64),  # kinetic energy the response removed [mass length^2/time^2]
    ("distance", np.float64),    # centre distance at the event: r_a + r_b at a contact, the
                                 # radius at a wall, the miss distance of a detonation [length]
    # who a and b were, read while they were alive (a destroyed body's too): kind codes
    # (names in World.kinds; -1 for no body) and the game's tags (World.tags; 0 for none)
    ("kind_a", np.int16), ("kind_b", np.int16),
    ("tag_a", np.int64), ("tag_b", np.int64),
    # which circle of a compound body (World.shape: the index into its Circles) touched, at a
    # contact of a compound body; -1 for a round body, a wall, or an event of no contact
    ("circle_a", np.int16), ("circle_b", np.int16),
])
"""One record per event; the id fields are generational ids as in World.ids.

Per kind: a collision (bounce, merge, destroy, wall) as described above; sensor_begin and
sensor_end: a sensor pair starts or stops overlapping, contact_begin and contact_end: an
elastic or bounce pair starts or stops resting in contact (docs/guide/collisions.md, "Begin
and end": at the moment, the point on a's surface, normal a -> b, speed the closing speed);
launch: a the missile, b its launcher, the point where it appeared; burnout (the burn time
ended) and fuel_empty: a the ship or missile, b = -1, at the moment it happened; detonation:
a the missile, b its target, the point the missile was at, normal toward the target, closing
speed, distance the miss distance; expiry: a the body whose lifetime ended; tether_break:
a and b the tether's ends (World.tether's a, b), at the end of the step whose tension passed
its break_force, the point midway, normal a -> b, speed the ends' separating speed,
energy_lost the spring energy it held, distance the ends' distance; soi_enter and soi_exit
(World.coast): a the coasting body, b the body whose sphere of influence it entered or left,
at the time it crossed the sphere, the point a was at, normal toward b, speed their relative
speed, distance the sphere's radius."""


# the fields events had before they named their bodies' kinds and tags, and their circles
# (run logs and state files written then hold these alone)
FIRST_FIELDS = EVENT_DTYPE.names[:EVENT_DTYPE.names.index("kind_a")]


def upgrade(events):
    """(E,) EVENT_DTYPE from events of this or an earlier EVENT_DTYPE (a state file's or a
    run log's, matched by field name): kinds and circles -1 and tags 0 where it has none."""
    events = np.asarray(events)
    if events.dtype == EVENT_DTYPE:
        return events.reshape(-1)
    out = np.zeros(events.size, EVENT_DTYPE)
    out["kind_a"] = out["kind_b"] = out["circle_a"] = out["circle_b"] = -1
    for name in events.dtype.names or ():
        out[name] = events[name].reshape(-1)
    return out


def kind_name(code):
    return EVENT_KINDS[int(code)]
