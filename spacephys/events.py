"""What happened during a step: the event dtype and the names of its kinds."""
import numpy as np

# event kinds (the `kind` field); later issues add launch, burnout, detonation...
BOUNCE, MERGE, DESTROY, SENSOR, WALL = 1, 2, 3, 4, 5
EVENT_KINDS = {BOUNCE: "bounce", MERGE: "merge", DESTROY: "destroy", SENSOR: "sensor",
               WALL: "wall"}

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
])
"""One record per event; the id fields are generational ids as in World.ids."""


def kind_name(code):
    return EVENT_KINDS[int(code)]
