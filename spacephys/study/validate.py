"""`spacephys validate`: every integrator on the reference problems, against REBOUND's IAS15.

For each problem the same initial conditions go to REBOUND 5.2 (IAS15, its default tolerance,
landing exactly on the final time) and to every integrator of the registry: the fixed-step
methods with the problem's step, Gauss-Radau with its default tolerance. Reported per pair: the
final position error relative to the system's size, max_i |x_i - x_i,ref| / max_i |x_i,ref|;
the relative energy error |E(T)/E(0) - 1|; steps and wall time. A method that cannot run a
problem (Wisdom-Holman without a dominant mass) is reported with its error message.
"""
import math
import time
from dataclasses import dataclass
from typing import Callable

import numpy as np

from ..integrators import INTEGRATORS
from ..kernels.wisdom_holman import kepler_drift
from ..orbits import elements_to_state, period
from ..scenes import FIGURE_EIGHT_PERIOD, kepler, outer_solar_system, pythagorean, figure_eight
from ..world import World


@dataclass(frozen=True)
class Problem:
    """build(**world) -> World; duration [time]; dt: the fixed-step methods' step; note."""
    build: Callable[..., World]
    duration: float
    dt: float
    note: str


def hyperbolic_flyby(**world):
    """A star (1) and a body (1e-3) on a hyperbolic orbit, e = 2, pericentre 0.5, passed at
    t = 10: the state at t = 0 comes from the exact two-body drift back from pericentre."""
    mu, q, e = 1.0 + 1e-3, 0.5, 2.0
    rel = np.array([[q, 0.0, 0.0]])
    vrel = np.array([[0.0, math.sqrt(mu * (1 + e) / q), 0.0]])
    kepler_drift(rel, vrel, 0, mu, -10.0)
    w = World(dim=2, **world)
    w.add_bodies([1.0, 1e-3], [[0.0, 0.0], rel[0, :2]], [[0.0, 0.0], vrel[0, :2]])
    w.move_to_center_of_mass()
    return w


def close_encounter(**world):
    """A star and two Jupiter-mass planets on circular orbits 0.05 apart, well inside their
    mutual Hill radius (0.07): at t = 0.69 the inner one overtakes the outer within 0.0046 and
    they scatter."""
    w = World(dim=3, **world)
    w.add_body(1.0, (0, 0, 0), kind="star")
    for a, f in ((1.0, 0.0), (1.05, 0.10)):
        p, v = elements_to_state(1.0 + 1e-3, a, 0.0, 0.01, f=f)
        w.add_body(1e-3, p, v, kind="planet")
    w.move_to_center_of_mass()
    return w


def _kepler(e):
    return lambda **kw: kepler(e, planet_mass=1e-3, **kw)


P1 = period(1.0 + 1e-3, 1.0)
PROBLEMS = {
    "kepler_e0": Problem(_kepler(0.0), 10 * P1, P1 / 200, "2 bodies (1, 1e-3), 10 orbits"),
    "kepler_e0.5": Problem(_kepler(0.5), 10 * P1, P1 / 500, "10 orbits"),
    "kepler_e0.9": Problem(_kepler(0.9), 10 * P1, P1 / 5000, "10 orbits"),
    "kepler_e0.99": Problem(_kepler(0.99), 10 * P1, P1 / 50000, "10 orbits"),
    "hyperbolic": Problem(hyperbolic_flyby, 20.0, 1e-3, "e = 2, pericentre 0.5 at t = 10"),
    "outer_solar_system": Problem(outer_solar_system, 1000.0, 0.1,
                                  "Sun, Jupiter..Neptune (HLW 2006), 1000 yr"),
    "pythagorean": Problem(pythagorean, 70.0, 1e-4, "masses 3, 4, 5 (Burrau), to t = 70"),
    "figure_eight": Problem(figure_eight, 10 * FIGURE_EIGHT_PERIOD, FIGURE_EIGHT_PERIOD / 1000,
                            "Chenciner-Montgomery, 10 periods"),
    "close_encounter": Problem(close_encounter, 5.0, 1e-3,
                               "2 planets pass within 0.0046 at t = 0.69"),
}


def _rebound_reference(w, duration):
    from . import rebound as peer
    sim = peer.simulation(w, "ias15")
    E0 = sim.energy()
    start = time.perf_counter()
    sim.integrate(duration)
    wall = time.perf_counter() - start
    xyz = peer.positions(sim)
    return {"pos": xyz[:, :w.dim], "energy_error": abs(sim.energy() / E0 - 1),
            "steps": int(sim.steps_done), "wall": wall}


def run_one(problem, integrator, reference):
    """Run `integrator` on `problem`; the result row as a dict."""
    adaptive = INTEGRATORS[integrator].adaptive
    # Gauss-Radau: one output interval, its own steps; the others: the problem's fixed step
    dt = problem.duration if adaptive else problem.dt
    w = problem.build(integrator=integrator, dt=dt)
    n = 1 if adaptive else max(1, round(problem.duration / problem.dt))
    E0 = w.energy()
    row = {"integrator": integrator}
    start = time.perf_counter()
    try:
        w.step(n)
    except FloatingPointError as err:
        row.update(status=f"failed: {str(err).split(':')[1].split('.')[0].strip()}")
        return row
    row["wall"] = time.perf_counter() - start
    ref = reference["pos"]
    row.update(status="ok",
               position_error=float(np.max(np.abs(w.pos - ref)) / np.max(np.abs(ref))),
               energy_error=float(abs(w.energy() / E0 - 1)),
               steps=w.integrator_stats["steps"] if adaptive else n)
    return row


def validate(problems=None, integrators=None):
    """Rows for every (problem, integrator) pair, plus REBOUND's own figures per problem."""
    problems = list(PROBLEMS) if not problems else problems
    integrators = list(INTEGRATORS) if not integrators else integrators
    for name in problems:
        if name not in PROBLEMS:
            raise ValueError(f"problem {name!r} is not known; valid: {', '.join(PROBLEMS)}")
    for name in integrators:
        if name not in INTEGRATORS:
            raise ValueError(f"integrator={name!r} is not known; valid: {', '.join(INTEGRATORS)}")
    results = {}
    for name in problems:
        problem = PROBLEMS[name]
        # compile every kernel outside the timings
        for integ in integrators:
            try:
                problem.build(integrator=integ, dt=problem.dt).step(1)
            except FloatingPointError:
                pass
        reference = _rebound_reference(problem.build(), problem.duration)
        rows = [run_one(problem, integ, reference) for integ in integrators]
        results[name] = {"note": problem.note, "duration": problem.duration, "dt": problem.dt,
                         "rebound_ias15": {k: v for k, v in reference.items() if k != "pos"},
                         "rows": rows}
    return results


MARKDOWN_HEADER = """# Validation against REBOUND

Regenerate with `spacephys validate --markdown docs/validation.md` (REBOUND 5.2, this
machine). Each problem starts from the same initial conditions in REBOUND (IAS15, default
tolerance, exact finish time) and in spacephys: the fixed-step methods use the problem's `dt`,
Gauss-Radau its default tolerance (1e-9). Position error: max_i |x_i - x_i,IAS15| over the
largest |x_i,IAS15|, at the final time. Energy error: |E(T)/E(0) - 1|. The Pythagorean problem
is chaotic: its close encounters amplify differences of 1e-11 into 1e-3 by t = 70, so two
correct integrators (or one at two tolerances) disagree at that level there.

"""


def format_markdown(results):
    lines = ["| problem | integrator | steps | position error vs IAS15 | energy error | wall [s] |",
             "|---|---|---:|---:|---:|---:|"]
    for name, res in results.items():
        ref = res["rebound_ias15"]
        lines.append(f"| **{name}** ({res['note']}; fixed dt = {res['dt']:.3g}) | REBOUND IAS15 "
                     f"| {ref['steps']} | (reference) | {ref['energy_error']:.1e} "
                     f"| {ref['wall']:.3f} |")
        for row in res["rows"]:
            if row["status"] != "ok":
                lines.append(f"| | {row['integrator']} | | {row['status']} | | |")
            else:
                lines.append(f"| | {row['integrator']} | {row['steps']} "
                             f"| {row['position_error']:.1e} | {row['energy_error']:.1e} "
                             f"| {row['wall']:.3f} |")
    return "\n".join(lines)
