"""`spacephys bench gravity`: direct summation side by side with REBOUND in the same run,
reported as ratios.

Timings are the best of several alternating repeats (timing.py). Each case also checks that
both codes did the same work: the velocities after a few identical steps must agree to
round-off.
"""
import numpy as np

from ..scenes import uniform_sphere
from . import header, title
from . import rebound as peer
from .timing import leapfrog_case


def gravity(quick=False):
    """The gravity benchmark of the Core issue: direct summation, leapfrog, G = 1, eps = 1e-3.
    (Compile and start times: `spacephys bench compile`.)"""
    rebound = peer.load()
    repeats, budget = (2, 0.1) if quick else (5, 0.3)
    sizes = (256, 1024) if quick else (1024, 4096)
    cases = []
    for n in sizes:
        cases.append(leapfrog_case(f"leapfrog N={n}", uniform_sphere(n, dt=1e-4),
                                   repeats=repeats, budget=budget))
    cases.append(leapfrog_case("leapfrog N=16 (many steps per call)",
                               uniform_sphere(16, dt=1e-4), repeats=repeats, budget=budget))
    m, t = (100, 10_000) if quick else (1000, 100_000)
    w = uniform_sphere(m, dt=1e-4)
    rng = np.random.default_rng(2)
    p = rng.normal(size=(t, 3))
    w.add_bodies(0.0, p / np.linalg.norm(p, axis=1)[:, None] * rng.random((t, 1)) ** (1 / 3))
    cases.append(leapfrog_case(f"{m} massive + {t} test particles", w,
                               repeats=max(1, repeats - 2), budget=budget, n_active=m,
                               check_steps=2))
    return {**header("gravity", quick, rebound),
            "cases": cases}


def format_gravity(results):
    """The table of `spacephys bench gravity`: a line per case (text)."""
    lines = [title(results),
             f"{'case':40s} {'spacephys':>14s} {'REBOUND':>14s} {'speed-up':>9s} "
             f"{'pairs/s (ours)':>15s} {'max rel. diff':>14s}"]
    for c in results["cases"]:
        lines.append(f"{c['case']:40s} {c['spacephys_s_per_step'] * 1e6:11.2f} us "
                     f"{c['rebound_s_per_step'] * 1e6:11.2f} us {c['ratio']:8.1f}x "
                     f"{c['spacephys_pairs_per_s']:15.3g} {c['max_relative_difference']:14.1e}")
    return "\n".join(lines)
