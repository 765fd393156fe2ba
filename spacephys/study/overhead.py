"""`spacephys bench overhead`: what a game pays per call, beside REBOUND in the same run.

Per-call costs (best of alternating repeats of many calls): step(1) and advance(1/60) on two
bodies against REBOUND's sim.steps(1); a duel (a fixed star, two ships with held controls,
collisions on): step(1) and control(), and step(1) with compound hulls (three circles a ship)
against the round duel's; leapfrog batched in one call on 2 to 5 bodies;
snapshot + restore and digest of the game's duel and of 10 000 bodies (against REBOUND's
sim.copy()); the
Spacewar! loop of docs/guide/game-loop.md, run as pasted; threads beside two busy processes; a jitted user force
against REBOUND's Python callback. The start and what it compiles: `spacephys bench compile`.
"""
import math
import re
import subprocess
import sys
import time
from importlib import resources

import numpy as np

from . import header
from . import rebound as peer

def _per_call(calls, repeats, count):
    """Best seconds per call of each function in calls (a dict), run in turn, `count` calls a
    repeat: a disturbance of the machine hits every one alike."""
    best = {name: math.inf for name in calls}
    for _ in range(repeats):
        for name, call in calls.items():
            start = time.perf_counter()
            for _ in range(count):
                call()
            best[name] = min(best[name], (time.perf_counter() - start) / count)
    return best


def _two_bodies(dt):
    from ..world import World
    w = World(dim=2, dt=dt)
    w.add_body(1.0, (0.0, 0.0), kind="star")
    w.add_body(1e-3, (1.0, 0.0), (0.0, 1.0), kind="planet")
    return w


# a long hull of three circles, as long as the round hull is wide (the same bounding radius)
HULL = ((1.4, 0.0), (0.0, 0.0), (-1.4, 0.0)), (0.6, 0.8, 0.6)


def _duel(compound=False):
    """A fixed star, two ships with held controls, collisions on (2D, 120 Hz); compound:
    each ship's hitbox the three circles of HULL."""
    from ..entities import Circles, ShipSpec
    from ..world import World
    w = World(dim=2, dt=1 / 120)
    w.add_body(1e4, (0.0, 0.0), radius=10.0, kind="star", fixed=True)
    shape = dict(shape=Circles(*HULL)) if compound else dict(radius=2.0)
    hull = ShipSpec(dry_mass=1.0, fuel_mass=1e6, max_thrust=1.0, exhaust_speed=1e9,
                    turn_rate=2.0, **shape)
    v = math.sqrt(1e4 / 100.0)
    a = w.add_ship(hull, (100.0, 0.0), (0.0, v), heading=math.pi / 2)
    b = w.add_ship(hull, (-100.0, 0.0), (0.0, -v), heading=-math.pi / 2)
    w.control(a, throttle=0.5, turn=0.1)
    w.control(b, throttle=0.3, turn=-0.1)
    w.set_collision("ship", "star", "destroy_a")
    w.set_collision("ship", "ship", "bounce", restitution=0.5)
    return w, a


def _calls(quick):
    """step(1), advance(1/60), the duel's step(1) and control(), against sim.steps(1)."""
    repeats, count = (3, 2000) if quick else (7, 10_000)
    w = _two_bodies(1e-3)
    sim = peer.simulation(w, "leapfrog", gravity="basic")
    frame = _two_bodies(1 / 60)
    frame_sim = peer.simulation(frame, "leapfrog", gravity="basic")
    duel, ship = _duel()
    long_duel, _ = _duel(compound=True)
    # the star pulls, the ships do not (as in spacephys, where actors are passive)
    duel_sim = peer.simulation(duel, "leapfrog", gravity="basic", n_active=1)
    duel_sim.collision = "line"
    for call in (w.step, sim.steps, duel.step, frame_sim.steps, long_duel.step):
        call(1)
    frame.advance(1 / 60)
    best = _per_call({
        "step(1), 2 bodies": lambda: w.step(1),
        "REBOUND sim.steps(1), 2 bodies": lambda: sim.steps(1),
        "advance(1/60), one step of 2 bodies": lambda: frame.advance(1 / 60),
        "REBOUND sim.steps(1), 2 bodies, dt = 1/60": lambda: frame_sim.steps(1),
        "duel step(1)": lambda: duel.step(1),
        "duel step(1), compound hulls": lambda: long_duel.step(1),
        "REBOUND sim.steps(1), 3 bodies, collisions line": lambda: duel_sim.steps(1),
        "duel control()": lambda: duel.control(ship, throttle=0.5, turn=0.1),
    }, repeats, count)
    rows = []
    for ours, theirs, target in (
            ("step(1), 2 bodies", "REBOUND sim.steps(1), 2 bodies", 5e-6),
            ("advance(1/60), one step of 2 bodies", "REBOUND sim.steps(1), 2 bodies, dt = 1/60",
             8e-6),
            ("duel step(1)", "REBOUND sim.steps(1), 3 bodies, collisions line", 10e-6),
            ("duel step(1), compound hulls", "REBOUND sim.steps(1), 3 bodies, collisions line",
             1.5 * best["duel step(1)"]),
            ("duel control()", None, 2e-6)):
        row = {"case": ours, "spacephys_s": best[ours], "target_s": target}
        if theirs:
            row.update(rebound_case=theirs, rebound_s=best[theirs],
                       ratio=best[ours] / best[theirs])
        rows.append(row)
    return rows


def _batched(quick):
    """Leapfrog on N = 2..5 bodies, many steps in one call (1 000 and 20 000; quick: 200 and
    2 000), against sim.steps(k): seconds per step."""
    from ..scenes import uniform_sphere
    calls, repeats = ((200, 2000), 3) if quick else ((1000, 20_000), 5)
    rows = []
    for n in (2, 3, 4, 5):
        for steps in calls:
            w = uniform_sphere(n, seed=3, dt=1e-4)
            sim = peer.simulation(w, "leapfrog", gravity="basic")
            w.step(1)
            sim.steps(1)
            # as many steps a repeat at every size: the short calls repeated
            best = _per_call({"ours": lambda: w.step(steps), "theirs": lambda: sim.steps(steps)},
                             repeats, calls[-1] // steps)
            rows.append({"bodies": n, "steps": steps, "spacephys_s_per_step": best["ours"] / steps,
                         "rebound_s_per_step": best["theirs"] / steps,
                         "ratio": best["ours"] / best["theirs"]})
    return rows


def _spacewar():
    """The Spacewar! loop of docs/guide/game-loop.md (study/spacewar_loop.py, the page's block
    word for word: tests/test_cli.py checks), run as pasted in a fresh process, twice: the
    second run's frame time (the first loads or compiles the kernels inside its timing)."""
    block = (resources.files(__package__) / "spacewar_loop.py").read_text()
    twice = f"block = {block!r}\nexec(block, {{}})\nexec(block, {{}})\n"
    runs = []
    for _ in range(3):
        res = subprocess.run([sys.executable, "-c", twice], capture_output=True, text=True,
                             check=True)
        found = re.findall(r"([\d.]+) ms per frame, (\d+) bodies", res.stdout)
        assert len(found) == 2, res.stdout
        runs.append((float(found[1][0]), int(found[1][1])))
    return {"ms_per_frame": min(r[0] for r in runs), "runs_ms": [r[0] for r in runs],
            "bodies_at_end": runs[0][1]}


_BUSY = "while True: pass"


def _threads(quick):
    """Per-step time of scenes big enough to thread, on an idle machine and beside two busy
    processes: the default choice ("auto"), always threads (the old default), one thread."""
    import numba
    from ..scenes import star_system, uniform_sphere
    scenes = {"star_system (2 007 bodies of which 6 pull)":
              lambda: star_system(integrator="yoshida4", dt=0.002),
              "cluster of 128": lambda: uniform_sphere(128, dt=1e-4),
              "cluster of 512": lambda: uniform_sphere(512, dt=1e-4)}
    if numba.config.NUMBA_NUM_THREADS < 2:
        return {"skipped": "one core: nothing to choose"}
    rows = []
    for busy in (False, True):
        procs = [subprocess.Popen([sys.executable, "-c", _BUSY]) for _ in range(2)] if busy \
            else []
        try:
            time.sleep(0.3)
            for name, make in scenes.items():
                row = {"scene": name, "busy": busy}
                for mode in ("auto", "always", "never"):
                    w = make()
                    w.threads = mode
                    w.step(1)
                    # step(1) calls, as a game makes them, for long enough that "auto" tries
                    # both choices (it looks again after 1, 2, 4... s): the median call
                    times = []
                    until = time.perf_counter() + (1.5 if quick else 5.0)
                    while time.perf_counter() < until:
                        start = time.perf_counter()
                        w.step(1)
                        times.append(time.perf_counter() - start)
                    row[mode + "_ms"] = 1e3 * float(np.median(times))
                rows.append(row)
        finally:
            for p in procs:
                p.kill()
    return rows


def _user_force(quick):
    """A planet with J2 and 200 moons: Gauss-Radau with the jitted J2 against IAS15 with the
    same force as a Python additional_forces callback; time per step of each."""
    from ..userforces import j2
    from ..world import World
    rng = np.random.default_rng(4)
    n = 50 if quick else 200
    k = 0.05 * 0.1 ** 2
    T = 2.0 if quick else 5.0

    def scene():
        w = World(dim=3, integrator="gauss_radau", dt=T)
        planet = w.add_body(1.0, (0.0, 0.0, 0.0), kind="planet")
        r = rng.uniform(0.4, 1.0, n)
        th = rng.uniform(0, 2 * np.pi, n)
        pos = np.c_[r * np.cos(th), r * np.sin(th), rng.normal(scale=0.05, size=n)]
        vel = np.c_[-np.sin(th), np.cos(th), rng.normal(scale=0.05, size=n)] / np.sqrt(r)[:, None]
        w.add_bodies(0.0, pos, vel, kind="asteroid")
        return w, planet

    w, planet = scene()
    w.add_force(j2, [planet, k])
    sim = peer.add_j2(peer.simulation(w, "ias15"), k)
    w.copy().step(1)                                     # compile or load, not timed
    ours, theirs, steps, rsteps = peer.adaptive_per_step(w, sim, T)
    diff = float(np.abs(w.pos - peer.positions(sim)).max())
    return {"bodies": n + 1, "time": T, "steps": steps, "rebound_steps": rsteps,
            "spacephys_s_per_step": ours, "rebound_s_per_step": theirs,
            "ratio": theirs / ours, "max_position_difference": diff}


def _snapshots(quick):
    """World.snapshot() + restore() and digest() of a duel and of 10 000 bodies, beside
    REBOUND's sim.copy() of the same bodies (its nearest call: a new simulation, no
    restore in place)."""
    from ..game.modes import autoplay
    from ..scenes import uniform_sphere
    repeats, count = (3, 300) if quick else (7, 3000)
    rows = []
    worlds = (("duel", autoplay("duel", 400, seed=7).world, 20e-6, 5e-6),   # 15 bodies
              ("10 000 bodies", uniform_sphere(10_000, seed=2, dt=1e-4), 1e-3, None))
    for name, w, target, digest_target in worlds:
        w.step(1)
        sim = peer.simulation(w, "leapfrog", gravity="basic")
        snap = w.snapshot()
        k = count if w.n < 1000 else max(count // 100, 5)
        best = _per_call({"both": lambda: w.restore(w.snapshot()),
                          "restore": lambda: w.restore(snap),
                          "digest": w.digest,
                          "copy": lambda: sim.copy()}, repeats, k)
        rows.append({"world": name, "bodies": w.n, "snapshot_restore_s": best["both"],
                     "restore_s": best["restore"], "digest_s": best["digest"],
                     "rebound_copy_s": best["copy"], "target_s": target,
                     "digest_target_s": digest_target,
                     "ratio": best["both"] / best["copy"]})
    return rows


def overhead(quick=False):
    """The per-call benchmark (see the module)."""
    rebound = peer.load()
    return {**header("overhead", quick, rebound),
            "calls": _calls(quick), "batched": _batched(quick),
            "snapshots": _snapshots(quick), "spacewar": _spacewar(),
            "threads": _threads(quick), "user_force": _user_force(quick)}


def format_overhead(r):
    us = lambda s: f"{s * 1e6:.2f} us"
    lines = [f"overhead benchmark on {r['machine']} ({r['numba_threads']} numba threads; "
             f"{r['versions']})", "", "| call | spacephys | REBOUND | ours / theirs | target |",
             "|---|---|---|---|---|"]
    for c in r["calls"]:
        theirs = f"{us(c['rebound_s'])} ({c['rebound_case']})" if "rebound_s" in c else "-"
        ratio = f"{c['ratio']:.2f}x" if "ratio" in c else "-"
        lines.append(f"| {c['case']} | {us(c['spacephys_s'])} | {theirs} | {ratio} | "
                     f"<= {us(c['target_s'])} |")
    calls = {c["case"]: c["spacephys_s"] for c in r["calls"]}
    if "duel step(1), compound hulls" in calls:
        lines += ["", f"compound hulls (three circles a ship) / round hulls, duel step(1): "
                  f"{calls['duel step(1), compound hulls'] / calls['duel step(1)']:.2f}x "
                  f"(target <= 1.50x)"]
    lines += ["", "| leapfrog, batched | steps a call | spacephys per step | REBOUND per step | "
              "ours / theirs |", "|---|---|---|---|---|"]
    for b in r["batched"]:
        lines.append(f"| N = {b['bodies']} | {b['steps']} | {us(b['spacephys_s_per_step'])} | "
                     f"{us(b['rebound_s_per_step'])} | {b['ratio']:.2f}x |")
    lines += ["", "| snapshot + restore | bodies | spacephys | restore alone | digest() | "
              "REBOUND sim.copy() | ours / copy | target |", "|---|---|---|---|---|---|---|---|"]
    for c in r["snapshots"]:
        aim = f"<= {us(c['target_s'])}" + (f", digest <= {us(c['digest_target_s'])}"
                                           if c["digest_target_s"] else "")
        lines.append(f"| {c['world']} | {c['bodies']} | {us(c['snapshot_restore_s'])} | "
                     f"{us(c['restore_s'])} | {us(c['digest_s'])} | "
                     f"{us(c['rebound_copy_s'])} | {c['ratio']:.2f}x | {aim} |")
    sw = r["spacewar"]
    lines.append("")
    lines.append(f"Spacewar! loop (docs/guide/game-loop.md): {sw['ms_per_frame']:.3f} ms per "
                 f"frame (runs: {', '.join(f'{x:.3f}' for x in sw['runs_ms'])}), "
                 f"{sw['bodies_at_end']} bodies at the end")
    th = r["threads"]
    if isinstance(th, dict):
        lines.append(f"threads: {th['skipped']}")
    else:
        lines += ["", "| scene | machine | auto (default) | always threads | one thread |",
                  "|---|---|---|---|---|"]
        for t in th:
            lines.append(f"| {t['scene']} | {'two busy processes' if t['busy'] else 'idle'} | "
                         f"{t['auto_ms']:.3f} ms | {t['always_ms']:.3f} ms | "
                         f"{t['never_ms']:.3f} ms |")
    u = r["user_force"]
    lines += ["", f"J2 user force, planet + {u['bodies'] - 1} moons over {u['time']:g}: "
              f"spacephys gauss_radau with the jitted force {us(u['spacephys_s_per_step'])} per "
              f"step ({u['steps']} steps), REBOUND IAS15 with a Python callback "
              f"{us(u['rebound_s_per_step'])} per step ({u['rebound_steps']} steps): "
              f"{u['ratio']:.1f}x; positions agree to {u['max_position_difference']:.1e}"]
    lines += ["", "start and compile times: spacephys bench compile"]
    return "\n".join(lines)
