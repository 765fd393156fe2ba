"""`spacephys bench fleet`: the fleet battle (scenes.fleet_battle) at 60 Hz, each step timed and
split into its parts, the game's fleet battle of heavybench.py, and the same gravity beside
REBOUND's leapfrog.
"""
import time

import numpy as np

from . import header, title
from . import rebound as peer
from .timing import per_step


def _fleet_split(w, repeats=5):
    """Milliseconds of each part of one step on w's current state (heavybench.split, best of
    repeats): gravity (one force evaluation: leapfrog makes one per step), guidance and
    thrust, and collisions (broad + narrow phase and responses)."""
    from .heavybench import split
    s = split(w, repeats)
    return {"gravity_ms": s["gravity_ms"], "guidance_ms": s["guidance_ms"],
            "collisions_ms": s["broad_ms"] + s["narrow_ms"] + s["responses_ms"]}


def fleet(quick=False):
    """The fleet battle (scenes.fleet_battle): 10 massive bodies, 200 ships, 2 000 guided
    missiles, 50 000 debris, collisions on, leapfrog at 60 Hz; milliseconds per step, split
    into gravity, guidance and collisions; and REBOUND's leapfrog on the same gravity alone
    (the 10 massive bodies as active particles, everything else as test particles)."""
    from ..scenes import fleet_battle
    rebound = peer.load()
    scale = 4 if quick else 1
    w = fleet_battle(ships=200 // scale, missiles=2000 // scale, debris=50_000 // scale)
    start = time.perf_counter()
    w.step(1)                                          # compile or load from the cache
    first = time.perf_counter() - start
    bodies = w.n
    w.step(4)
    steps = 30 if quick else 120
    w.copy().step(steps)               # untimed: the kernels of later events loaded first
    times = []
    splits = []
    for k in range(steps):
        if k % (steps // 3) == 0:
            splits.append(_fleet_split(w))
        start = time.perf_counter()
        w.step(1)
        times.append(time.perf_counter() - start)
    times = 1e3 * np.array(times)
    split = {key: float(np.median([s[key] for s in splits])) for key in splits[0]}
    # the same gravity without ships, missiles or collisions: spacephys and REBOUND leapfrog
    from ..world import World
    pulls = w.pulls
    plain = World(dim=2, G=w.G, dt=w.dt)
    plain.add_bodies(np.where(pulls, w.mass, 0.0), w.pos, w.vel)
    order = np.concatenate([np.flatnonzero(pulls), np.flatnonzero(~pulls)])
    ordered = World(dim=2, G=w.G, dt=w.dt)
    ordered.add_bodies(np.where(pulls, w.mass, 0.0)[order], w.pos[order], w.vel[order])
    sim = peer.simulation(ordered, "leapfrog", gravity="basic", n_active=int(pulls.sum()))
    massive = np.flatnonzero(pulls)
    plain.step(1)
    sim.steps(1)
    reps = 3 if quick else 5
    ours_ms = 1e3 * per_step(plain.step, 10, reps)
    rebound_ms = 1e3 * per_step(sim.steps, 10, reps)
    from .heavybench import fleet_game
    return {**header("fleet", quick, rebound), "game": fleet_game(quick),
            "bodies_start": bodies, "bodies_end": w.n, "massive": int(massive.size),
            "steps": steps, "first_step_s": first,
            "median_ms": float(np.median(times)), "p95_ms": float(np.percentile(times, 95)),
            "max_ms": float(times.max()), "split_ms": split,
            "gravity_only_ms": ours_ms, "rebound_gravity_only_ms": rebound_ms,
            "gravity_ratio": rebound_ms / ours_ms}


def format_fleet(results):
    """The report of `spacephys bench fleet` (text)."""
    from .heavybench import format_rows
    s = results["split_ms"]
    rest = results["median_ms"] - sum(s.values())
    return "\n".join([
        title(results),
        f"fleet battle: {results['bodies_start']} -> {results['bodies_end']} bodies "
        f"({results['massive']} massive), {results['steps']} steps of leapfrog at 60 Hz",
        f"one step: median {results['median_ms']:.2f} ms, 95th percentile "
        f"{results['p95_ms']:.2f} ms, max {results['max_ms']:.2f} ms (target 8 ms)",
        f"split: gravity {s['gravity_ms']:.2f} ms, guidance and thrust "
        f"{s['guidance_ms']:.2f} ms, collisions {s['collisions_ms']:.2f} ms, the rest "
        f"(integration, bookkeeping, explosions) {rest:.2f} ms",
        f"the same bodies under gravity alone (no ships, missiles or collisions), leapfrog: "
        f"spacephys {results['gravity_only_ms']:.2f} ms, REBOUND "
        f"{results['rebound_gravity_only_ms']:.2f} ms per step "
        f"({results['gravity_ratio']:.1f}x)", ""] + format_rows(
        f"the fleet battle as a game sets it up (10 planets, 200 ships, 2 000 missiles in "
        f"salvos, 50 000 debris, all destroying each other), {results['game']['steps']} "
        f"steps (goal: 95th percentile <= 8 ms, worst <= 16 ms, <= 1.5x with a core busy)",
        [(k, results["game"][k]) for k in ("quiet", "one core busy")]))
