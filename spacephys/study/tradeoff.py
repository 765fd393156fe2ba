"""The speed/accuracy trade, measured (`spacephys bench tradeoff`): for each scene, every
integrator that applies at a ladder of steps (tolerances for Gauss-Radau), the relative
energy error and the final position error against a converged Gauss-Radau reference, against
the wall time per unit of simulated time. Writes JSON, CSV and a log-log plot per scene, and
a table of the cheapest integrator meeting each error target."""
import csv
import json
import math
import os
import time

import numpy as np

from . import header
from .. import scenes
from ..entities import ShipSpec
from ..integrators import INTEGRATORS
from ..steppers import capabilities

# the candidates, from the registry: every fixed-step method, those made for one dominant
# mass (Wisdom-Holman, on the scenes that have one), the adaptive one at several tolerances
FIXED = [s.name for s in INTEGRATORS.values()
         if not s.adaptive and not capabilities(s.name).dominant_mass]
DOMINANT = [s.name for s in INTEGRATORS.values() if capabilities(s.name).dominant_mass]
ADAPTIVE = next(s.name for s in INTEGRATORS.values() if s.adaptive)
TARGETS = (1e-3, 1e-6, 1e-9)


def _kepler(**kw):
    return scenes.kepler(0.9, planet_mass=1e-3, **kw)


def _cluster(**kw):
    # 100 equal masses in a unit sphere with a little softening, set spinning slowly so
    # that it neither collapses at once nor flies apart
    w = scenes.uniform_sphere(100, seed=4, softening=0.02, **kw)
    w.set_body(0, vel=(0.0, 0.0, 0.0))
    return w


def _dogfight(**kw):
    # a ship burning (its mass falling) in orbit about a planet with a moon: thrust inside
    # every integrator. Its heading is held, so the continuous problem is well defined and
    # every integrator converges to it (a turning ship's thrust direction is set per step)
    w = scenes.kepler(0.1, planet_mass=1e-3, dim=2, **kw)
    ship = w.add_ship(ShipSpec(dry_mass=1.0, fuel_mass=1.0, max_thrust=0.05,
                               exhaust_speed=1.0), (0.0, 1.5), (-0.8, 0.0), heading=2.0)
    w.control(ship, throttle=1.0)
    return w


# name -> (build(**world), duration, dts (coarse to fine), Wisdom-Holman applies)
SCENES = {
    "kepler_e0.9": (_kepler, 4 * 2 * math.pi, [0.02, 0.01, 0.005, 0.0025, 0.00125], True),
    "outer_solar_system": (scenes.outer_solar_system, 1000.0, [0.5, 0.25, 0.1, 0.05, 0.02],
                           True),
    "cluster_100": (_cluster, 0.5, [0.01, 0.005, 0.0025, 0.00125, 0.000625], False),
    "dogfight": (_dogfight, 8.0, [0.04, 0.02, 0.01, 0.005, 0.0025], True),
}


def _run(build, name, dt, T, **kw):
    """(seconds of stepping, final World, energy error) for one integrator and step: the
    best of repeats from the same start until 0.05 s were spent (a short run's time is
    mostly noise otherwise)."""
    start_w = build(integrator=name, dt=dt, **kw)
    E0 = start_w.energy(True)
    warm = start_w.copy()
    warm.step(1)                                   # compile or load the kernel first
    n = max(1, round(T / dt))
    best, spent = math.inf, 0.0
    while spent < 0.05:
        w = start_w.copy()
        start = time.perf_counter()
        w.step(n)
        seconds = time.perf_counter() - start
        best, spent = min(best, seconds), spent + seconds
    E = w.energy(True)
    return best, w, abs(E - E0) / abs(E0) if E0 else abs(E - E0)


def study(quick=False, out_dir=None):
    """Run the study; returns the results (and writes files into out_dir if given)."""
    rows = []
    for scene, (build, T, dts, wh) in SCENES.items():
        if quick:
            T, dts = T / 4, dts[:3]
        # a whole number of the coarsest step (and so of every step of the ladder): every run
        # ends at the same time as the reference
        T = math.ceil(T / dts[0] - 1e-9) * dts[0]
        ref_w = build(integrator=ADAPTIVE, dt=T, tolerance=1e-12)
        ref_w.step(1)
        scale = max(float(np.max(np.abs(ref_w.pos))), 1e-300)
        plan = [(name, dt, {}) for name in FIXED for dt in dts]
        if wh:
            plan += [(name, dt, {}) for name in DOMINANT for dt in dts]
        tolerances = [1e-4, 1e-6, 1e-8] if quick else [1e-3, 1e-5, 1e-7, 1e-9]
        plan += [(ADAPTIVE, T / 100, {"tolerance": tol}) for tol in tolerances]
        for name, dt, kw in plan:
            try:
                seconds, w, energy_error = _run(build, name, dt, T, **kw)
            except (ValueError, FloatingPointError) as e:
                rows.append({"scene": scene, "integrator": name, "dt": dt, **kw,
                             "failed": str(e).split("\n")[0]})
                continue
            err = float(np.max(np.abs(w.pos - ref_w.pos))) / scale
            tol = kw.get("tolerance")
            rows.append({"scene": scene, "integrator": name, "dt": dt, "tolerance": tol,
                         "setting": f"dt {dt:g}" if tol is None else f"tol {tol:g}",
                         "steps": round(T / dt),
                         "seconds": seconds, "seconds_per_time": seconds / T,
                         "energy_error": energy_error,
                         "position_error": err if math.isfinite(err) else math.inf})
    results = {**header("tradeoff", quick), "rows": rows, "best": _cheapest(rows)}
    if out_dir is not None:
        _write(results, out_dir)
    return results


def _cheapest(rows):
    """scene -> target -> the cheapest run whose position error (relative to the scene's
    size) meets the target, or None."""
    best = {}
    for row in rows:
        if "failed" in row:
            continue
        for target in TARGETS:
            if row["position_error"] <= target:
                key = best.setdefault(row["scene"], {}).get(str(target))
                if key is None or row["seconds_per_time"] < key["seconds_per_time"]:
                    best[row["scene"]][str(target)] = row
    return best


def _write(results, out_dir):
    os.makedirs(out_dir, exist_ok=True)
    with open(os.path.join(out_dir, "tradeoff.json"), "w") as f:
        json.dump(results, f, indent=1)
    fields = ["scene", "integrator", "dt", "tolerance", "steps", "seconds", "seconds_per_time",
              "energy_error", "position_error", "failed"]
    with open(os.path.join(out_dir, "tradeoff.csv"), "w", newline="") as f:
        out = csv.DictWriter(f, fields)
        out.writeheader()
        for row in results["rows"]:
            out.writerow({k: row.get(k) for k in fields})
    from ..plot import _matplotlib
    plt = _matplotlib()
    for scene in SCENES:
        rows = [r for r in results["rows"] if r["scene"] == scene and "failed" not in r]
        if not rows:
            continue
        fig, axes = plt.subplots(1, 2, figsize=(12, 5))
        for name in dict.fromkeys(r["integrator"] for r in rows):
            mine = sorted((r for r in rows if r["integrator"] == name),
                          key=lambda r: r["seconds_per_time"])
            cost = [r["seconds_per_time"] for r in mine]
            for ax, key in zip(axes, ("position_error", "energy_error")):
                ax.loglog([max(r[key], 1e-17) for r in mine], cost, "o-", ms=3, label=name)
        for ax, what in zip(axes, ("final position error / scene size",
                                   "relative energy error |dE/E|")):
            ax.set_xlabel(what)
            ax.set_ylabel("wall seconds per unit of simulated time")
            ax.grid(True, which="both", alpha=0.3)
        axes[0].legend(fontsize=8)
        fig.suptitle(f"{scene}: work against precision (down and left is better)")
        fig.tight_layout()
        fig.savefig(os.path.join(out_dir, f"tradeoff_{scene}.png"), dpi=100)
        plt.close(fig)


def markdown(results):
    """The table of the cheapest integrator per scene and position-error target."""
    lines = ["| scene | " + " | ".join(f"error ≤ {t:g}" for t in TARGETS) + " |",
             "|---|" + "---|" * len(TARGETS)]
    for scene, by in results["best"].items():
        cells = []
        for t in TARGETS:
            r = by.get(str(t))
            if r is None:
                cells.append("none measured")
            else:
                cells.append(f"{r['integrator']} ({r['setting']}): "
                             f"{r['seconds_per_time'] * 1e3:.3g} ms per time unit")
        lines.append(f"| {scene} | " + " | ".join(cells) + " |")
    return "\n".join(lines)


# ----------------------------------------------------------------------------- peers

# ours -> REBOUND's integrator of the same method
PAIRS = {"leapfrog": "leapfrog", "wisdom_holman": "whfast", "gauss_radau": "ias15"}


def _rebound_run(w, integrator, dt, T, epsilon=None):
    """(best seconds, final positions (n, dim)) of REBOUND on World w's bodies."""
    from . import rebound as peer
    best, spent = math.inf, 0.0
    while spent < 0.05:
        settings = {"safe_mode": 0} if integrator == "whfast" else \
            {"epsilon": epsilon} if epsilon is not None else {}
        sim = peer.simulation(w, integrator, **settings)
        sim.dt = dt
        start = time.perf_counter()
        if integrator == "ias15":
            sim.integrate(T, exact_finish_time=1)
        else:
            sim.steps(max(1, round(T / dt)))
            sim.synchronize()
        seconds = time.perf_counter() - start
        best, spent = min(best, seconds), spent + seconds
    return best, peer.positions(sim)[:, :w.dim]


def peers(quick=False, out_dir=None):
    """The same scenes and ladders with REBOUND's leapfrog, WHFast and IAS15 beside ours;
    the cost ratio at equal accuracy, interpolated along each method's work-precision
    curve. Thrust has no REBOUND counterpart here: the dogfight is left out."""
    from . import rebound as peer
    rebound = peer.load()
    rows, ratios = [], []
    for scene, (build, T, dts, wh) in SCENES.items():
        if scene == "dogfight":
            continue
        if quick:
            T, dts = T / 4, dts[:3]
        T = math.ceil(T / dts[0] - 1e-9) * dts[0]
        ref_w = build(integrator="gauss_radau", dt=T, tolerance=1e-12)
        start_w = ref_w.copy()
        ref_w.step(1)
        scale = max(float(np.max(np.abs(ref_w.pos))), 1e-300)
        tolerances = [1e-4, 1e-6, 1e-8] if quick else [1e-3, 1e-5, 1e-7, 1e-9]
        for ours, theirs in PAIRS.items():
            if ours == "wisdom_holman" and not wh:
                continue
            # the adaptive ones integrate straight to T (no output intervals), as IAS15 does
            ladder = [(dt, None) for dt in dts] if ours != "gauss_radau" else \
                [(T, tol) for tol in tolerances]
            curve = {"spacephys": [], "rebound": []}
            for dt, tol in ladder:
                kw = {"tolerance": tol} if tol is not None else {}
                seconds, w, _ = _run(build, ours, dt, T, **kw)
                err = float(np.max(np.abs(w.pos - ref_w.pos))) / scale
                r_seconds, r_pos = _rebound_run(start_w, theirs, dt, T, epsilon=tol)
                r_err = float(np.max(np.abs(r_pos - ref_w.pos))) / scale
                for code, s, e in (("spacephys", seconds, err), ("rebound", r_seconds, r_err)):
                    rows.append({"scene": scene, "code": code,
                                 "integrator": ours if code == "spacephys" else theirs,
                                 "dt": dt, "tolerance": tol, "seconds_per_time": s / T,
                                 "position_error": e})
                    curve[code].append((e, s / T))
            ratios.append({"scene": scene, "spacephys": ours, "rebound": theirs,
                           "ratio": _equal_accuracy_ratio(curve["spacephys"],
                                                          curve["rebound"])})
    results = {**header("peers", quick, rebound), "rows": rows, "ratios": ratios}
    if out_dir is not None:
        os.makedirs(out_dir, exist_ok=True)
        with open(os.path.join(out_dir, "peers.json"), "w") as f:
            json.dump(results, f, indent=1)
    return results


def _equal_accuracy_ratio(ours, theirs):
    """Median over our points of REBOUND's cost / ours at the same position error, REBOUND's
    cost interpolated log-log along its curve (points outside its range are skipped; where
    both sit at the round-off floor, the cost at the same step is compared). None if the
    curves do not overlap."""
    theirs = sorted(theirs)
    errs = np.log([max(e, 1e-300) for e, _ in theirs])
    costs = np.log([c for _, c in theirs])
    out = []
    for e, c in ours:
        le = math.log(max(e, 1e-300))
        if errs.size and errs[0] <= le <= errs[-1] and errs[-1] > errs[0]:
            out.append(math.exp(float(np.interp(le, errs, costs))) / c)
    return float(np.median(out)) if out else None


def peers_markdown(results):
    lines = ["| scene | spacephys | REBOUND | REBOUND's cost / ours at equal accuracy |",
             "|---|---|---|---|"]
    for r in results["ratios"]:
        ratio = "curves do not overlap" if r["ratio"] is None else f"{r['ratio']:.2f}×"
        lines.append(f"| {r['scene']} | {r['spacephys']} | {r['rebound']} | {ratio} |")
    return "\n".join(lines)
