"""Record a match, replay it bit for bit, and read the log back: a scripted duel of two
ships around a planet (controls and torpedo launches are the inputs), recorded into an HDF5
run log, re-run from the log by sp.replay, then read with sp.open_run as a match viewer
would.

    python examples/replay_match.py [run.h5]       # default: a temporary file

A log of a real match holds the players' inputs the same way: the calls, at their steps.
"""
import math
import sys
import tempfile
from collections import Counter
from pathlib import Path

import spacephys as sp

path = sys.argv[1] if len(sys.argv) > 1 else str(Path(tempfile.mkdtemp()) / "match.h5")

w = sp.World(dim=2, dt=1 / 60, seed=42)                   # the seed fixes every explosion
w.add_body(2e5, (0, 0), radius=25, kind="planet", fixed=True)
w.set_collision("missile", "ship", "destroy_both")
w.set_collision("*", "planet", "destroy_a")
hull = sp.ShipSpec(dry_mass=2, fuel_mass=1, max_thrust=30, exhaust_speed=500, turn_rate=2,
                   radius=4, explosion=sp.ExplosionSpec(count=30, speed=20, lifetime=1.5))
torpedo = sp.MissileSpec(mass=0.05, fuel_mass=0.05, thrust=4, exhaust_speed=300,
                         guidance="pn", turn_rate=3, launch_speed=60, lifetime=6,
                         arming_delay=0.2, radius=1)
v = math.sqrt(2e5 / 150)                                  # circular at r = 150
alpha = w.add_ship(hull, (-150, 0), (0, -v), heading=-math.pi / 2)
omega = w.add_ship(hull, (150, 0), (0, v), heading=math.pi / 2)

# Record every 6th step as a frame; inputs and events are recorded whatever `every` is.
with w.record(path, every=6):
    for frame in range(60 * 10):                          # ten seconds of play
        for ship, enemy, turn in ((alpha, omega, 0.5), (omega, alpha, 0.3)):
            if ship not in w or enemy not in w:           # the match is over
                continue
            if frame % 60 == 0:                           # a new command once a second
                w.control(ship, throttle=0.3 if frame % 120 else 0.0, turn=turn)
            if frame % 90 == 45:
                w.launch(ship, torpedo, target=enemy)
        w.step(1)
    survivors = [name for name, s in (("alpha", alpha), ("omega", omega)) if s in w]
# leaving the block closes the log: a last frame and checkpoint, the state replay ends on

# Replay: a fresh World from the log's first checkpoint, the same calls at the same steps,
# every frame, every event and the final state compared bit for bit.
result = sp.replay(path)
print(f"replay: {'identical' if result.ok else 'DIFFERENT'} ({result.message})")

with sp.open_run(path) as run:                            # lazy: reads only what is asked
    print(f"log: {len(run)} frames from t = {run.frame(0).t:.3f} to t = {run.frame(-1).t:.3f}")
    calls = Counter(entry["call"] for entry in run.inputs())
    print("inputs:", ", ".join(f"{n} {call}" for call, n in sorted(calls.items())))
    kinds = Counter(sp.EVENT_KINDS[k] for k in run.events()["kind"].tolist())
    print("events:", ", ".join(f"{n} {kind}" for kind, n in sorted(kinds.items())))
    track = run.trajectory(omega)                         # (t, pos, vel, alive) per frame
    last = track.t[track.alive][-1]                       # the last frame it was in
    print(f"omega: in {track.alive.sum()} of {len(run)} frames, last seen at t = {last:.3f}; "
          f"survivors: {', '.join(survivors) or 'none'}")
