"""`spacephys bench predict`: what a predicted path costs and how right it is, beside REBOUND
making the same prediction (copy, integrate to each sample time, read the ship) in the same
run.

The scene: a star and 9 planets (G = 1, planets of 1e-4 at r = 1 ... 5.8) and a passive ship
on an orbit of a = 0.02, e = 0.1 about the fourth body. One prediction: 10 of the ship's
orbits, 1000 samples (1001 times with the start). The error is the largest distance over the
samples from a Gauss-Radau reference (tolerance 1e-12) at the same times, relative to the
ship's orbit radius (the scale a HUD draws). Also: 100 ships in one call, the first (cold)
call, and the frame times of a paced 60 Hz game loop with and without predict_async running
beside it.
"""
import math
import time

import numpy as np

from . import header
from . import rebound as peer

ORBITS = 10
POINTS = 1001
R_SHIP = 0.02
M_PLANET = 1e-4
PERIOD = 2 * math.pi * math.sqrt(R_SHIP ** 3 / M_PLANET)
DURATION = ORBITS * PERIOD
# (integrator, steps per sample interval or the tolerance): every case samples at the
# reference's times
CASES = [("leapfrog", 10), ("yoshida4", 1), ("yoshida4", 2), ("yoshida6", 1), ("rk4", 1),
         ("gauss_radau", 1e-9)]


def scene(integrator="yoshida4", dt=None, ships=1, seed=1):
    """(World, ship ids (k,)): the star, 9 planets and `ships` ships about the fourth."""
    import spacephys as sp
    w = sp.World(dim=3, G=1.0, integrator=integrator, dt=dt or DURATION / (POINTS - 1))
    w.add_body(1.0, [0.0, 0.0, 0.0])
    rng = np.random.default_rng(seed)
    for k in range(9):
        r, ph = 1.0 + 0.6 * k, rng.uniform(0, 2 * math.pi)
        w.add_body(M_PLANET, [r * math.cos(ph), r * math.sin(ph), 0.0],
                   [-math.sin(ph) / math.sqrt(r), math.cos(ph) / math.sqrt(r), 0.0])
    spec = sp.ShipSpec(dry_mass=1e-12, fuel_mass=0.0, max_thrust=0.0)
    ids = []
    for j in range(ships):
        a = R_SHIP * (1.0 + 0.5 * j / ships)
        pos, vel = sp.state_from_elements(M_PLANET, a=a, e=0.1, i=0.3 * rng.uniform(),
                                          Omega=rng.uniform(0, 6), omega=rng.uniform(0, 6),
                                          f=rng.uniform(-3, 3))
        ids.append(w.add_ship(spec, w.pos[3] + pos, w.vel[3] + vel))
    return w, np.array(ids)


def _best(fn, repeats):
    best = math.inf
    for _ in range(repeats):
        start = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - start)
    return best


def _options(integrator, setting):
    if integrator == "gauss_radau":
        return {"integrator": integrator, "tolerance": setting}
    return {"integrator": integrator, "dt": DURATION / ((POINTS - 1) * setting)}


def _rebound(w, times, row, integrator, dt=None):
    """REBOUND's prediction: copy the simulation, integrate to each sample time, read the
    ship; returns the function that does it (-> (P, 3))."""
    sim0 = peer.simulation(w, integrator, dt=dt, n_active=w.n - 1)
    sim0.testparticle_hidewarnings = 1          # the ship's mass: it pulls nothing, as ours

    def run():
        sim = sim0.copy()
        out = np.empty((times.size, 3))
        for j, t in enumerate(times):
            sim.integrate(t)
            p = sim.particles[row]
            out[j] = p.x, p.y, p.z
        return out
    return run


def predict_bench(quick=False):
    rebound = peer.load()
    repeats = 3 if quick else 9
    w, (ship,) = scene()
    reference = w.predict(ship, DURATION, points=POINTS, integrator="gauss_radau",
                          tolerance=1e-12).pos[0]
    error = lambda pos: float(np.max(np.linalg.norm(pos - reference, axis=1)) / R_SHIP)
    cases = []
    for integrator, setting in CASES:
        options = _options(integrator, setting)
        call = lambda: w.predict(ship, DURATION, points=POINTS, **options)
        start = time.perf_counter()
        pred = call()
        first = time.perf_counter() - start
        steps = (POINTS - 1) * (1 if integrator == "gauss_radau" else setting)
        cases.append({"case": f"{integrator}, " + (f"tolerance {setting:g}"
                      if integrator == "gauss_radau" else f"{steps // ORBITS} steps an orbit"),
                      "options": dict(options), "steps": steps,
                      "first_call_s": first, "warm_call_s": _best(call, repeats),
                      "error": error(pred.pos[0])})
    within = [c for c in cases if c["error"] <= 1e-6]
    best = min(within, key=lambda c: c["warm_call_s"]) if within else None
    times = np.linspace(0.0, DURATION, POINTS)
    row = w.index_of(ship)
    theirs = []
    for integrator, dt in [("ias15", None), ("leapfrog", DURATION / ((POINTS - 1) * 10))]:
        run = _rebound(w, times, row, integrator, dt)
        label = "REBOUND ias15" if dt is None else \
            f"REBOUND leapfrog, {10 * (POINTS - 1) // ORBITS} steps an orbit"
        theirs.append({"case": label,
                       "warm_call_s": _best(run, repeats), "error": error(run())})
    by_error = _by_error(error, repeats)
    options = best["options"] if best else _options("yoshida4", 1)
    w100, ids100 = scene(ships=100)
    many = lambda: w100.predict(ids100, DURATION, points=POINTS, **options)
    many()
    hundred = _best(many, repeats)
    return {**header("predict", quick, rebound), "orbits": ORBITS, "points": POINTS,
            "bodies": w.n, "ship_period": PERIOD, "cases": cases, "rebound": theirs,
            "best": best, "hundred_ships_s": hundred, "by_error": by_error,
            "stepping_s": {"1": _stepping(w, options, repeats),
                           "100": _stepping(w100, options, repeats)},
            "hud_s": _hud(options, repeats), "frames": _frames(quick, options)}


def _by_error(error, repeats, asked=1e-6):
    """World.predict(..., error=asked) alone, the settings its own choice
    (spacephys/prediction_settings.py): the first call (the trials) and a warm call, the
    error against the reference (`error`: pos -> float), the settings chosen; and 100 ships
    likewise, warm."""
    w, (ship,) = scene()
    call = lambda: w.predict(ship, DURATION, points=POINTS, error=asked)
    start = time.perf_counter()
    pred = call()
    first = time.perf_counter() - start
    name, dt, _ = next(iter(w.driver.choices.values()))
    w100, ids100 = scene(ships=100)
    many = lambda: w100.predict(ids100, DURATION, points=POINTS, error=asked)
    many()
    return {"asked": asked, "first_call_s": first, "warm_call_s": _best(call, repeats),
            "error": error(pred.pos[0]), "integrator": name,
            "steps_an_orbit": round(PERIOD / dt), "hundred_ships_s": _best(many, repeats)}


def _hud(options, repeats):
    """A HUD's prediction each frame: the World flies the prediction's own integrator and
    dt, one step further between calls, so the planets' recorded future plays on (the tape,
    spacephys/tape.py); and a call on a World whose integrator differs (each records anew).
    Best call [s] of each."""
    same, (ship,) = scene(options["integrator"], dt=options.get("dt"))
    other, (ship2,) = scene("leapfrog", dt=options.get("dt"))
    out = {}
    for name, w, s in (("same_integrator", same, ship), ("other_integrator", other, ship2)):
        call = lambda: w.predict(s, DURATION, points=POINTS, **options)
        call()

        def frame():
            w.step(1)
            call()
        out[name] = _best(frame, 2 * repeats) - _best(lambda: w.step(1), 2 * repeats)
    return out


def _stepping(w, options, repeats):
    """The prediction's integration alone: a copy of w with its integrator and dt taking the
    same steps, no samples, no markers [s] (what the call costs beyond is theirs)."""
    copy = w.copy()
    copy.integrator = options["integrator"]
    copy.dt = options.get("dt", DURATION / (POINTS - 1))    # Gauss-Radau: its output steps
    if "tolerance" in options:
        copy.tolerance = options["tolerance"]
    steps = round(DURATION / copy.dt)
    copy.step(steps)
    return _best(lambda: copy.step(steps), repeats)


def _frames(quick, options):
    """A game loop paced at 60 Hz, the ship's orbit 60 s of game time: advance(1/60 s), 4
    leapfrog steps a frame. Per-frame wall time of the loop's own work alone, and with the
    ship's next 100 orbits (10 001 samples, several frames long) predicted by predict_async
    every 6th frame (a HUD at 10 Hz) when the last is done, launched after the frame's own
    steps: the frames while a prediction runs beside them, and the frames that launch one
    (they pay for taking the World's state). Median, 95th percentile, worst [s]; alone
    measured before and after."""
    scale = 60.0 / PERIOD                       # game seconds per time unit
    w, (ship,) = scene("leapfrog", dt=1.0 / 240.0 / scale)
    frames = 180 if quick else 600

    def loop(background):
        alone, running, launching, handle, made = [], [], [], None, 0
        tick = time.perf_counter()
        for k in range(frames):
            start = time.perf_counter()
            busy = handle is not None and not handle.done()
            launch = background and k % 6 == 0 and not busy
            w.advance(1.0 / 60.0 / scale)
            w.interpolate(0.5)
            if launch:              # after the frame's physics: the worker's start overlaps
                if handle is not None:                      # the wait for the next frame
                    handle.result()
                    made += 1
                handle = w.predict_async(ship, 10 * DURATION, points=10 * POINTS - 9,
                                         **options)
            spent = time.perf_counter() - start
            (launching if launch else running if busy else alone).append(spent)
            tick += 1.0 / 60.0
            time.sleep(max(0.0, tick - time.perf_counter()))
        if handle is not None:
            handle.result()
            made += 1
        return alone, running, launching, made

    loop(False)
    # a prediction's own tables (one thread) compiled or loaded before the frames are timed
    w.predict_async(ship, 10 * DURATION, points=10 * POINTS - 9, **options).result()
    alone = loop(False)[0]
    _, running, launching, made = loop(True)
    alone += loop(False)[0]
    stats = lambda x: {"count": len(x), "median_s": float(np.median(x)),
                       "p95_s": float(np.percentile(x, 95)), "max_s": float(np.max(x))}
    return {"predictions": made, "alone": stats(alone), "running": stats(running),
            "launching": stats(launching)}


def format_predict(r):
    lines = [f"predict benchmark on {r['machine']} ({r['numba_threads']} numba threads; "
             f"{r['versions']})",
             f"a ship among {r['bodies'] - 1} massive bodies, {r['orbits']} of its orbits, "
             f"{r['points']} samples; error: the largest distance from a Gauss-Radau "
             f"reference (tolerance 1e-12) over the ship's orbit radius",
             f"{'case':36s} {'steps':>6s} {'warm call':>11s} {'first call':>11s} "
             f"{'error':>9s}"]
    for c in r["cases"]:
        lines.append(f"{c['case']:36s} {c['steps']:6d} {c['warm_call_s'] * 1e3:8.3f} ms "
                     f"{c['first_call_s'] * 1e3:8.1f} ms {c['error']:9.1e}")
    for c in r["rebound"]:
        lines.append(f"{c['case']:36s} {'':6s} {c['warm_call_s'] * 1e3:8.3f} ms "
                     f"{'':11s} {c['error']:9.1e}")
    b = r["best"]
    if b is not None:
        ok = [c for c in r["rebound"] if c["error"] <= 1e-6]
        theirs = min(ok, key=lambda c: c["warm_call_s"]) if ok else None
        lines.append(f"fastest within 1e-6: {b['case']}, {b['warm_call_s'] * 1e3:.3f} ms a "
                     f"call (target 1 ms)" + (
                         f"; REBOUND's fastest within 1e-6: {theirs['case']}, "
                         f"{theirs['warm_call_s'] * 1e3:.3f} ms "
                         f"({theirs['warm_call_s'] / b['warm_call_s']:.1f}x ours)"
                         if theirs else ""))
    lines.append(f"100 ships predicted in one call: {r['hundred_ships_s'] * 1e3:.2f} ms "
                 f"(target 20 ms)")
    e = r["by_error"]
    lines.append(f"error={e['asked']:g} alone: {e['integrator']}, {e['steps_an_orbit']} steps "
                 f"an orbit chosen; {e['warm_call_s'] * 1e3:.3f} ms a call (first, with the "
                 f"trials: {e['first_call_s'] * 1e3:.0f} ms), error {e['error']:.1e}; 100 ships "
                 f"{e['hundred_ships_s'] * 1e3:.2f} ms")
    st = r["stepping_s"]
    lines.append(f"a World flying the same steps (all bodies, one thread, no samples or markers): "
                 f"{st['1'] * 1e3:.3f} ms for 1 ship, {st['100'] * 1e3:.2f} ms for 100")
    h = r["hud_s"]
    lines.append(f"a HUD's call, the World a step further each time: "
                 f"{h['same_integrator'] * 1e3:.3f} ms when it flies the prediction's "
                 f"integrator and dt (the planets' future played back), "
                 f"{h['other_integrator'] * 1e3:.3f} ms when it does not")
    f = r["frames"]
    for name, label in (("alone", "alone"), ("running", "while a prediction runs beside"),
                        ("launching", "launching one (predict_async)")):
        x = f[name]
        lines.append(f"60 Hz game loop, a frame's own work {label}: median "
                     f"{x['median_s'] * 1e6:.0f} us, p95 {x['p95_s'] * 1e6:.0f} us, worst "
                     f"{x['max_s'] * 1e6:.0f} us ({x['count']} frames)")
    return "\n".join(lines)
