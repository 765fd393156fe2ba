"""`spacephys bench tree`: the Barnes-Hut tree beside pytreegrav, REBOUND's tree and our own
direct summation, on the same positions, opening angles and softening; and the accuracy table
of docs/tree.md (`accuracy`).

Every time is one force evaluation of every body (the tree built inside the timing), the best
of a few repeats. Every error is the relative error |a - a_exact| / |a_exact| of each code
against its own exact sum (pytreegrav's softening kernel is not Plummer's), over up to 2 000
bodies drawn at random, reported as its RMS and maximum.
"""
from importlib import metadata

import numpy as np

from ..scenes import cold_disc_model, plummer_model
from . import best_of, header
from . import rebound as peer

EPS = 0.01                 # Plummer softening [length] (Plummer's sphere: scale length 1)
# pytreegrav softens with a spline kernel of support h; the same force at large distances
# and at the centre as Plummer's eps for h = 2.8 eps (Springel 2005, GADGET-2, section 2)
SPLINE_PER_PLUMMER = 2.8
CHECKED = 2000             # bodies the errors are measured on


def _world(pos, mass, gravity, theta=None, quadrupole=None, eps=EPS):
    """A World (G = 1, dim = pos's columns) of the bodies pos (n, dim), mass (n,) at rest."""
    from ..world import World
    tree = dict(theta=theta, quadrupole=quadrupole) if gravity == "tree" else {}
    w = World(dim=pos.shape[1], G=1.0, gravity=gravity, softening=eps, capacity=mass.size,
              **tree)
    w.add_bodies(mass, pos, kind="star")
    return w


def _errors(a, exact):
    e = np.linalg.norm(a - exact, axis=1) / np.linalg.norm(exact, axis=1)
    return float(np.sqrt(np.mean(e * e))), float(e.max())


def _checked(n, seed=0):
    return np.sort(np.random.default_rng(seed).choice(n, min(n, CHECKED), replace=False))


def accuracy(n=10_000, thetas=(0.3, 0.5, 0.7, 1.0)):
    """The accuracy table: RMS and maximum relative force error of the tree against direct
    summation on Plummer's sphere and on a cold exponential disc (2D), n bodies each, for
    every theta, with and without the quadrupole; and the time of each evaluation."""
    rows = []
    for model, (pos, _, mass), dim in (("plummer", plummer_model(n, seed=1), 3),
                                       ("cold disc", cold_disc_model(n, seed=1), 2)):
        pos = np.ascontiguousarray(pos[:, :dim])
        ids = _checked(n)
        exact = _world(pos, mass, "direct").gravity_accelerations(ids)
        for quadrupole in (True, False):
            for theta in thetas:
                w = _world(pos, mass, "tree", theta, quadrupole)
                w.gravity_accelerations(ids[:1])
                seconds, a = best_of(lambda: w.gravity_accelerations(), 3)
                rms, worst = _errors(a[ids], exact)
                rows.append({"model": model, "dim": dim, "bodies": n, "theta": theta,
                             "quadrupole": quadrupole, "rms_error": rms, "max_error": worst,
                             "seconds": seconds})
    return rows


def _pytreegrav_case(pytreegrav, pos, mass, theta, quadrupole, ids, repeats):
    h = np.full(mass.size, SPLINE_PER_PLUMMER * EPS)
    run = lambda: pytreegrav.Accel(pos, mass, h, theta=theta, parallel=True,
                                   quadrupole=quadrupole)
    seconds, a = best_of(run, repeats)
    exact = pytreegrav.AccelTarget(pos[ids], pos, mass, softening_target=h[ids],
                                   softening_source=h, method="bruteforce", parallel=True)
    rms, worst = _errors(a[ids], exact)
    return seconds, rms, worst


def _rebound_case(pos, mass, theta, ids, exact):
    """REBOUND's tree (monopole, its opening angle theta, one thread) for one leapfrog step
    from rest: its gravity is evaluated once per step, with the tree updated."""
    rebound = peer.load()
    sim = rebound.Simulation()
    sim.G = 1.0
    sim.softening = EPS
    sim.gravity = "tree"
    sim.opening_angle2 = theta * theta
    sim.root_size = 2.02 * float(np.abs(pos).max())
    sim.integrator = "leapfrog"
    sim.dt = 1e-12                   # a step that does not move the bodies in the measurement
    for m, p in zip(mass, pos):
        sim.add(m=float(m), x=p[0], y=p[1], z=p[2])
    sim.steps(1)
    seconds, _ = best_of(lambda: sim.steps(1), 2)
    acc = np.array([[sim.particles[int(i)].ax, sim.particles[int(i)].ay,
                     sim.particles[int(i)].az] for i in ids])
    rms, worst = _errors(acc, exact)
    return seconds, rms, worst


def _crossover(sizes, repeats):
    """Times of one evaluation by the tree (theta 0.5, quadrupole) and by direct summation,
    and the size where they cross (interpolated in log-log)."""
    rows = []
    for n in sizes:
        pos, _, mass = plummer_model(n, seed=2)
        t = {}
        for gravity in ("direct", "tree"):
            w = _world(pos, mass, gravity, 0.5 if gravity == "tree" else None)
            w.gravity_accelerations()
            t[gravity] = best_of(lambda: w.gravity_accelerations(), repeats)[0]
        rows.append({"bodies": n, "direct_s": t["direct"], "tree_s": t["tree"]})
    cross = None
    for a, b in zip(rows, rows[1:]):
        ra, rb = a["tree_s"] / a["direct_s"], b["tree_s"] / b["direct_s"]
        if ra >= 1.0 > rb:
            f = np.log(ra) / (np.log(ra) - np.log(rb))
            cross = float(np.exp(np.log(a["bodies"]) + f * (np.log(b["bodies"])
                                                            - np.log(a["bodies"]))))
    if cross is None and rows and rows[0]["tree_s"] < rows[0]["direct_s"]:
        cross = float(rows[0]["bodies"])            # the tree already wins at the smallest
    return rows, cross


def tree(quick=False, sizes=None):
    """The tree benchmark (see the module): for each size, our tree at several opening
    angles, pytreegrav's (monopole, its default, and quadrupole), REBOUND's tree (to 10^5
    bodies: one thread) and our direct summation (to 10^5), the crossover with direct, and
    the speed-up over pytreegrav at equal RMS error. sizes: the bodies of each case (default
    10^3 .. 10^6, --quick to 10^5)."""
    import pytreegrav
    rebound = peer.load()
    if sizes is None:
        sizes = (1_000, 10_000, 100_000) if quick else (1_000, 10_000, 100_000, 1_000_000)
    repeats = 2 if quick else 3
    ours_thetas = (0.5, 0.7, 1.0)
    theirs_thetas = (0.5, 0.7, 1.0)
    cases = []
    for n in sizes:
        pos, _, mass = plummer_model(n, seed=0)
        ids = _checked(n)
        exact = _world(pos, mass, "direct").gravity_accelerations(ids)
        for quadrupole in (True, False):
            for theta in ours_thetas if quadrupole else (0.7,):
                w = _world(pos, mass, "tree", theta, quadrupole)
                w.gravity_accelerations(ids[:1])
                seconds, a = best_of(lambda: w.gravity_accelerations(), repeats)
                rms, worst = _errors(a[ids], exact)
                cases.append({"code": "spacephys tree", "bodies": n, "theta": theta,
                              "quadrupole": quadrupole, "seconds": seconds,
                              "rms_error": rms, "max_error": worst})
        for quadrupole in (False, True):
            for theta in theirs_thetas if not quadrupole else (0.7,):
                seconds, rms, worst = _pytreegrav_case(pytreegrav, pos, mass, theta,
                                                       quadrupole, ids, repeats)
                cases.append({"code": "pytreegrav", "bodies": n, "theta": theta,
                              "quadrupole": quadrupole, "seconds": seconds,
                              "rms_error": rms, "max_error": worst})
        if n <= 100_000:
            w = _world(pos, mass, "direct")
            seconds, a = best_of(lambda: w.gravity_accelerations(), 1 if n >= 100_000 else repeats)
            cases.append({"code": "spacephys direct", "bodies": n, "theta": None,
                          "quadrupole": None, "seconds": seconds,
                          "rms_error": _errors(a[ids], exact)[0], "max_error": 0.0})
        if n <= (10_000 if quick else 100_000):
            seconds, rms, worst = _rebound_case(pos, mass, 0.5, ids, exact)
            cases.append({"code": "REBOUND tree", "bodies": n, "theta": 0.5,
                          "quadrupole": False, "seconds": seconds, "rms_error": rms,
                          "max_error": worst})
    crossover_rows, crossover = _crossover((500, 1000, 2000, 4000, 8000), repeats)
    return {**header("tree", quick, rebound),
            "softening": EPS, "pytreegrav_softening": SPLINE_PER_PLUMMER * EPS,
            "pytreegrav_version": metadata.version("pytreegrav"),
            "cases": cases, "equal_error": equal_error(cases),
            "crossover_rows": crossover_rows, "crossover_bodies": crossover}


def equal_error(cases):
    """Per size: pytreegrav at its default (theta 0.7, monopole) against our fastest
    evaluation of no larger RMS error: the two times and their ratio."""
    out = []
    for n in sorted({c["bodies"] for c in cases}):
        ref = [c for c in cases if c["bodies"] == n and c["code"] == "pytreegrav"
               and c["theta"] == 0.7 and not c["quadrupole"]]
        ours = [c for c in cases if c["bodies"] == n and c["code"] == "spacephys tree"]
        if not ref:
            continue
        ok = [c for c in ours if c["rms_error"] <= ref[0]["rms_error"]]
        if not ok:
            continue
        best = min(ok, key=lambda c: c["seconds"])
        out.append({"bodies": n, "pytreegrav_s": ref[0]["seconds"],
                    "pytreegrav_rms": ref[0]["rms_error"], "spacephys_s": best["seconds"],
                    "spacephys_rms": best["rms_error"], "spacephys_theta": best["theta"],
                    "spacephys_quadrupole": best["quadrupole"],
                    "speedup": ref[0]["seconds"] / best["seconds"]})
    return out


def format_tree(results):
    lines = [f"tree benchmark on {results['machine']} ({results['numba_threads']} numba "
             f"threads; {results['versions']}, pytreegrav {results['pytreegrav_version']}); "
             f"Plummer's sphere, softening {results['softening']} (pytreegrav's spline "
             f"h = {results['pytreegrav_softening']:.3g})",
             f"{'code':18s} {'N':>9s} {'theta':>6s} {'quad':>5s} {'s / evaluation':>15s} "
             f"{'RMS error':>10s} {'max error':>10s}"]
    for c in results["cases"]:
        theta = "" if c["theta"] is None else f"{c['theta']:.1f}"
        quad = "" if c["quadrupole"] is None else ("yes" if c["quadrupole"] else "no")
        lines.append(f"{c['code']:18s} {c['bodies']:9d} {theta:>6s} {quad:>5s} "
                     f"{c['seconds']:15.4g} {c['rms_error']:10.2e} {c['max_error']:10.2e}")
    lines.append("at equal RMS error (pytreegrav theta 0.7 monopole, its default):")
    for e in results["equal_error"]:
        lines.append(f"  N = {e['bodies']:>9d}: pytreegrav {e['pytreegrav_s']:.4g} s "
                     f"(RMS {e['pytreegrav_rms']:.2e}), spacephys {e['spacephys_s']:.4g} s "
                     f"(theta {e['spacephys_theta']}, "
                     f"{'quadrupole' if e['spacephys_quadrupole'] else 'monopole'}, RMS "
                     f"{e['spacephys_rms']:.2e}): {e['speedup']:.2f}x")
    lines.append("tree (theta 0.5) against direct summation, one evaluation:")
    for r in results["crossover_rows"]:
        lines.append(f"  N = {r['bodies']:>6d}: direct {r['direct_s'] * 1e3:8.3f} ms, "
                     f"tree {r['tree_s'] * 1e3:8.3f} ms")
    cross = results["crossover_bodies"]
    lines.append(f"crossover: {'none in the range' if cross is None else f'{cross:,.0f} bodies'}")
    return "\n".join(lines)


def _memory_child(n):
    """In a process of its own: the peak resident memory a Plummer sphere of n stars under
    the tree adds while it is built and takes two leapfrog steps, per body (the peak counter
    reset after the kernels are loaded and the model drawn). Prints JSON."""
    import json
    from pathlib import Path
    from ..scenes import plummer_sphere
    plummer_sphere(5000, theta=0.5).step(2)              # the kernels, loaded or compiled
    pos, vel, mass = plummer_model(n, seed=0)
    status = Path("/proc/self/status")
    Path("/proc/self/clear_refs").write_text("5")         # peak RSS := current RSS

    def kb(field):
        line = next(x for x in status.read_text().splitlines() if x.startswith(field))
        return int(line.split()[1]) * 1024
    base = kb("VmRSS:")
    w = _world(pos, mass, "tree", 0.5)
    w.step(2)
    peak = kb("VmHWM:")
    print(json.dumps({"bodies": n, "peak_growth_bytes": peak - base,
                      "held": w.bytes_per_body()}))


def memory(n):
    """(peak bytes per body, held bytes per body by part) of a tree World of n bodies
    stepping, measured in a child process (_memory_child)."""
    import json
    import subprocess
    import sys
    code = f"from spacephys.study.treebench import _memory_child; _memory_child({int(n)})"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True).stdout
    r = json.loads(out.strip().splitlines()[-1])
    return r["peak_growth_bytes"] / n, r["held"]
