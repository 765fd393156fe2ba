"""`spacephys bench models`: what each gravity model costs and what it gets wrong, beside
REBOUND where it has the same model.
"""
import numpy as np

from . import header, title
from . import rebound as peer
from .timing import alternating, leapfrog_case, per_step, steps_for


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
        direct = leapfrog_case(f"full N-body, N={n}", _orbit_world("direct", n, dt, eps),
                               repeats=repeats, budget=budget)
        test = leapfrog_case(f"test particles, N={n}", _orbit_world("test", n, dt, eps),
                             repeats=repeats, budget=budget, n_active=1)
        central, surface = _orbit_world("central", n, dt, eps), _surface_world(n)
        k = steps_for(central.step, budget)
        surface.step(1)
        t_central, t_surface = alternating(central.step, surface.step, k, repeats)
        tree = _orbit_world("tree", n, dt, eps)
        t_tree = per_step(tree.step, steps_for(tree.step, budget), repeats)
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
    from .coastbench import coasting
    from .railsbench import rails
    return {**header("models", quick, rebound), "rails": rails(quick),
            "coasting": coasting(quick),
            "orbits": {"dt": dt, "steps": steps, "time": dt * steps, "softening": eps,
                       "body_mass": 1e-9, "star_mass": 1.0, "radii": [1.0, 3.0]},
            "surface": {"g": 9.81, "planet_radius": _R, "max_height": _H, "half_width": _X,
                        "dt": 1 / 240, "steps": 960, "time": 4.0, "two_h_over_R": 2 * _H / _R},
            "cases": cases}


def format_models(results):
    """The report of `spacephys bench models`: the two scenes, a markdown table with a row per
    case, and what the direct, central and uniform cases add (text)."""
    o, f = results["orbits"], results["surface"]
    lines = [
        title(results),
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
    if "rails" in results:
        from .railsbench import format_rails
        lines += ["", format_rails(results["rails"])]
    if "coasting" in results:
        from .coastbench import format_coasting
        lines += ["", format_coasting(results["coasting"])]
    return "\n".join(lines)
