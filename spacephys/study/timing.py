"""What the benchmarks beside REBOUND share: best seconds per step of repeated runs, and one
leapfrog case timed on both codes.

Timings are the best of several repeats (the machine is shared and noisy; the minimum is the
least disturbed run of each code), the two codes run in turn so that a disturbance hits both
alike.
"""
import time

import numpy as np

from . import rebound as peer


def alternating(ours, theirs, steps, repeats):
    """Best seconds per step of ours(steps) and theirs(steps), called in turn."""
    best = [float("inf"), float("inf")]
    for _ in range(repeats):
        for k, run in enumerate((ours, theirs)):
            start = time.perf_counter()
            run(steps)
            best[k] = min(best[k], (time.perf_counter() - start) / steps)
    return best


def per_step(run, steps, repeats):
    """Best seconds per step of run(steps), over `repeats` calls."""
    best = float("inf")
    for _ in range(repeats):
        start = time.perf_counter()
        run(steps)
        best = min(best, (time.perf_counter() - start) / steps)
    return best


def steps_for(run, budget):
    """How many steps of `run` take about `budget` seconds (after one warm-up step)."""
    run(1)
    start = time.perf_counter()
    run(1)
    return max(1, int(budget / max(time.perf_counter() - start, 1e-9)))


def leapfrog_case(name, w, *, repeats, budget, n_active=None, check_steps=5):
    """Time a leapfrog step of World w and of REBOUND on the same bodies."""
    sim = peer.simulation(w, "leapfrog", gravity="basic", n_active=n_active)
    # same work: a few steps from identical states must agree to round-off. Velocities, not
    # positions: from rest, positions move by less than their own rounding in a few steps.
    a, s = w.copy(), peer.simulation(w, "leapfrog", gravity="basic", n_active=n_active)
    a.step(check_steps)
    s.steps(check_steps)
    agreement = float(np.max(np.abs(a.vel - peer.velocities(s)[:, :w.dim])) /
                      np.max(np.abs(a.vel)))

    ours = steps_for(w.step, budget)
    theirs = steps_for(sim.steps, budget)
    t_ours = t_theirs = float("inf")
    for _ in range(repeats):               # alternate, so a disturbance hits both alike
        t_ours = min(t_ours, per_step(w.step, ours, 1))
        t_theirs = min(t_theirs, per_step(sim.steps, theirs, 1))
    n_pull = n_active if n_active is not None else w.n
    pairs = n_pull * (n_pull - 1) + (w.n - n_pull) * n_pull
    return {"case": name, "bodies": w.n, "pulling": n_pull,
            "spacephys_s_per_step": t_ours, "rebound_s_per_step": t_theirs,
            "ratio": t_theirs / t_ours, "spacephys_pairs_per_s": pairs / t_ours,
            "rebound_pairs_per_s": pairs / t_theirs, "max_relative_difference": agreement}
