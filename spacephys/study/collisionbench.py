"""`spacephys bench collisions`: the broad + narrow phase on circle fields (brute force
against the grid), the dense field of heavybench.py, and merging beside REBOUND.
"""
import time

import numpy as np

from . import header, title
from . import rebound as peer


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
    from ..kernels import broadphase, collide
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
        pairs = broadphase.brute_pairs(A, B, tb, plan.alive, plan.rules, lo, hi)
    else:
        pairs, _ = broadphase.candidate_pairs(A, B, tb, plan.alive, plan.rules, lo, hi)
    contacts = collide.pair_contacts(A, B, tb, pairs, L, plan.rules, None)[0].size
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
    from .heavybench import dense, dense_scaling
    return {**header("collisions", quick, rebound), "dense": dense(quick),
            "dense_scaling": dense_scaling(quick),
            "detection": passes, "scaling": passes[sizes[1]]["seconds"] / passes[sizes[0]]["seconds"],
            "brute_vs_grid": {"bodies": small.n, "brute_seconds": t_brute,
                              "grid_seconds": t_grid, "pairs_brute": pairs_brute,
                              "pairs_grid": pairs_grid},
            "merging": merge}


def format_collisions(results):
    """The report of `spacephys bench collisions` (text)."""
    from .heavybench import format_rows
    d = results["dense"]
    lines = [title(results)] + format_rows(
        f"dense field: circles of radii 0.5..2 covering 10%, elastic, dt 0.01, "
        f"{d['steps']} steps (goal: 100 000 <= 30 ms, 200 000 / 100 000 <= 2.1); "
        f"200k/100k = {d['scaling']:.2f}",
        [(f"{n} circles, {k}", d["cases"][str(n)][k]) for n in d["sizes"]
         for k in ("quiet", "one core busy")]) + [""]
    sc = results["dense_scaling"]
    lines.append(f"the dense field's step per body [ns] (median of "
                 f"{min(sc['steps'].values())}-{max(sc['steps'].values())} steps; goal: within "
                 f"1.3x from 12 500 to 800 000)")
    lines.append(f"{'circles':>9s} {'space order':>12s} {'creation order':>15s}")
    for n in sc["sizes"]:
        lines.append(f"{n:9d} {sc['space order'][str(n)]:12.1f} "
                     f"{sc['creation order'][str(n)]:15.1f}")
    lines.append(f"{'spread':>9s} {sc['space order spread']:11.2f}x "
                 f"{sc['creation order spread']:14.2f}x")
    lines.append("")
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
