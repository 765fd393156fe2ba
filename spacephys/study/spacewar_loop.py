import math
import time

import spacephys as sp

# Spacewar! (1962): two ships around a star that pulls them, torpedoes, a screen that wraps
w = sp.World(dim=2, dt=1 / 120, max_substeps=4)          # 120 Hz physics, 60 Hz frames
w.set_boundary("periodic", lo=(-512, -512), hi=(512, 512))
w.add_body(4e6, (0, 0), radius=16, kind="star", fixed=True)
w.set_collision("missile", "ship", "destroy_both")
w.set_collision("ship", "ship", "destroy_both")
w.set_collision("*", "star", "destroy_a")                 # whatever falls in is gone
hull = sp.ShipSpec(dry_mass=1, fuel_mass=1, max_thrust=60, exhaust_speed=3000,
                   turn_rate=3, radius=10)
torpedo = sp.MissileSpec(mass=0.01, launch_speed=220, lifetime=2.5, radius=2,
                         arming_delay=0.2)
v = math.sqrt(4e6 / 300)                                  # a circular orbit at r = 300
starts = {"needle": ((-300, 0), (0, -v), -math.pi / 2), "wedge": ((300, 0), (0, v), math.pi / 2)}
ships = {name: w.add_ship(hull, *start) for name, start in starts.items()}
score = {"needle": 0, "wedge": 0}

start = time.perf_counter()
for frame in range(1200):                                 # 20 s of play at 60 frames/s
    for name, turn in (("needle", 0.6), ("wedge", -0.4)):  # two scripted players
        ship = ships[name]
        if ship not in w:                                 # destroyed: the next round
            ships[name] = ship = w.add_ship(hull, *starts[name])
        w.control(ship, throttle=1.0 if frame % 90 < 30 else 0.0,
                  turn=turn if frame % 120 < 60 else -turn)
        if frame % 20 == 0:
            w.launch(ship, torpedo)
    alpha = w.advance(1 / 60)
    draw = w.interpolate(alpha)                           # where to draw everything now
    for e in w.events:
        for name, ship in ships.items():
            if e["kind"] == sp.events.DESTROY and e["a"] == ship:
                other = "wedge" if name == "needle" else "needle"
                score[other] += 1
ms = 1e3 * (time.perf_counter() - start) / 1200
print(f"1200 frames: {ms:.3f} ms per frame, {w.n} bodies now; score {score}")
