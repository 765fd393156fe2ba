"""`spacephys bench netplay`: what rollback costs a game.

The rollback of a late input: restore the snapshot of 8 frames ago and step those 8 frames
again (each frame: both players' inputs applied, 2 steps, a snapshot), in the game's duel
and its arena, beside the same 8 frames stepped once (what a frame costs without netplay);
and the frame time (Session.advance: the frame, the rollbacks it triggers, the packets) of
two sessions on loopback UDP at 100 ms one way, 20 ms jitter, 60 frames a second.
"""
import math
import time

import numpy as np

from . import header, title

ROLLBACK = 8                 # frames re-stepped: the session's default window


def _rollback(name, quick):
    """Best seconds of: 8 frames stepped (inputs, steps, a snapshot each), and a restore
    followed by the same 8 frames (a rollback), alternated."""
    from ..game.modes import autoplay
    from ..netplay import Inputs
    mode = autoplay(name, 120 if quick else 400, seed=5)   # torpedoes and debris flying
    w = mode.world
    steps = max(1, round(mode.frame_time / w.dt))
    ships = [int(i) for i in w.actor_ids if w.is_ship(i)][:2]
    inputs = []
    for f in range(ROLLBACK):
        inp = Inputs()
        for k, ship in enumerate(ships):
            inp.control(ship, throttle=(f + k) % 2 * 1.0, turn=0.5 - k)
        inputs.append(inp)

    def frames():
        for inp in inputs:
            w.snapshot()
            inp.apply(w)
            w.step(steps)

    start = w.snapshot()
    best = {"frames": math.inf, "rollback": math.inf}
    for _ in range(5 if quick else 25):
        w.restore(start)
        t0 = time.perf_counter()
        frames()
        t1 = time.perf_counter()
        w.restore(start)
        frames()
        t2 = time.perf_counter()
        best["frames"] = min(best["frames"], t1 - t0)
        best["rollback"] = min(best["rollback"], t2 - t1)
    return {"mode": name, "bodies": w.n, "steps_per_frame": steps,
            "frames_s": best["frames"], "rollback_s": best["rollback"],
            "goal_s": 1.5e-3 if name == "duel" else None}


def _latency(quick, latency=0.1, jitter=0.02):
    """Two duel sessions on loopback at `latency` one way: each advance()'s time."""
    from ..netplay import Channel, Conditions, Session
    from ..game.duel import Duel
    frames = 180 if quick else 1200
    modes = [Duel(players=0, seed=7) for _ in range(2)]
    a = Channel(0, None, conditions=Conditions(latency, jitter, 0.0, seed=1))
    b = Channel(0, ("127.0.0.1", a.port), conditions=Conditions(latency, jitter, 0.0, seed=2))
    spec = modes[0].torpedo
    sessions = [Session(m.world, k, c, specs=(spec,))
                for k, (m, c) in enumerate(zip(modes, (a, b)))]
    modes[0].world.digest()            # its kernel loaded before the sessions' are timed
    times, done = [], [0, 0]
    tick = time.perf_counter()
    try:
        while min(done) < frames:
            for k, s in enumerate(sessions):
                if done[k] >= frames:
                    continue
                inp = s.input()
                ship = 1 + k
                inp.control(ship, throttle=(done[k] // 30 + k) % 2 * 1.0,
                            turn=((done[k] // 20 + k) % 3 - 1) * 1.0)
                if done[k] % 45 == 20 * k:
                    inp.launch(ship, spec, heading=None)
                t0 = time.perf_counter()
                stepped = s.advance(inp)
                if stepped:
                    times.append(time.perf_counter() - t0)
                    done[k] += 1
            tick += 1 / 60
            pause = tick - time.perf_counter()
            if pause > 0:
                time.sleep(pause)
        while not all(s.done() for s in sessions):
            for s in sessions:
                s.tick()
            time.sleep(0.002)
        same = sessions[0].world.digest() == sessions[1].world.digest()
    finally:
        a.close()
        b.close()
    t = 1e3 * np.array(times)
    stats = [s.stats for s in sessions]
    return {"latency_ms": 1e3 * latency, "jitter_ms": 1e3 * jitter, "frames": frames,
            "median_ms": float(np.median(t)), "p95_ms": float(np.percentile(t, 95)),
            "max_ms": float(t.max()), "rollbacks": sum(s["rollbacks"] for s in stats),
            "frames_resimulated": sum(s["frames_resimulated"] for s in stats),
            "waits": sum(s["waits"] for s in stats),
            "ping_ms": stats[0]["ping_ms"], "same_digest": bool(same)}


def netplay_bench(quick=False):
    """The rollback benchmark (see the module)."""
    return {**header("netplay", quick, None),
            "rollback": [_rollback("duel", quick), _rollback("arena", quick)],
            "latency": _latency(quick)}


def format_netplay(r):
    ms = lambda s: f"{s * 1e3:.3f} ms"
    lines = [title(r), "",
             f"| mode | bodies | {ROLLBACK} frames stepped | restore + the same {ROLLBACK} "
             f"frames (a rollback) | goal |", "|---|---|---|---|---|"]
    for c in r["rollback"]:
        goal = f"<= {ms(c['goal_s'])}" if c["goal_s"] else "-"
        lines.append(f"| {c['mode']} ({c['steps_per_frame']} steps a frame) | {c['bodies']} | "
                     f"{ms(c['frames_s'])} | {ms(c['rollback_s'])} | {goal} |")
    lat = r["latency"]
    lines += ["", f"two duel sessions on loopback, {lat['latency_ms']:.0f} ms one way "
              f"(+- {lat['jitter_ms']:.0f} ms), {lat['frames']} frames each at 60 Hz: "
              f"advance() median {lat['median_ms']:.3f} ms, p95 {lat['p95_ms']:.3f} ms, "
              f"max {lat['max_ms']:.3f} ms; {lat['rollbacks']} rollbacks re-stepping "
              f"{lat['frames_resimulated']} frames, {lat['waits']} waits for the window, "
              f"ping {lat['ping_ms']:.0f} ms; the same final digest: {lat['same_digest']}"]
    return "\n".join(lines)
