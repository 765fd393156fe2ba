"""sp.recommend: the cheapest integrator and step meeting an error target, measured."""
import math
import time

import numpy as np
import pytest

import spacephys as sp
from spacephys import scenes
from spacephys.study import rebound as peer


def _kepler():
    return scenes.kepler(0.9, planet_mass=1e-3, dt=0.01)


@pytest.fixture(scope="module")
def kepler_choice():
    return sp.recommend(_kepler(), 1e-6)


def test_the_choice_meets_the_target_against_rebound(kepler_choice):
    """Applied to the scene and run over the trial horizon, the recommended setting ends
    within the target of REBOUND's IAS15 (each body's error over its distance to the other;
    energy too), and recommend left the World it was given unchanged."""
    rec = kepler_choice
    w = _kepler()
    before = w.pos.copy(), w.vel.copy(), w.integrator, w.dt
    rec2 = sp.recommend(w, 1e-6)
    assert np.array_equal(w.pos, before[0]) and (w.integrator, w.dt) == before[2:]
    assert rec2.integrator in ("wisdom_holman", "wisdom_holman_corrected", "gauss_radau")
    rec.apply(w)
    assert w.integrator == rec.integrator and w.dt == rec.dt
    H = rec.scene.horizon
    sim = peer.simulation(w, "ias15", dt=1e-3)          # REBOUND's own first step
    sim.integrate(H, exact_finish_time=1)
    E0 = w.energy()
    w.step(round(H / w.dt))
    assert abs(w.t - H) < 1e-9
    ref = peer.positions(sim)[:, :2]
    separation = np.linalg.norm(ref[1] - ref[0])
    assert np.abs(w.pos[:, :2] - ref).max() / separation < 1e-6
    assert abs(w.energy() / E0 - 1) < 1e-6
    assert rec.met and rec.error <= 1e-6


def test_it_is_the_cheapest_trial_that_met_the_target(kepler_choice):
    """Every trial that met the target cost at least as much as the choice; the trials cover
    the integrators that apply (Wisdom-Holman here: one dominant mass), and the reasons name
    the scene's dominant body, its eccentricity and what sets the shortest time."""
    rec = kepler_choice
    met = [r for r in rec.candidates if r["error"] <= 1e-6]
    assert all(r["cost"] >= rec.cost for r in met)
    tried = {r["integrator"] for r in rec.candidates}
    assert {"gauss_radau", "wisdom_holman", "leapfrog", "yoshida4", "yoshida6"} <= tried
    s = rec.scene
    assert s.dominant == 0 and s.mass_ratio == pytest.approx(1e-3)
    assert s.max_eccentricity == pytest.approx(0.9, abs=1e-9)
    assert s.min_pericentre == pytest.approx(0.1, rel=1e-9)
    assert "pericentre passage of body 1" in s.timescale_source
    assert s.timescale == pytest.approx(math.sqrt(0.1 ** 3 / (1.001 * 1.9)), rel=1e-9)
    text = str(rec)
    assert rec.integrator in text and "dominant body 0" in text


def _clocked_cost(setting, horizon):
    """Wall seconds per unit of simulated time of one setting (a candidate row: integrator,
    dt, tolerance) over the horizon, timed here rather than taken from recommend's table: the
    best of runs from a fresh World, at least 0.1 s of them and at least 5."""
    w = _kepler()
    w.integrator, w.dt = setting["integrator"], setting["dt"]
    if setting["tolerance"] is not None:
        w.tolerance = setting["tolerance"]
    n = round(horizon / w.dt)
    w.copy().step(1)                                  # the kernel loaded, not timed
    best, spent, runs = math.inf, 0.0, 0
    while spent < 0.1 or runs < 5:
        run = w.copy()
        start = time.perf_counter()
        run.step(n)
        took = time.perf_counter() - start
        best, spent, runs = min(best, took), spent + took, runs + 1
    return best / horizon


def test_the_choice_is_the_cheapest_by_a_clock_of_its_own(kepler_choice):
    """Every setting that met the target, timed again here: none is cheaper than the choice
    by more than timing noise (a factor 1.5). Measured: Wisdom-Holman at tau/1.3 and its
    corrected twin 0.06 ms per unit of time, Yoshida 6 and 8 and Gauss-Radau 0.6-1.8 ms. A
    cost booked per step instead of per unit of time passes the table's own check above and
    chooses a setting 700x dearer than the cheapest; this catches it."""
    rec = kepler_choice
    H = rec.scene.horizon
    met = [r for r in rec.candidates if r["error"] <= 1e-6]
    assert len({r["integrator"] for r in met}) >= 3
    setting = {"integrator": rec.integrator, "dt": rec.dt, "tolerance": rec.tolerance}
    # the choice clocked before and after the others, its best kept: a slow spell of this
    # shared machine during one clocking (seen once: 1.58x its corrected twin, the same
    # step) is not the choice's cost
    first = _clocked_cost(setting, H)
    costs = [_clocked_cost(r, H) for r in met]
    chosen = min(first, _clocked_cost(setting, H))
    assert chosen <= 1.5 * min(costs), (rec.integrator, chosen, sorted(zip(costs, met),
                                                                       key=lambda c: c[0])[0])


def test_a_looser_target_is_met_more_cheaply():
    """1e-2 instead of 1e-6: the choice costs no more, and its error is within 1e-2."""
    tight = sp.recommend(scenes.outer_solar_system(), 1e-9)
    loose = sp.recommend(scenes.outer_solar_system(), 1e-2)
    assert loose.met and tight.met
    assert loose.error <= 1e-2 and tight.error <= 1e-9
    # the loose trials include settings within 1e-2 that cost less than the tight choice
    assert min(r["cost"] for r in loose.candidates if r["error"] <= 1e-2) < tight.cost


def test_no_dominant_mass_no_wisdom_holman_and_a_budget_too_small():
    """A small cluster has no dominant body: Wisdom-Holman is not tried, and says why. A
    budget no run can meet returns the most accurate run within it... or of all, with
    met False and the reason."""
    w = scenes.uniform_sphere(12, seed=3, softening=0.05)
    rec = sp.recommend(w, 1e-4, budget=1e-9)
    assert not rec.met
    assert not any(r["integrator"].startswith("wisdom") for r in rec.candidates)
    assert any("Wisdom-Holman not tried: there is no dominant pulling body" in r
               for r in rec.reasons)
    assert any("no trial met error 0.0001 within the budget" in r for r in rec.reasons)
    assert rec.scene.dominant is None


def test_drag_is_judged_against_gauss_radau_and_leaves_out_wisdom_holman():
    """A projectile with drag in a uniform field: Gauss-Radau takes drag and is both the
    reference and a candidate; Wisdom-Holman (no dominant mass) is not tried, and says why;
    energy is not conserved."""
    rec = sp.recommend("projectile", 1e-8)
    assert rec.met
    assert not rec.scene.conserves_energy
    tried = {r["integrator"] for r in rec.candidates}
    assert "gauss_radau" in tried and "wisdom_holman" not in tried
    assert any("Wisdom-Holman not tried: it needs gravity='direct'" in r for r in rec.reasons)
    assert any("against Gauss-Radau at 1e-12" in r for r in rec.reasons)


def test_model_advice_for_light_bodies_and_a_planet_surface():
    """Bodies lighter than the target fraction of the star: as test particles. Bodies within
    a few metres of a planet's surface: the uniform field, with its g."""
    w = scenes.kepler(0.1, planet_mass=1e-9)
    rec = sp.recommend(w, 1e-6)
    assert any("1 pulling bodies have less than 1e-06 of the dominant mass" in a
               for a in rec.scene.advice)
    surface = sp.World(dim=2, units="si", dt=0.01)
    R, M = 6.371e6, 5.972e24
    surface.add_body(M, (0, 0), radius=R, kind="planet")
    surface.add_body(1.0, (0, R + 10.0), (30.0, 20.0), kind="asteroid")
    rec = sp.recommend(surface, 1e-3, duration=2.0)
    advice = " ".join(rec.scene.advice)
    assert "gravity='uniform'" in advice and "|g| = 9.8" in advice


def test_chaotic_scene_relaxes_positions_and_says_so():
    """The Pythagorean problem over its whole run: Gauss-Radau at 1e-9 and 1e-12 end apart
    (measured 5e-3 of the bodies' separations), so positions are held to ten times that and
    energy to the target, which only Gauss-Radau reaches (the fixed-step methods at tau/20
    are off by orders of magnitude after the close encounters)."""
    w = scenes.pythagorean(integrator="gauss_radau", dt=0.1)
    rec = sp.recommend(w, 1e-9, duration=70.0)
    assert rec.scene.chaotic and rec.scene.horizon == 70.0
    assert any("chaotic over the horizon" in r for r in rec.reasons)
    assert rec.met and rec.integrator == "gauss_radau"
    best = [r for r in rec.candidates if r["integrator"] == "gauss_radau"
            and r["tolerance"] == rec.tolerance][0]
    assert best["energy_error"] <= 1e-9 and best["position_error"] > 1e-9


def test_bad_input_names_the_field():
    w = _kepler()
    with pytest.raises(ValueError, match="error = 0"):
        sp.recommend(w, 0.0)
    with pytest.raises(ValueError, match="budget"):
        sp.recommend(w, 1e-6, budget=-1.0)
    with pytest.raises(ValueError, match="duration"):
        sp.recommend(w, 1e-6, duration=math.nan)
    with pytest.raises(ValueError, match="no bodies"):
        sp.recommend(sp.World(), 1e-6)


def test_the_command_prints_the_choice_and_writes_every_trial(tmp_path, capsys):
    """`spacephys recommend two_body --json`: exit 0, the choice and its reasons printed, the
    JSON holds the same choice and every trial; an unknown scene is exit 2 with no
    traceback."""
    import json

    from spacephys.cli import main
    path = tmp_path / "rec.json"
    assert main(["recommend", "two_body", "--error", "1e-6", "--json", str(path)]) == 0
    out = capsys.readouterr().out
    data = json.loads(path.read_text())
    assert out.startswith(data["integrator"]) and "shortest dynamical time" in out
    assert data["met"] and data["error"] <= 1e-6 and len(data["candidates"]) >= 5
    assert data["scene"]["dominant"] == 0
    assert main(["recommend", "no_such_scene"]) == 2
    assert "no_such_scene" in capsys.readouterr().err


def test_the_returned_step_is_the_one_timed():
    """Every setting returned is a trial's: its dt (for Gauss-Radau the World's own output
    interval, at whose multiples it must land) and its measured cost and error."""
    for w in (_kepler(), scenes.pythagorean(dt=0.05)):
        rec = sp.recommend(w, 1e-6)
        row = [r for r in rec.candidates if r["integrator"] == rec.integrator
               and r["dt"] == rec.dt and r["tolerance"] == rec.tolerance]
        assert row and row[0]["cost"] == rec.cost and row[0]["error"] == rec.error
        gr = [r for r in rec.candidates if r["integrator"] == "gauss_radau"]
        assert all(r["dt"] == w.dt for r in gr)


def test_collisions_and_explosions_are_judged_not_crashed():
    """A ship falling onto a planet that destroys it (at t = 2.89) and throws debris: the
    trials are judged against the reference's bodies, debris included (before, a KeyError),
    and the reasons say that outcomes after a contact shift with the step. Here no trial
    reaches 1e-6 (the floor is about 1e-4), so the most accurate is returned, met False."""
    w = sp.World(dim=2, dt=0.01)
    w.add_body(1000.0, (0, 0), radius=19.0, kind="planet")
    w.add_ship(sp.ShipSpec(dry_mass=1.0, radius=0.5,
                           explosion=sp.ExplosionSpec(count=6, speed=2.0, lifetime=5.0)),
               (25.0, 0.0), (0.0, 3.0))
    w.set_collision("ship", "planet", "destroy_a")
    rec = sp.recommend(w, 1e-6, duration=4.0)
    judged = [r for r in rec.candidates if math.isfinite(r["error"])]
    assert len(judged) > 5 and math.isfinite(rec.error)
    assert rec.error == min(r["error"] for r in judged)
    assert any("a contact is found at the end of the step" in r for r in rec.reasons)
    assert not rec.met and any("no trial met error 1e-06" in r for r in rec.reasons)


def test_a_central_field_far_from_the_origin_is_judged_on_the_orbit():
    """A unit orbit in a central field at (1000, 0): positions are judged against the orbit
    (distance to the field's centre), not the distance to the origin, and the far coordinates
    do not break the reference: the claimed error holds against the closed form."""
    w = sp.World(dim=2, gravity="central", central_mass=1.0, central_pos=(1000.0, 0.0),
                 dt=0.01)
    w.add_body(0.0, (1001.0, 0.0), (0.0, 1.0))
    rec = sp.recommend(w, 1e-6)
    rec.apply(w)
    w.step(round(rec.scene.horizon / w.dt))
    p, _ = sp.kepler_state(1.0, 1.0, 0.0, w.t)
    assert np.abs(w.pos[0] - (1000.0, 0.0) - p[:2]).max() < 1e-6 + 2e-13 * 1000


def test_rails_and_coasting_are_proposed_where_kepler_meets_the_target(kepler_choice):
    """Measured against the reference run: a planet alone about its star keeps its Kepler
    orbit (two bodies: exact), so rails and coasting are proposed for every body; with a
    Jupiter beside it, an asteroid's Kepler orbit drifts by far more than 1e-6 in the
    horizon, and only the bodies that do meet it are named."""
    advice = " ".join(kepler_choice.scene.advice)
    assert "every other body ends the horizon within" in advice and "set_rails" in advice
    w = sp.World(2, G=1.0, dt=0.01)
    w.add_body(1.0, (0.0, 0.0))
    jupiter = w.add_body(1e-3, (5.2, 0.0), (0.0, math.sqrt(1.001 / 5.2)))
    rock = w.add_body(0.0, (0.0, 3.0), (-math.sqrt(1 / 3.0), 0.0))
    rec = sp.recommend(w, 1e-6, duration=20.0)
    advice = " ".join(rec.scene.advice)
    assert f"1 of 2 bodies end the horizon on their Kepler orbits" in advice
    assert f"(ids [{jupiter}])" in advice and "set_rails" not in advice
