"""A hitscan laser: a ray cast from a ship's nose along its heading hits the nearest body in
its way; that body is removed, and the next shot goes on to the one behind it, until a wall
stops it.

    python examples/laser.py
"""
import math

import numpy as np

import spacephys as sp

AIM = math.radians(30)                                    # the gunship's heading
RANGE = 1000.0


def on_line(s, side):
    """The point s along the firing line from the origin, `side` to its left."""
    return (s * math.cos(AIM) - side * math.sin(AIM), s * math.sin(AIM) + side * math.cos(AIM))


w = sp.World(dim=2, gravity="none")
gunship = w.add_ship(sp.ShipSpec(dry_mass=10, radius=5), (0, 0), heading=AIM)
names = {gunship: "gunship"}
rocks = {"aside": (on_line(40, -30), 6),                  # the nearest rock, but off the line
         "first": (on_line(150, 0), 10),
         "grazed": (on_line(220, 3.5), 4),                # its edge pokes 0.5 over the line
         "behind": (on_line(300, 0), 20)}
for name, (pos, radius) in rocks.items():
    names[w.add_body(1.0, pos, radius=radius, kind="asteroid")] = name
w.add_segment(on_line(400, -50), on_line(400, 50))        # a wall across the line


def fire(ship):
    """One shot along the ship's heading: (body id or "wall", distance, point), or None."""
    angle = w.heading(ship)                               # 2D: an angle (3D: a unit vector)
    aim = np.array([math.cos(angle), math.sin(angle)])
    # from the ship's centre: a ray that starts inside a body meets it at distance 0, so the
    # ship leaves itself out
    ray = w.raycast(w.pos[w.index_of(ship)], aim, RANGE, ignore=ship)   # a batch of one ray
    if not ray.hit[0]:
        return None
    what = int(ray.body[0]) if ray.body[0] >= 0 else "wall"   # a wall: ray.wall[0] says which
    return what, float(ray.distance[0]), ray[0].points[0]


for shot in range(1, 6):
    result = fire(gunship)
    if result is None:
        print(f"shot {shot}: nothing within {RANGE:.0f}")
        break
    what, distance, point = result
    print(f"shot {shot}: hit {names.get(what, what)} at distance {distance:.6f}, "
          f"point ({point[0]:.6f}, {point[1]:.6f})")
    if what == "wall":
        break
    w.remove(what)                                        # vaporised; its id is never reused

print("rocks left:", ", ".join(names[i] for i in w.ids.tolist() if i != gunship))
