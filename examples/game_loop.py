"""A fixed-step game loop: physics at a steady 120 Hz whatever the frame rate, drawn between
the last two physics states, events read once a frame.

    python examples/game_loop.py

No window here: every 150th frame prints what a renderer would be handed, then a summary.
The scene: a planet, a ring of rocks (some too slow to stay up) and a ship circling.
"""
import math

import numpy as np

import spacephys as sp

w = sp.World(dim=2, dt=1 / 120, max_substeps=8, seed=1)   # at most 8 steps (1/15 s) a frame
w.add_body(1e4, (0, 0), radius=20, kind="planet", fixed=True)
w.set_collision("asteroid", "planet", "destroy_a")        # a rock that falls in is gone

rng = np.random.default_rng(1)
r, phi = rng.uniform(60, 300, 200), rng.uniform(0, 2 * math.pi, 200)
speed = np.sqrt(1e4 / r) * rng.uniform(0.2, 1.0, 200)     # below circular: the slowest fall
pos = np.c_[r * np.cos(phi), r * np.sin(phi)]
vel = np.c_[-speed * np.sin(phi), speed * np.cos(phi)]
w.add_bodies(0.0, pos, vel, radius=2.0, kind="asteroid")
ship = w.add_ship(sp.ShipSpec(dry_mass=1, radius=3), (100, 0), (0, 10), heading=math.pi / 2)

# A real loop measures the frame time (time.perf_counter()); here it is made up: about 60
# frames a second with some jitter, and every 200th frame a hitch of a quarter second.
frames, played, steps_taken, n0 = 600, 0.0, [], w.n
alpha_lo, alpha_hi, fallen = 1.0, 0.0, 0
for frame in range(frames):
    frame_time = 0.25 if frame % 200 == 199 else rng.uniform(0.7, 1.3) / 60
    played += frame_time

    t0 = w.t
    alpha = w.advance(frame_time)          # takes the whole steps that fit; alpha: the rest
    steps_taken.append(round((w.t - t0) / w.dt))
    alpha_lo, alpha_hi = min(alpha_lo, alpha), max(alpha_hi, alpha)

    # Draw between the last two states, never the raw ones: a 60 Hz screen showing 120 Hz
    # physics (or a 144 Hz one showing it) would otherwise stutter. Rows match w.ids now.
    draw = w.interpolate(alpha)
    ship_on_screen = draw[w.index_of(ship)]

    for e in w.events:                     # all events of this frame's steps
        if e["kind"] == sp.events.DESTROY:
            fallen += 1                    # a renderer would put a flash at (e["x"], e["y"])

    if frame % 150 == 0:
        print(f"frame {frame:3d}: {w.n} bodies, {steps_taken[-1]} steps, alpha {alpha:.3f}, "
              f"ship drawn at ({ship_on_screen[0]:.2f}, {ship_on_screen[1]:.2f})")

steps = np.array(steps_taken)
print(f"frames {frames}, played {played:.4f} s, simulated {w.t:.4f} s, "
      f"dropped {w.dropped_time:.4f} s")
print(f"steps {steps.sum()} in all, {steps.min()} to {steps.max()} per frame")
print(f"alpha from {alpha_lo:.3f} to {alpha_hi:.3f}")
print(f"rocks fallen into the planet: {fallen}; bodies {n0} -> {w.n}")
