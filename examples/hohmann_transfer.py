"""A Hohmann transfer flown by the autopilot: a ship on a circular orbit of radius 1 raises
it to radius 2 with two prograde burns half an ellipse apart. The plan is predicted first
(what a map screen would draw, with its apsides), then flown, and the orbit reached is
compared with the goal.

    python examples/hohmann_transfer.py
"""
import math

import numpy as np

import spacephys as sp

GOAL = 2.0
w = sp.World(dim=2, integrator="yoshida4", dt=5e-4)       # G = 1
planet = w.add_body(1.0, (0, 0), radius=0.1, kind="planet")
# the transfer's delta-v (0.284) takes 0.0057 of fuel at exhaust speed 50: 0.006 is enough
engine = sp.ShipSpec(dry_mass=1.0, fuel_mass=0.006, max_thrust=50.0, exhaust_speed=50.0)
ship = w.add_ship(engine, (1.0, 0.0), (0.0, 1.0), heading=math.pi / 2)   # circular, r = 1

# Two finite burns sized by this ship's engine and mass, each centred on the impulse it
# replaces. The autopilot flies them inside the step: heading held prograde about the
# planet, thrust switched on and off at the exact times within steps.
burns = sp.hohmann(w, ship, GOAL, about=planet)
for k, b in enumerate(burns, 1):
    print(f"burn {k}: t = {b.start:.4f} for {b.duration:.5f}, {b.direction}")

# A map screen, the first burn alone: the transfer ellipse, whose apocentre is on the goal
# orbit, half an orbit on, where the second burn is centred.
w.plan(ship, burns[:1])
apo = next(a for a in w.predict(ship, 8.0, points=400).apsides if a.kind == "apocentre")
print(f"first burn alone: apocentre r = {apo.distance:.6f} at t = {apo.t:.4f} "
      f"(burn 2 centred at t = {burns[1].start + burns[1].duration / 2:.4f})")

# The whole plan, past the second burn and one orbit on. The prediction steps a copy of the
# World with the same integrator and dt: the path the ship will fly, bit for bit.
w.plan(ship, burns)
steps = round((burns[1].stop + 2 * math.pi * GOAL ** 1.5 - w.t) / w.dt)
pred = w.predict(ship, steps * w.dt, points=1001)
for a in pred.apsides[:2]:
    print(f"whole plan: {a.kind:<10} r = {a.distance:.6f} at t = {a.t:.4f}")

fuel0 = w.fuel(ship)
w.step(steps)                                             # fly it: no input needed
el = w.elements(ship, about=planet)
path = pred.path(ship)[0]
r_path = np.linalg.norm(path[pred.t > burns[1].stop], axis=1)

print(f"fuel burned {fuel0 - w.fuel(ship):.6f} of {fuel0:.6f}")
print(f"prediction vs flight: {np.abs(path[-1] - w.pos[w.index_of(ship)]).max():.3g} apart")
print(f"goal radius {GOAL}: reached a = {el.a:.6f}, e = {el.e:.2e}, "
      f"r from {r_path.min():.6f} to {r_path.max():.6f} over the last orbit")
