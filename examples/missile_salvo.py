"""A salvo of guided missiles at a jinking target: four proportional-navigation (PN) missiles
fired a quarter second apart, fanned out so that they come at the target from different
sides; the events of the engagement as they happen, and how it ended.

    python examples/missile_salvo.py
"""
import math

import spacephys as sp

w = sp.World(dim=2, gravity="none", dt=1 / 60, seed=3)

red = w.add_ship(sp.ShipSpec(dry_mass=50, radius=4), (0, 0), heading=0.0)
blue = w.add_ship(sp.ShipSpec(dry_mass=5, fuel_mass=5, max_thrust=60, exhaust_speed=400,
                              turn_rate=1.5, radius=3,
                              explosion=sp.ExplosionSpec(count=40, speed=15, lifetime=2)),
                  (500, -200), (0, 40), heading=math.pi / 2)
names = {red: "red", blue: "blue"}

# PN steers to null the line of sight's rotation, so it leads a crossing target instead of
# chasing its tail. The fuse fires on the closest approach within a step: a missile passing
# between two frames still detonates. arming_delay keeps it from blowing up on the launcher.
# No missile-ship collision rule: the fuse does the killing (a destroy rule would take a
# missile that touches the hull within the step its fuse fires, with no detonation event).
seeker = sp.MissileSpec(mass=0.5, fuel_mass=1.0, thrust=40, exhaust_speed=250,
                        guidance="pn", nav_constant=4.0, turn_rate=2.5, launch_speed=40,
                        arming_delay=0.5, fuse_radius=4.0, lifetime=8, radius=0.5)
bearing = math.atan2(-200, 500)
fan = [-0.6, -0.2, 0.2, 0.6]                              # radians off the bearing
missiles, tally, killed_by = [], {}, None

for frame in range(60 * 12):
    t = frame / 60
    if frame % 15 == 0 and len(missiles) < len(fan) and blue in w:
        missiles.append(w.launch(red, seeker, target=blue, heading=bearing + fan[len(missiles)]))
        names[missiles[-1]] = f"missile {len(missiles)}"
    if blue in w:                                         # blue jinks every 1.5 s
        w.control(blue, throttle=1.0, turn=1.0 if int(t / 1.5) % 2 else -1.0)

    w.step(1)
    for e in w.events:
        a, b = names.get(int(e["a"])), names.get(int(e["b"]))
        if a is None:
            continue                                      # debris fading out
        kind = sp.EVENT_KINDS[e["kind"]]
        tally[kind] = tally.get(kind, 0) + 1
        line = f"t = {e['time']:6.3f}  {kind:<11} {a}"
        if e["kind"] == sp.events.LAUNCH:
            line += f" from {b}"
        elif e["kind"] == sp.events.DETONATION:           # kill_target: blue dies with it
            killed_by = f"{a} at t = {e['time']:.3f}"
            line += f" at {b}: miss distance {e['distance']:.3f}, closing speed {e['speed']:.1f}"
            line += f", {(w.kind == w.kind_code('debris')).sum()} debris thrown"
        print(line)
    if len(missiles) == len(fan) and not any(m in w for m in missiles):
        break                                             # every missile has gone

print("tally:", ", ".join(f"{n} {k}" for k, n in tally.items()))
if blue in w:
    print(f"result: blue survived with {w.fuel(blue):.2f} fuel left")
else:
    print(f"result: blue destroyed by {killed_by}")
