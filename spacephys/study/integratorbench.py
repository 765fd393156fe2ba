"""`spacephys bench integrators`: the high-accuracy integrators beside REBOUND's in the same
run: Gauss-Radau against IAS15 and Wisdom-Holman against WHFast, on the same problems.
"""
import numpy as np

from . import header, title
from . import rebound as peer
from .timing import alternating


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
    t_ours, t_theirs = alternating(w.step, sim.steps, steps, repeats)
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


def format_integrators(results):
    """The table of `spacephys bench integrators`: a line per case (text)."""
    lines = [title(results),
             f"{'case':62s} {'spacephys':>12s} {'REBOUND':>12s} {'speed-up':>9s} "
             f"{'steps (ours/theirs)':>20s} {'max rel. diff':>14s}"]
    for c in results["cases"]:
        steps = f"{c['steps']}/{c.get('rebound_steps', c['steps'])}"
        extra = (f"  energy error {c['energy_error']:.1e} (REBOUND {c['rebound_energy_error']:.1e})"
                 if "energy_error" in c else "")
        lines.append(f"{c['case']:62s} {c['spacephys_s_per_step'] * 1e6:9.2f} us "
                     f"{c['rebound_s_per_step'] * 1e6:9.2f} us {c['ratio']:8.2f}x "
                     f"{steps:>20s} {c['max_relative_difference']:14.1e}{extra}")
    return "\n".join(lines)
