"""Every integer code the kernels and the Python side share, each defined once with its name.

No meaning is carried by numeric order: code that asks "does this response remove a body"
asks it of a set (REMOVING), not of a range.
"""

# (the gravity models' codes live with their accelerations and potentials, in forces.py)

# collision responses, the kind x kind matrix (kernels/responses.py)
IGNORE, SENSOR, ELASTIC, BOUNCE, MERGE = 0, 1, 2, 3, 4
DESTROY_A, DESTROY_B, DESTROY_BOTH = 5, 6, 7
BREAK_A, BREAK_B = 8, 9          # a bounce, then the first (second) body is destroyed
RESPONSES = {"ignore": IGNORE, "sensor": SENSOR, "elastic": ELASTIC, "bounce": BOUNCE,
             "merge": MERGE, "destroy_a": DESTROY_A, "destroy_b": DESTROY_B,
             "destroy_both": DESTROY_BOTH, "break_a": BREAK_A, "break_b": BREAK_B}
# (a, b) -> (b, a): what a response set for kinds (A, B) means for the pair seen as (B, A)
MIRRORED = {DESTROY_A: DESTROY_B, DESTROY_B: DESTROY_A, BREAK_A: BREAK_B, BREAK_B: BREAK_A}
# responses that end a body at first touch: bodies already overlapping meet at once
TOUCH_ENDS = (MERGE, DESTROY_A, DESTROY_B, DESTROY_BOTH)
# responses that reflect velocities
REFLECTING = (ELASTIC, BOUNCE, BREAK_A, BREAK_B)

# world boundaries
OPEN, REFLECT, PERIODIC = 0, 1, 2
BOUNDARIES = {"open": OPEN, "reflect": REFLECT, "periodic": PERIODIC}

# wall rows: [type, x0, y0, z0, x1, y1, z1, restitution]; a plane through (x0, y0, z0) with unit
# normal (x1, y1, z1) toward the side bodies live on, or a segment from point 0 to point 1
PLANE, SEGMENT = 0, 1

# event kinds (the `kind` field of spacephys.EVENT_DTYPE)
EV_BOUNCE, EV_MERGE, EV_DESTROY, EV_SENSOR_BEGIN, EV_WALL = 1, 2, 3, 4, 5
EV_LAUNCH, EV_BURNOUT, EV_FUEL_EMPTY, EV_DETONATION, EV_EXPIRY = 6, 7, 8, 9, 10
EV_SENSOR_END, EV_CONTACT_BEGIN, EV_CONTACT_END = 11, 12, 13
EV_TETHER_BREAK = 14
EV_SOI_ENTER, EV_SOI_EXIT = 15, 16
EVENT_KINDS = {EV_BOUNCE: "bounce", EV_MERGE: "merge", EV_DESTROY: "destroy",
               EV_SENSOR_BEGIN: "sensor_begin", EV_WALL: "wall", EV_LAUNCH: "launch",
               EV_BURNOUT: "burnout", EV_FUEL_EMPTY: "fuel_empty",
               EV_DETONATION: "detonation", EV_EXPIRY: "expiry",
               EV_SENSOR_END: "sensor_end", EV_CONTACT_BEGIN: "contact_begin",
               EV_CONTACT_END: "contact_end", EV_TETHER_BREAK: "tether_break",
               EV_SOI_ENTER: "soi_enter", EV_SOI_EXIT: "soi_exit"}

# missile guidance laws (kernels/control.py)
NO_GUIDANCE, PURSUIT, PROPORTIONAL = 0, 1, 2
GUIDANCE = {"none": NO_GUIDANCE, "pursuit": PURSUIT, "pn": PROPORTIONAL}

# planned burns' directions (kernels/control.py): along a fixed vector, or relative to the
# burn's frame body: its velocity, the orbit's normal r x v, r's part normal to v
BURN_VECTOR, BURN_PROGRADE, BURN_RETROGRADE, BURN_NORMAL, BURN_ANTINORMAL = 0, 1, 2, 3, 4
BURN_RADIAL_IN, BURN_RADIAL_OUT = 5, 6
BURN_DIRECTIONS = {"vector": BURN_VECTOR, "prograde": BURN_PROGRADE,
                   "retrograde": BURN_RETROGRADE, "normal": BURN_NORMAL,
                   "antinormal": BURN_ANTINORMAL, "radial_in": BURN_RADIAL_IN,
                   "radial_out": BURN_RADIAL_OUT}

# what a contact, and the collision pass of a step, did (kernels/responses.py, collide.py):
# nothing; changed velocities only; removed or merged bodies away. Ordered: a pass reports
# the most any of its contacts did
UNTOUCHED, DEFLECTED, BODIES_GONE = 0, 1, 2

# how the broad phase's grid takes a body (kernels/broadphase.py, spacephys/collisions.py):
# left out (a giant, or of a kind that meets giants only), entered in every cell its box
# covers, or entered only in the cells an IN_GRID body covers (it meets none of its own)
OUT_OF_GRID, IN_GRID, FOLLOWS = 0, 1, 2

# what a step kernel's call reports, as bits of its status
REMOVED = 1        # bodies were destroyed or merged: the call stopped so World can catch up
NONFINITE = 2      # a position or velocity is NaN or infinite after the call
FAILED = 4         # the integrator gave up (a Kepler solve, a Gauss-Radau step below the
                   # clock's resolution): the state is that after the steps it reports done
