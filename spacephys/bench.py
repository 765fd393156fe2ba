"""`spacephys bench`: spacephys side by side with REBOUND in the same run, reported as ratios.

Timings are the best of several alternating repeats (the machine is shared and noisy; the
minimum is the least disturbed run of each code). Each case also checks that both codes did
the same work: the positions after a few identical steps must agree to round-off.
"""
import os
import platform
import subprocess
import sys
import tempfile
import time

import numpy as np

from .scenes import uniform_sphere


def _rebound():
    try:
        import rebound
    except ImportError:
        raise ValueError("the benchmarks compare with REBOUND: pip install 'spacephys[test]'") from None
    return rebound


def _rebound_sim(w, *, n_active=None):
    """A REBOUND leapfrog simulation with w's bodies, G, softening and dt (gravity "basic")."""
    rebound = _rebound()
    sim = rebound.Simulation()
    sim.G = w.G
    sim.softening = w.softening
    sim.integrator = "leapfrog"
    sim.gravity = "basic"
    sim.dt = w.dt
    for m, p, v in zip(w.mass, w.pos, w.vel):
        sim.add(m=float(m), x=p[0], y=p[1], z=p[2], vx=v[0], vy=v[1], vz=v[2])
    if n_active is not None:
        sim.N_active = n_active
        sim.testparticle_type = 0          # test particles feel, do not pull: as spacephys
    return sim


def _rebound_velocities(sim):
    v = np.empty((sim.N, 3))
    sim.serialize_particle_data(vxvyvz=v)
    return v


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
    sim = _rebound_sim(w, n_active=n_active)
    # same work: a few steps from identical states must agree to round-off. Velocities, not
    # positions: from rest, positions move by less than their own rounding in a few steps.
    a, s = w.copy(), _rebound_sim(w, n_active=n_active)
    a.step(check_steps)
    s.steps(check_steps)
    agreement = float(np.max(np.abs(a.vel - _rebound_velocities(s))) / np.max(np.abs(a.vel)))

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


_COMPILE_PROBE = """
import time
start = time.perf_counter()
import numpy as np
import spacephys as sp
from spacephys.scenes import uniform_sphere
imported = time.perf_counter()
w = uniform_sphere(64, dt=1e-3)
w.step(1)
first = time.perf_counter()
for name in sp.INTEGRATORS:
    w.integrator = name
    w.step(1)
w.energy()
every = time.perf_counter()
print(imported - start, first - start, every - start)
"""


def _compile_times():
    """Seconds for import, import + first leapfrog step, and every kernel: cold, then warm."""
    with tempfile.TemporaryDirectory() as cache:
        env = dict(os.environ, NUMBA_CACHE_DIR=cache)
        out = {}
        for label in ("cold", "warm"):
            res = subprocess.run([sys.executable, "-c", _COMPILE_PROBE], env=env, check=True,
                                 capture_output=True, text=True)
            imp, first, every = map(float, res.stdout.split())
            out[label] = {"import_s": imp, "import_and_first_step_s": first,
                          "all_kernels_s": every}
        return out


def gravity(quick=False):
    """The gravity benchmark of the Core issue: direct summation, leapfrog, G = 1, eps = 1e-3."""
    import numba
    rebound = _rebound()
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
    return {"benchmark": "gravity", "quick": quick,
            "machine": f"{platform.processor() or platform.machine()}, {os.cpu_count()} cores",
            "numba_threads": numba.get_num_threads(),
            "versions": {"numba": numba.__version__, "numpy": np.__version__,
                         "rebound": rebound.__version__},
            "cases": cases, "compile": _compile_times()}


def _rebound_copy(w, integrator, **settings):
    rebound = _rebound()
    sim = rebound.Simulation()
    sim.G = w.G
    sim.softening = w.softening
    sim.integrator = integrator
    sim.dt = w.dt
    for key, value in settings.items():
        setattr(sim.integrator, key, value)
    pos = np.zeros((w.n, 3))
    vel = np.zeros((w.n, 3))
    pos[:, :w.dim], vel[:, :w.dim] = w.pos, w.vel
    for m, p, v in zip(w.mass, pos, vel):
        sim.add(m=float(m), x=p[0], y=p[1], z=p[2], vx=v[0], vy=v[1], vz=v[2])
    return sim


def _positions(sim):
    xyz = np.empty((sim.N, 3))
    sim.serialize_particle_data(xyz=xyz)
    return xyz


def _gauss_radau_case(n, duration, repeats):
    """Gauss-Radau and IAS15 over the same interval of the same cluster: time per step."""
    from .scenes import uniform_sphere
    make = lambda: uniform_sphere(n, seed=1, softening=0.01, integrator="gauss_radau",
                                  dt=duration)
    make().step(1)                                      # compile outside the timing
    best_ours = best_theirs = float("inf")
    for _ in range(repeats):
        w = make()
        sim = _rebound_copy(w, "ias15")
        start = time.perf_counter()
        w.step(1)
        ours = time.perf_counter() - start
        start = time.perf_counter()
        sim.integrate(duration)
        theirs = time.perf_counter() - start
        steps, rsteps = w.integrator_stats["steps"], int(sim.steps_done)
        best_ours = min(best_ours, ours / steps)
        best_theirs = min(best_theirs, theirs / rsteps)
    diff = float(np.max(np.abs(w.pos - _positions(sim))) / np.max(np.abs(w.pos)))
    return {"case": f"gauss_radau vs IAS15, N={n}, t={duration:g}", "bodies": n,
            "steps": steps, "rebound_steps": rsteps,
            "spacephys_s_per_step": best_ours, "rebound_s_per_step": best_theirs,
            "ratio": best_theirs / best_ours, "max_relative_difference": diff}


def _wisdom_holman_case(corrector, steps, repeats):
    """Sun + 8 planets, 5-day steps: WH and WHFast (safe mode off: both synchronise at the
    end of the batch only)."""
    from .scenes import solar_system
    name = "wisdom_holman_corrected" if corrector else "wisdom_holman"
    w = solar_system(integrator=name, dt=5 / 365.25)
    sim = _rebound_copy(w, "whfast", corrector=corrector, safe_mode=0)
    E0, E0r = w.energy(), sim.energy()
    w.step(1)
    sim.steps(1)
    t_ours = t_theirs = float("inf")
    for _ in range(repeats):
        start = time.perf_counter()
        w.step(steps)
        t_ours = min(t_ours, (time.perf_counter() - start) / steps)
        start = time.perf_counter()
        sim.steps(steps)
        t_theirs = min(t_theirs, (time.perf_counter() - start) / steps)
    sim.synchronize()
    diff = float(np.max(np.abs(w.pos - _positions(sim))) / np.max(np.abs(w.pos)))
    return {"case": f"{name} vs WHFast{' (corrector 3)' if corrector else ''}, Sun + 8 "
                    f"planets, dt = 5 d", "bodies": w.n, "steps": 1 + repeats * steps,
            "spacephys_s_per_step": t_ours, "rebound_s_per_step": t_theirs,
            "ratio": t_theirs / t_ours, "max_relative_difference": diff,
            "energy_error": float(abs(w.energy() / E0 - 1)),
            "rebound_energy_error": float(abs(sim.energy() / E0r - 1))}


def integrators(quick=False):
    """The high-accuracy integrators against REBOUND's: IAS15 and WHFast, same problems."""
    import numba
    rebound = _rebound()
    repeats = 2 if quick else 3
    cases = [_gauss_radau_case(16, 0.5 if quick else 2.0, repeats),
             _gauss_radau_case(256 if quick else 1024, 0.01 if quick else 0.05, 1)]
    for corrector in (0, 3):
        cases.append(_wisdom_holman_case(corrector, 10_000 if quick else 33_333, repeats))
    return {"benchmark": "integrators", "quick": quick,
            "machine": f"{platform.processor() or platform.machine()}, {os.cpu_count()} cores",
            "numba_threads": numba.get_num_threads(),
            "versions": {"numba": numba.__version__, "numpy": np.__version__,
                         "rebound": rebound.__version__},
            "cases": cases}


def format_table(results):
    lines = [f"{results['benchmark']} benchmark on {results['machine']} "
             f"({results['numba_threads']} numba threads; {results['versions']})",
             f"{'case':40s} {'spacephys':>14s} {'REBOUND':>14s} {'speed-up':>9s} "
             f"{'pairs/s (ours)':>15s} {'max rel. diff':>14s}"]
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
    cold, warm = results["compile"]["cold"], results["compile"]["warm"]
    lines.append(f"cold numba cache: import + first leapfrog step {cold['import_and_first_step_s']:.2f} s, "
                 f"every integrator and the energy {cold['all_kernels_s']:.2f} s")
    lines.append(f"warm numba cache: import {warm['import_s']:.2f} s, import + first step "
                 f"{warm['import_and_first_step_s']:.2f} s, every kernel {warm['all_kernels_s']:.2f} s")
    return "\n".join(lines)


BENCHMARKS = {"gravity": gravity, "integrators": integrators}
