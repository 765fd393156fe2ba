"""`spacephys bench`: spacephys side by side with REBOUND in the same run, reported as ratios.

Timings are the best of several alternating repeats (the machine is shared and noisy; the
minimum is the least disturbed run of each code). Each case also checks that both codes did
the same work: the positions after a few identical steps must agree to round-off.
"""
import os
import time

import numpy as np

from ..scenes import uniform_sphere
from . import header
from . import rebound as peer


def _alternating(ours, theirs, steps, repeats):
    """Best seconds per step of ours(steps) and theirs(steps), called in turn."""
    best = [float("inf"), float("inf")]
    for _ in range(repeats):
        for k, run in enumerate((ours, theirs)):
            start = time.perf_counter()
            run(steps)
            best[k] = min(best[k], (time.perf_counter() - start) / steps)
    return best


def _per_step(run, steps, repeats):
    best = float("inf")
    for _ in range(repeats):
        start = time.perf_counter()
        run(steps)
        best = min(best, (time.perf_counter() - start) / steps)
    return best


def _steps_for(run, budget):
    """How many steps of `run` take about `budget` seconds (after one warm-up step)."""
    start = time.perf_counter()
    run(1)
    return max(1, int(budget / max(time.perf_counter() - start, 1e-9)))


def _case(name, w, *, repeats, budget, n_active=None, check_steps=5):
    """Time a leapfrog step of World w and of REBOUND on the same bodies."""
    sim = peer.simulation(w, "leapfrog", gravity="basic", n_active=n_active)
    # same work: a few steps from identical states must agree to round-off. Velocities, not
    # positions: from rest, positions move by less than their own rounding in a few steps.
    a, s = w.copy(), peer.simulation(w, "leapfrog", gravity="basic", n_active=n_active)
    a.step(check_steps)
    s.steps(check_steps)
    agreement = float(np.max(np.abs(a.vel - peer.velocities(s)[:, :w.dim])) /
                      np.max(np.abs(a.vel)))

    ours = _steps_for(w.step, budget)
    theirs = _steps_for(sim.steps, budget)
    t_ours = t_theirs = float("inf")
    for _ in range(repeats):               # alternate, so a disturbance hits both alike
        t_ours = min(t_ours, _per_step(w.step, ours, 1))
        t_theirs = min(t_theirs, _per_step(sim.steps, theirs, 1))
    n_pull = n_active if n_active is not None else w.n
    pairs = n_pull * (n_pull - 1) + (w.n - n_pull) * n_pull
    return {"case": name, "bodies": w.n, "pulling": n_pull,
            "spacephys_s_per_step": t_ours, "rebound_s_per_step": t_theirs,
            "ratio": t_theirs / t_ours, "spacephys_pairs_per_s": pairs / t_ours,
            "rebound_pairs_per_s": pairs / t_theirs, "max_relative_difference": agreement}


def gravity(quick=False):
    """The gravity benchmark of the Core issue: direct summation, leapfrog, G = 1, eps = 1e-3.
    (Compile and start times: `spacephys bench overhead`.)"""
    rebound = peer.load()
    repeats, budget = (2, 0.1) if quick else (5, 0.3)
    sizes = (256, 1024) if quick else (1024, 4096)
    cases = []
    for n in sizes:
        cases.append(_case(f"leapfrog N={n}", uniform_sphere(n, dt=1e-4), repeats=repeats,
                           budget=budget))
    cases.append(_case("leapfrog N=16 (many steps per call)", uniform_sphere(16, dt=1e-4),
                       repeats=repeats, budget=budget))
    m, t = (100, 10_000) if quick else (1000, 100_000)
    w = uniform_sphere(m, dt=1e-4)
    rng = np.random.default_rng(2)
    p = rng.normal(size=(t, 3))
    w.add_bodies(0.0, p / np.linalg.norm(p, axis=1)[:, None] * rng.random((t, 1)) ** (1 / 3))
    cases.append(_case(f"{m} massive + {t} test particles", w, repeats=max(1, repeats - 2),
                       budget=budget, n_active=m, check_steps=2))
    return {**header("gravity", quick, rebound),
            "cases": cases}


def _gauss_radau_case(n, duration, repeats):
    """Gauss-Radau and IAS15 over the same interval of the same cluster: time per step."""
    from ..scenes import uniform_sphere
    make = lambda: uniform_sphere(n, seed=1, softening=0.01, integrator="gauss_radau",
                                  dt=duration)
    make().step(1)                                      # compile outside the timing
    best_ours = best_theirs = float("inf")
    for _ in range(repeats):
        w = make()
        sim = peer.simulation(w, "ias15")
        ours, theirs, steps, rsteps = peer.adaptive_per_step(w, sim, duration)
        best_ours = min(best_ours, ours)
        best_theirs = min(best_theirs, theirs)
    diff = float(np.max(np.abs(w.pos - peer.positions(sim))) / np.max(np.abs(w.pos)))
    return {"case": f"gauss_radau vs IAS15, N={n}, t={duration:g}", "bodies": n,
            "steps": steps, "rebound_steps": rsteps,
            "spacephys_s_per_step": best_ours, "rebound_s_per_step": best_theirs,
            "ratio": best_theirs / best_ours, "max_relative_difference": diff}


def _wisdom_holman_case(corrector, steps, repeats):
    """Sun + 8 planets, 5-day steps: WH and WHFast (safe mode off: both synchronise at the
    end of the batch only)."""
    from ..scenes import solar_system
    name = "wisdom_holman_corrected" if corrector else "wisdom_holman"
    w = solar_system(integrator=name, dt=5 / 365.25)
    sim = peer.simulation(w, "whfast", corrector=corrector, safe_mode=0)
    E0, E0r = w.energy(), sim.energy()
    w.step(1)
    sim.steps(1)
    t_ours, t_theirs = _alternating(w.step, sim.steps, steps, repeats)
    sim.synchronize()
    diff = float(np.max(np.abs(w.pos - peer.positions(sim))) / np.max(np.abs(w.pos)))
    return {"case": f"{name} vs WHFast{' (corrector 3)' if corrector else ''}, Sun + 8 "
                    f"planets, dt = 5 d", "bodies": w.n, "steps": 1 + repeats * steps,
            "spacephys_s_per_step": t_ours, "rebound_s_per_step": t_theirs,
            "ratio": t_theirs / t_ours, "max_relative_difference": diff,
            "energy_error": float(abs(w.energy() / E0 - 1)),
            "rebound_energy_error": float(abs(sim.energy() / E0r - 1))}


def integrators(quick=False):
    """The high-accuracy integrators against REBOUND's: IAS15 and WHFast, same problems."""
    rebound = peer.load()
    repeats = 2 if quick else 3
    cases = [_gauss_radau_case(16, 0.5 if quick else 2.0, repeats),
             _gauss_radau_case(256 if quick else 1024, 0.01 if quick else 0.05, 1)]
    for corrector in (0, 3):
        cases.append(_wisdom_holman_case(corrector, 10_000 if quick else 33_333, repeats))
    return {**header("integrators", quick, rebound),
            "cases": cases}


def circle_field(n, seed=0, dim=2):
    """n circles, radii 0.2..1 with 1% up to 3, on a jittered lattice (no overlaps at the
    start), 5% of the area covered, moving a third of a radius per step on average; every
    pair collides elastically."""
    from ..world import World
    rng = np.random.default_rng(seed)
    r = rng.uniform(0.2, 1.0, n)
    big = rng.random(n) < 0.01
    r[big] = rng.uniform(1.0, 3.0, big.sum())
    side = int(np.ceil(np.sqrt(n)))
    spacing = np.sqrt(np.pi * (r ** 2).sum() / 0.05 / n)
    k = np.arange(n)
    pos = np.stack([k % side, k // side], axis=1) * spacing
    pos += rng.uniform(-0.2, 0.2, (n, 2)) * spacing
    w = World(dim=2, gravity="none", dt=0.1)
    w.set_collision("*", "*", "elastic")
    w.add_bodies(1.0, pos, rng.normal(scale=2.0, size=(n, 2)), radius=r)
    return w


def _detection_pass(w, brute=False):
    """One broad + narrow phase pass over the step the bodies' velocities make: seconds,
    candidate pairs, contacts."""
    from ..kernels import collide
    n = w.n
    plan = w.tables()
    A = np.zeros((n, 3))
    B = np.zeros((n, 3))
    A[:, :w.dim] = w.pos
    B[:, :w.dim] = w.vel * w.dt
    tb = np.zeros(n)
    lo, hi = np.empty((n, 3)), np.empty((n, 3))
    L = np.zeros(3)
    start = time.perf_counter()
    if brute:
        pairs = collide.brute_pairs(A, B, tb, plan.alive, plan.rules, lo, hi)
    else:
        pairs, _ = collide.candidate_pairs(A, B, tb, plan.alive, plan.rules, lo, hi)
    contacts = collide.pair_contacts(A, B, tb, pairs, L, plan.rules)[0].size
    return time.perf_counter() - start, len(pairs), contacts


def _merging_cluster(n, steps, radius, repeats, seed=4):
    """n equal masses (total 1) in a unit sphere, G = 1, leapfrog dt = 1e-3, merging on
    contact: spacephys against REBOUND (collision "line", resolve "merge").

    Where three or more bodies touch in one step REBOUND's result varies from run to run
    (seen: 11, 10, 10 merges for one set of initial conditions in one process); spacephys
    merges all of them, every time. Compare on scenes without such chains."""
    from ..world import World
    rng = np.random.default_rng(seed)
    p = rng.normal(size=(n, 3))
    p *= (rng.random(n) ** (1 / 3) / np.linalg.norm(p, axis=1))[:, None]
    v = rng.normal(scale=0.1, size=(n, 3))

    def ours():
        w = World(dim=3, dt=1e-3)
        w.set_collision("*", "*", "merge")
        w.add_bodies(1.0 / n, p, v, radius=radius)
        return w

    ours().step(2)                                     # compile outside the timing
    t_ours = t_theirs = float("inf")
    for _ in range(repeats):
        w = ours()
        sim = peer.simulation(w, "leapfrog", gravity="basic")
        sim.collision, sim.collision_resolve = "line", "merge"
        start = time.perf_counter()
        w.step(steps)
        t_ours = min(t_ours, (time.perf_counter() - start) / steps)
        start = time.perf_counter()
        sim.steps(steps)
        t_theirs = min(t_theirs, (time.perf_counter() - start) / steps)
    masses = np.array([q.m for q in sim.particles])
    momentum = np.sum([[q.m * q.vx, q.m * q.vy, q.m * q.vz] for q in sim.particles], axis=0)
    same = w.n == sim.N and np.allclose(np.sort(w.mass), np.sort(masses), rtol=1e-12, atol=0)
    return {"case": f"{n} bodies merging, {steps} leapfrog steps", "bodies": n,
            "spacephys_s_per_step": t_ours, "rebound_s_per_step": t_theirs,
            "ratio": t_theirs / t_ours, "merges": n - w.n, "rebound_merges": n - sim.N,
            "same_masses": bool(same),
            "momentum_difference": float(np.max(np.abs(w.momentum() - momentum)))}


def collisions(quick=False):
    """Broad + narrow phase on circle fields, brute force against the grid, and merging
    against REBOUND."""
    rebound = peer.load()
    sizes = (10_000, 20_000) if quick else (100_000, 200_000)
    _detection_pass(circle_field(1000))                # compile
    passes = {}
    for n in sizes:
        w = circle_field(n)
        best = min(_detection_pass(w)[0] for _ in range(3 if quick else 5))
        _, pairs, contacts = _detection_pass(w)
        passes[n] = {"seconds": best, "pairs": pairs, "contacts": contacts}
        steps = w.copy()
        steps.step(1)
        start = time.perf_counter()
        steps.step(1)
        passes[n]["full_step_seconds"] = time.perf_counter() - start
        passes[n]["events"] = len(steps.events)
    small = circle_field(2000 if quick else 10_000)
    _detection_pass(small, brute=True)
    t_brute, pairs_brute, _ = _detection_pass(small, brute=True)
    t_grid, pairs_grid, _ = min(_detection_pass(small) for _ in range(3))
    merge = _merging_cluster(2000 if quick else 10_000, 5 if quick else 10,
                             0.01 if quick else 0.004, 1 if quick else 2)
    from .heavybench import dense
    return {**header("collisions", quick, rebound), "dense": dense(quick),
            "detection": passes, "scaling": passes[sizes[1]]["seconds"] / passes[sizes[0]]["seconds"],
            "brute_vs_grid": {"bodies": small.n, "brute_seconds": t_brute,
                              "grid_seconds": t_grid, "pairs_brute": pairs_brute,
                              "pairs_grid": pairs_grid},
            "merging": merge}


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
    times = []
    splits = []
    steps = 30 if quick else 120
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
    ours_ms = 1e3 * _per_step(plain.step, 10, reps)
    rebound_ms = 1e3 * _per_step(sim.steps, 10, reps)
    from .heavybench import fleet_game
    return {**header("fleet", quick, rebound), "game": fleet_game(quick),
            "bodies_start": bodies, "bodies_end": w.n, "massive": int(massive.size),
            "steps": steps, "first_step_s": first,
            "median_ms": float(np.median(times)), "p95_ms": float(np.percentile(times, 95)),
            "max_ms": float(times.max()), "split_ms": split,
            "gravity_only_ms": ours_ms, "rebound_gravity_only_ms": rebound_ms,
            "gravity_ratio": rebound_ms / ours_ms}


def log(quick=False):
    """What recording costs: a 1 000-body 3D leapfrog run (equal masses in a unit sphere,
    softened) stepped in one call, without a log and recording a frame every step or every
    10th step (default settings: every table raw; and with compression="gzip",
    compress_state=True); wall time overhead and bytes per frame, best of alternating
    repeats. REBOUND's Simulationarchive on the same run (a snapshot every step / every 10th
    step) for comparison, as time per frame."""
    import tempfile
    from ..world import World
    rebound = peer.load()
    n, steps, reps = 1000, (500 if quick else 3000), (3 if quick else 5)
    rng = np.random.default_rng(7)
    pos = rng.normal(size=(n, 3))
    vel = rng.normal(scale=0.1, size=(n, 3))
    folder = tempfile.mkdtemp(prefix="spacephys-bench-log-")
    path = os.path.join(folder, "run.h5")

    def ours(every, **kw):
        w = scene()
        w.step(1)
        log = w.record(path, every=every, **kw) if every else None
        start = time.perf_counter()
        w.step(steps)
        if log is not None:
            log.flush()
        seconds = time.perf_counter() - start
        size = 0
        if log is not None:
            log.close()
            size = os.path.getsize(path) / (steps // every + 2)
        return seconds, size

    def scene():
        w = World(dim=3, dt=1e-3, softening=1e-3)
        w.add_bodies(np.full(n, 1.0 / n), pos, vel)
        return w

    def theirs(every):
        sim = peer.simulation(scene(), "leapfrog", gravity="basic")
        if every:
            sim.save_to_file(os.path.join(folder, "run.bin"), step=every, delete_file=True)
        start = time.perf_counter()
        sim.steps(steps // 4)
        return time.perf_counter() - start

    cases = {"none": {}, "every step": {"every": 1}, "every 10th step": {"every": 10},
             "every step, gzip everything": {"every": 1, "compression": "gzip",
                                             "compress_state": True},
             "every 10th step, gzip everything": {"every": 10, "compression": "gzip",
                                                  "compress_state": True}}
    ours(1)                                       # compile or load the kernels once
    runs = {name: [] for name in cases}
    rb = {0: [], 1: [], 10: []}
    for _ in range(reps):
        for name, kw in cases.items():
            runs[name].append(ours(kw.get("every", 0),
                                   **{k: v for k, v in kw.items() if k != "every"}))
        for every in rb:
            rb[every].append(theirs(every))
    # best of the repeats: interference on a shared machine only ever adds time
    base = float(np.min([r[0] for r in runs["none"]]))
    rows = []
    for name, kw in cases.items():
        if name == "none":
            continue
        t = float(np.min([r[0] for r in runs[name]]))
        every = kw["every"]
        rows.append({"case": name, "seconds": t, "overhead": t / base - 1.0,
                     "us_per_frame": (t - base) / (steps / every) * 1e6,
                     "bytes_per_frame": float(np.median([r[1] for r in runs[name]]))})
    rb_base = float(np.min(rb[0]))
    rebound_rows = [{"every": every, "overhead": float(np.min(rb[every])) / rb_base - 1.0,
                     "us_per_frame": (float(np.min(rb[every])) - rb_base) /
                     (steps // 4 / every) * 1e6} for every in (1, 10)]
    for name in os.listdir(folder):
        os.unlink(os.path.join(folder, name))
    os.rmdir(folder)
    return {**header("log", quick, rebound),
            "bodies": n, "steps": steps, "base_seconds": base,
            "base_us_per_step": base / steps * 1e6, "cases": rows,
            "rebound_us_per_step": rb_base / (steps // 4) * 1e6, "rebound": rebound_rows}


def _ring_world(n):
    """A star and n test particles on circular orbits 1..2 from it (3D arrays, z = 0)."""
    from ..world import World
    w = World(dim=3, dt=0.01, capacity=n + 1)
    w.add_body(1.0, (0.0, 0.0, 0.0))
    rng = np.random.default_rng(0)
    r, th = rng.uniform(1.0, 2.0, n), rng.uniform(0.0, 2 * np.pi, n)
    pos = np.c_[r * np.cos(th), r * np.sin(th), np.zeros(n)]
    vel = np.c_[-np.sin(th), np.cos(th), np.zeros(n)] / np.sqrt(r)[:, None]
    w.add_bodies(0.0, pos, vel)
    return w


def memory_used(n, steps=5):
    """(peak bytes Python and numpy allocated, World bytes held) to build a star with n test
    particles and take `steps` leapfrog steps; tracemalloc sees numpy's buffers."""
    import tracemalloc
    _ring_world(10).step(steps)            # load the kernels outside the count
    tracemalloc.start()
    try:
        w = _ring_world(n)
        w.step(steps)
        held = tracemalloc.get_traced_memory()[0]
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    return peak, held


def memory(quick=False):
    """State is O(N): bytes per body (state columns, id slots, the kernels' scratch) and the
    peak memory of a star with 10^6 test particles taking leapfrog steps; and the peak
    memory per body of a Plummer sphere of as many stars under the tree."""
    import resource
    n = 100_000 if quick else 1_000_000
    w = _ring_world(1000)
    w.step(1)
    per_body = w.bytes_per_body()
    before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024
    start = time.perf_counter()
    peak, held = memory_used(n)
    seconds = time.perf_counter() - start
    after = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024
    from .treebench import memory as tree_memory
    tree_peak, tree_held = tree_memory(n)
    return {**header("memory", quick), "bodies": n,
            "bytes_per_body": per_body,
            "held_bytes": held, "peak_bytes": peak, "maxrss_growth_bytes": after - before,
            "seconds": seconds, "tree_peak_bytes_per_body": tree_peak,
            "tree_held_bytes_per_body": tree_held}


def _orbit_world(model, n, dt, softening):
    """A star of mass 1 (G = 1) and n bodies on circular orbits at radii 1..3 in 2D, as one of
    the gravity models: "direct" (every body of mass 1e-9 pulls), "tree" (the same bodies,
    their pull summed by the tree, theta 0.5; the star, over 1% of the mass, directly), "test"
    (the bodies have mass 0: only the star pulls) or "central" (no star body: a fixed field
    of mass 1 at 0)."""
    from ..world import World
    rng = np.random.default_rng(0)
    r, th = rng.uniform(1.0, 3.0, n), rng.uniform(0.0, 2 * np.pi, n)
    pos = np.c_[r * np.cos(th), r * np.sin(th)]
    vel = np.c_[-np.sin(th), np.cos(th)] / np.sqrt(r)[:, None]
    kw = dict(dim=2, dt=dt, softening=softening, capacity=n + 1)
    if model == "central":
        w = World(gravity="central", central_mass=1.0, **kw)
    else:
        w = World(gravity="tree" if model == "tree" else "direct", **kw)
        w.add_body(1.0, (0.0, 0.0), kind="star")
    w.add_bodies(1e-9 if model in ("direct", "tree") else 0.0, pos, vel, active=True)
    return w


# the projectile scene: Earth's g at its surface, radius R [m], bodies up to H [m] above it
# and within X [m] of the origin; the reference is the planet as a point mass at (0, -R)
_R, _H, _X = 6.371e6, 1000.0, 100.0


def _surface_world(n, reference=False):
    from ..world import World
    rng = np.random.default_rng(1)
    pos = np.c_[rng.uniform(-_X, _X, n), rng.uniform(0.0, _H, n)]
    vel = np.c_[rng.uniform(-20.0, 20.0, n), rng.uniform(20.0, 40.0, n)]
    field = (dict(gravity="central", central_mass=9.81 * _R ** 2, central_pos=(0.0, -_R))
             if reference else dict(gravity="uniform", g=(0.0, -9.81)))
    w = World(dim=2, dt=1 / 240, capacity=n, **field)
    w.add_bodies(1.0, pos, vel)
    return w


def _errors(pos, ref):
    d = np.linalg.norm(pos - ref, axis=1)
    return {"max_position_error": float(d.max()), "median_position_error": float(np.median(d))}


def models(quick=False):
    """What each gravity model costs and what it gets wrong: a star (mass 1, G = 1) and N
    bodies on circular orbits at radii 1..3, 2D leapfrog, as full N-body (bodies of mass 1e-9,
    all pulling), test particles (mass 0) and a central field (no star body); and N
    projectiles near a planet's surface in a uniform field. Time per step (best of repeats;
    full N-body and test particles side by side with REBOUND's leapfrog, N_active = 1 for the
    test particles) and the bodies' position errors after one inner orbit, T = 2 pi, against
    the full N-body run (the uniform field: after 4 s, against the planet as a point mass).
    The tree (theta 0.5) runs the full N-body scene with its pull approximated."""
    rebound = peer.load()
    sizes = (200, 4000) if quick else (1000, 10_000)
    repeats, budget = (3, 0.05) if quick else (5, 0.3)
    dt, eps, steps = 2 * np.pi / 500, 0.01, 500
    cases = []
    for n in sizes:
        runs = {m: _orbit_world(m, n, dt, eps) for m in ("direct", "tree", "test", "central")}
        for w in runs.values():
            w.step(steps)
        full = runs["direct"].pos[-n:]
        direct = _case(f"full N-body, N={n}", _orbit_world("direct", n, dt, eps),
                       repeats=repeats, budget=budget)
        test = _case(f"test particles, N={n}", _orbit_world("test", n, dt, eps),
                     repeats=repeats, budget=budget, n_active=1)
        central, surface = _orbit_world("central", n, dt, eps), _surface_world(n)
        k = _steps_for(central.step, budget)
        surface.step(1)
        t_central, t_surface = _alternating(central.step, surface.step, k, repeats)
        tree = _orbit_world("tree", n, dt, eps)
        t_tree = _per_step(tree.step, _steps_for(tree.step, budget), repeats)
        flat, ref = _surface_world(n), _surface_world(n, reference=True)
        d = ref.pos - (0.0, -_R)
        exact = -9.81 * _R ** 2 * d / np.linalg.norm(d, axis=1)[:, None] ** 3
        flat.step(960)
        ref.step(960)
        rows = [{**direct, "model": "direct", **_errors(full, full),
                 "star_displacement": float(np.linalg.norm(runs["direct"].pos[0]))},
                {"case": f"tree, N={n}", "model": "tree", "bodies": n + 1,
                 "spacephys_s_per_step": t_tree, **_errors(runs["tree"].pos[-n:], full)},
                {**test, "model": "test", **_errors(runs["test"].pos[-n:], full)},
                {"case": f"central field, N={n}", "model": "central", "bodies": n,
                 "spacephys_s_per_step": t_central, **_errors(runs["central"].pos, full),
                 "difference_from_test_particles":
                     float(np.max(np.abs(runs["central"].pos - runs["test"].pos[-n:])))},
                {"case": f"uniform field, N={n}", "model": "uniform", "bodies": n,
                 "spacephys_s_per_step": t_surface, **_errors(flat.pos, ref.pos),
                 "relative_force_error":
                     float(np.max(np.linalg.norm(exact - (0.0, -9.81), axis=1)) / 9.81)}]
        for r in rows:
            r["us_per_body_step"] = r["spacephys_s_per_step"] / r["bodies"] * 1e6
        cases += rows
    return {**header("models", quick, rebound),
            "orbits": {"dt": dt, "steps": steps, "time": dt * steps, "softening": eps,
                       "body_mass": 1e-9, "star_mass": 1.0, "radii": [1.0, 3.0]},
            "surface": {"g": 9.81, "planet_radius": _R, "max_height": _H, "half_width": _X,
                        "dt": 1 / 240, "steps": 960, "time": 4.0, "two_h_over_R": 2 * _H / _R},
            "cases": cases}


def _heavy_lines(title, cases):
    from .heavybench import format_rows
    return format_rows(title, cases)


def format_table(results):
    if results["benchmark"] == "compile":
        from .compilebench import format_compile
        return format_compile(results)
    if results["benchmark"] == "overhead":
        from .overhead import format_overhead
        return format_overhead(results)
    if results["benchmark"] == "predict":
        from .prediction import format_predict
        return format_predict(results)
    if results["benchmark"] == "tree":
        from .treebench import format_tree
        return format_tree(results)
    if results["benchmark"] == "queries":
        from .querybench import format_queries
        return format_queries(results)
    if results["benchmark"] == "sweep":
        from .sweepbench import format_sweep
        return format_sweep(results)
    if results["benchmark"] == "play":
        from .playbench import format_play
        return format_play(results)
    lines = [f"{results['benchmark']} benchmark on {results['machine']} "
             f"({results['numba_threads']} numba threads; {results['versions']})",
             f"{'case':40s} {'spacephys':>14s} {'REBOUND':>14s} {'speed-up':>9s} "
             f"{'pairs/s (ours)':>15s} {'max rel. diff':>14s}"]
    if results["benchmark"] == "memory":
        per = results["bytes_per_body"]
        n = results["bodies"]
        return "\n".join([
            f"memory benchmark on {results['machine']} ({results['versions']})",
            "memory: " + ", ".join(f"{k} {v} B" for k, v in per.items()) +
            f" per body ({sum(per.values())} B)",
            f"a star and {n:,} test particles, built and stepped: held "
            f"{results['held_bytes'] / 1e6:.0f} MB ({results['held_bytes'] / n:.0f} B per "
            f"body), peak {results['peak_bytes'] / 1e6:.0f} MB "
            f"({results['peak_bytes'] / n:.0f} B per body); the process's peak resident size "
            f"grew by {results['maxrss_growth_bytes'] / 1e6:.0f} MB",
            f"a Plummer sphere of {n:,} stars under the tree (theta 0.5), built and stepped "
            f"twice (leapfrog), in a process of its own: peak resident memory "
            f"{results['tree_peak_bytes_per_body']:.0f} B per body (held: " +
            ", ".join(f"{k} {v} B" for k, v in results["tree_held_bytes_per_body"].items())
            + ")"])
    if results["benchmark"] == "models":
        o, f = results["orbits"], results["surface"]
        lines = lines[:1] + [
            f"orbits: a star (mass 1, G = 1) and N bodies at r = 1..3, 2D leapfrog, dt = "
            f"{o['dt']:.5f}, softening {o['softening']:g}; errors after T = {o['time']:.4f} "
            f"against the full N-body run (length units)",
            f"uniform field: projectiles 0..{f['max_height']:g} m above a planet of radius "
            f"{f['planet_radius']:g} m, dt = 1/240 s; errors after {f['time']:g} s against the "
            f"planet as a point mass (m)", "",
            "| model | bodies | time per step | per body-step | REBOUND / ours "
            "| max position error | median position error |", "|---|---|---|---|---|---|---|"]
        for c in results["cases"]:
            ratio = f"{c['ratio']:.1f}x" if "ratio" in c else "-"
            unit = " m" if c["model"] == "uniform" else ""
            errors = ("reference | reference" if c["model"] == "direct" else
                      f"{c['max_position_error']:.1e}{unit} | "
                      f"{c['median_position_error']:.1e}{unit}")
            lines.append(f"| {c['case'].split(',')[0]} | {c['bodies']:,} | "
                         f"{c['spacephys_s_per_step'] * 1e6:,.1f} us | "
                         f"{c['us_per_body_step']:.4f} us | {ratio} | {errors} |")
        lines.append("")
        for c in results["cases"]:
            if c["model"] == "direct":
                lines.append(f"{c['case']}: the star moved {c['star_displacement']:.1e}; "
                             f"REBOUND's velocities agree to {c['max_relative_difference']:.0e}")
            elif c["model"] == "central":
                lines.append(f"{c['case']}: differs from the test particles by "
                             f"{c['difference_from_test_particles']:.1e}")
            elif c["model"] == "uniform":
                lines.append(f"{c['case']}: relative force error {c['relative_force_error']:.2e} "
                             f"(2h/R = {f['two_h_over_R']:.2e})")
        return "\n".join(lines)
    if results["benchmark"] == "log":
        lines = lines[:1] + [
            f"{results['bodies']} bodies, 3D leapfrog, {results['steps']} steps in one call: "
            f"{results['base_us_per_step']:.0f} us per step without a log"]
        for c in results["cases"]:
            lines.append(f"{c['case']:34s} {c['overhead']:+7.1%} wall time, "
                         f"{c['us_per_frame']:6.1f} us and {c['bytes_per_frame'] / 1e3:6.1f} kB "
                         f"per frame")
        for r in results["rebound"]:
            lines.append(f"REBOUND Simulationarchive, a snapshot every {r['every']:>2} steps: "
                         f"{r['overhead']:+7.1%} wall time of its {results['rebound_us_per_step']:.0f}"
                         f" us steps, {r['us_per_frame']:6.1f} us per snapshot")
        return "\n".join(lines)
    if results["benchmark"] == "fleet":
        s = results["split_ms"]
        rest = results["median_ms"] - sum(s.values())
        return "\n".join(lines[:1] + [
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
            f"({results['gravity_ratio']:.1f}x)", ""] + _heavy_lines(
            f"the fleet battle as a game sets it up (10 planets, 200 ships, 2 000 missiles in "
            f"salvos, 50 000 debris, all destroying each other), {results['game']['steps']} "
            f"steps (goal: 95th percentile <= 8 ms, worst <= 16 ms, <= 1.5x with a core busy)",
            [(k, results["game"][k]) for k in ("quiet", "one core busy")]))
    if results["benchmark"] == "collisions":
        d = results["dense"]
        lines = lines[:1] + _heavy_lines(
            f"dense field: circles of radii 0.5..2 covering 10%, elastic, dt 0.01, "
            f"{d['steps']} steps (goal: 100 000 <= 30 ms, 200 000 / 100 000 <= 2.1); "
            f"200k/100k = {d['scaling']:.2f}",
            [(f"{n} circles, {k}", d["cases"][str(n)][k]) for n in d["sizes"]
             for k in ("quiet", "one core busy")]) + [""]
        for n, d in results["detection"].items():
            lines.append(f"{n:>7} circles: one broad + narrow pass {d['seconds'] * 1e3:7.2f} ms "
                         f"({d['pairs']} candidate pairs, {d['contacts']} contacts); a whole "
                         f"step with responses {d['full_step_seconds'] * 1e3:.1f} ms "
                         f"({d['events']} events)")
        lines.append(f"scaling: time({list(results['detection'])[1]}) / "
                     f"time({list(results['detection'])[0]}) = {results['scaling']:.2f}")
        bg = results["brute_vs_grid"]
        lines.append(f"{bg['bodies']} circles: brute force {bg['brute_seconds'] * 1e3:.1f} ms, "
                     f"grid {bg['grid_seconds'] * 1e3:.2f} ms "
                     f"({bg['brute_seconds'] / bg['grid_seconds']:.0f}x); pairs "
                     f"{bg['pairs_brute']} / {bg['pairs_grid']}")
        m = results["merging"]
        lines.append(f"{m['case']}: spacephys {m['spacephys_s_per_step'] * 1e3:.1f} ms/step, "
                     f"REBOUND {m['rebound_s_per_step'] * 1e3:.1f} ms/step ({m['ratio']:.1f}x); "
                     f"merges {m['merges']} / {m['rebound_merges']}, same masses: "
                     f"{m['same_masses']}, momentum difference {m['momentum_difference']:.1e}")
        return "\n".join(lines)
    if results["benchmark"] == "integrators":
        lines[1] = (f"{'case':62s} {'spacephys':>12s} {'REBOUND':>12s} {'speed-up':>9s} "
                    f"{'steps (ours/theirs)':>20s} {'max rel. diff':>14s}")
        for c in results["cases"]:
            steps = f"{c['steps']}/{c.get('rebound_steps', c['steps'])}"
            extra = (f"  energy error {c['energy_error']:.1e} (REBOUND {c['rebound_energy_error']:.1e})"
                     if "energy_error" in c else "")
            lines.append(f"{c['case']:62s} {c['spacephys_s_per_step'] * 1e6:9.2f} us "
                         f"{c['rebound_s_per_step'] * 1e6:9.2f} us {c['ratio']:8.2f}x "
                         f"{steps:>20s} {c['max_relative_difference']:14.1e}{extra}")
        return "\n".join(lines)
    for c in results["cases"]:
        lines.append(f"{c['case']:40s} {c['spacephys_s_per_step'] * 1e6:11.2f} us "
                     f"{c['rebound_s_per_step'] * 1e6:11.2f} us {c['ratio']:8.1f}x "
                     f"{c['spacephys_pairs_per_s']:15.3g} {c['max_relative_difference']:14.1e}")
    return "\n".join(lines)


def _overhead(quick=False):
    from .overhead import overhead
    return overhead(quick)


def _predict(quick=False):
    from .prediction import predict_bench
    return predict_bench(quick)


def _tree(quick=False):
    from .treebench import tree
    return tree(quick)


def _queries(quick=False):
    from .querybench import queries
    return queries(quick)


def _sweep(quick=False):
    from .sweepbench import sweep_bench
    return sweep_bench(quick)


def _compile(quick=False):
    from .compilebench import compile_bench
    return compile_bench(quick)


def _play(quick=False):
    from .playbench import play_bench
    return play_bench(quick)


BENCHMARKS = {"gravity": gravity, "integrators": integrators, "collisions": collisions,
              "fleet": fleet, "log": log, "memory": memory, "models": models,
              "overhead": _overhead, "predict": _predict, "tree": _tree, "queries": _queries,
              "sweep": _sweep, "play": _play, "compile": _compile}
