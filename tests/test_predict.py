"""Trajectory prediction (issue 15, items 1, 2 and 7): World.predict on a copy, its markers
checked against closed forms, the path equal to the flown one, predict_async beside a
stepping World, bad input."""
import math
import time

import numpy as np
import pytest

import spacephys as sp


def _kepler(e=0.6, dim=3, points=400, a=1.0):
    """A test particle on an ellipse about a central mass 1 (G = 1), at its pericentre."""
    w = sp.World(dim=dim, G=1.0, gravity="central", central_mass=1.0, integrator="gauss_radau")
    body = w.add_body(0.0, np.zeros(dim))
    w.set_orbit(body, a=a, e=e, i=0.3 if dim == 3 else 0.0, Omega=0.4, omega=1.1, f=-2.0)
    return w, body


def test_the_world_is_unchanged_by_a_prediction():
    """The whole World.state(), bit for bit, with a ship flying a plan and a different
    integrator for the prediction."""
    from spacephys.runs import _difference
    w = sp.World(dim=2, G=1.0, integrator="leapfrog", dt=1e-3)
    w.add_body(1.0, [0.0, 0.0])
    ship = w.add_ship(sp.ShipSpec(dry_mass=1.0, fuel_mass=1.0, max_thrust=0.1,
                                  exhaust_speed=1.0), [1.0, 0.0], [0.0, 1.0])
    w.plan(ship, [sp.Burn(0.01, 0.5)])
    w.step(3)
    before = w.state()
    w.predict(ship, 2.0, points=100)
    w.predict(ship, 2.0, points=100, integrator="gauss_radau", tolerance=1e-9)
    assert _difference(before, w.state(), "") is None


@pytest.mark.parametrize("dim", [2, 3])
def test_apsides_of_a_kepler_ellipse_match_the_closed_form(dim):
    """Pericentres at q = a (1 - e), apocentres at Q = a (1 + e), one period apart, from the
    time the elements give, with 40 samples an orbit: each apsis is taken on the conic
    osculating at the nearer sample (measured within 1.3e-15 of a in distance and 1.1e-15
    of the period in time; the Hermite cubic between samples alone was 6e-4 off)."""
    w, body = _kepler(dim=dim)
    el = w.elements(body)
    P = el.period
    pred = w.predict(body, 3.2 * P, points=129, tolerance=1e-12)
    peri = [a for a in pred.apsides if a.kind == "pericentre"]
    apo = [a for a in pred.apsides if a.kind == "apocentre"]
    span = 3.2 * P
    assert len(peri) == math.floor((span - el.time_to_pericentre) / P) + 1 >= 3
    assert len(apo) == math.floor((span - el.time_to_apocentre) / P) + 1 >= 3
    for k, a in enumerate(peri):
        assert a.distance == pytest.approx(el.pericentre, rel=1e-13)
        assert a.t == pytest.approx(w.t + el.time_to_pericentre + k * P, abs=1e-13 * P)
        assert a.about == -1
        assert np.linalg.norm(a.pos) == pytest.approx(a.distance, rel=1e-14)
        assert a.pos.shape == (dim,)
    for k, a in enumerate(apo):
        assert a.distance == pytest.approx(el.apocentre, rel=1e-13)
        assert a.t == pytest.approx(w.t + el.time_to_apocentre + k * P, abs=1e-13 * P)
    assert [a.t for a in pred.apsides] == sorted(a.t for a in pred.apsides)


def test_apsides_are_about_the_dominant_body_and_change_with_it():
    """A moon's orbit about a planet that orbits a star: the moon's apsides are about the
    planet (it pulls hardest), the planet's about the star."""
    w = sp.World(dim=2, G=1.0, integrator="yoshida6", dt=2e-3)
    star = w.add_body(1.0, [0.0, 0.0])
    planet = w.add_body(1e-3, [5.0, 0.0], [0.0, 1.0 / math.sqrt(5.0)])
    moon = w.add_body(0.0, [5.05, 0.0], [0.0, 1.0 / math.sqrt(5.0) + math.sqrt(1e-3 / 0.05)])
    pred = w.predict([moon, planet], 5.0, points=500)
    assert {a.about for a in pred.apsides if a.id == moon} == {planet}
    assert set(pred.about[0]) == {planet} and set(pred.about[1]) == {star}
    assert pred.changes == []


def test_closest_approach_of_straight_lines_is_exact():
    """Two bodies moving in straight lines (no gravity): the closest approach's time,
    distance and relative speed in closed form, from samples 0.1 apart (the refinement is
    exact for straight lines: the Hermite cubic of a line is the line)."""
    w = sp.World(dim=3, gravity="none", dt=0.01)
    a = w.add_body(1.0, [0.0, 0.0, 0.0], [1.0, 0.0, 0.0])
    b = w.add_body(1.0, [5.0, 3.0, 1.0], [-1.0, 0.5, 0.0])
    pred = w.predict(a, 10.0, points=101, target=b)
    (ap,) = pred.approaches
    r0, v = np.array([5.0, 3.0, 1.0]), np.array([-2.0, 0.5, 0.0])
    t = -r0 @ v / (v @ v)
    assert ap.target == b and ap.id == a
    assert ap.t == pytest.approx(t, rel=1e-13)
    assert ap.distance == pytest.approx(np.linalg.norm(r0 + v * t), rel=1e-13)
    assert ap.speed == pytest.approx(np.linalg.norm(v), rel=1e-13)


def test_change_of_dominant_body_is_where_the_pulls_are_equal():
    """A test particle flying straight past two fixed masses (4 and 1 at x = 0 and x = 10):
    the pulls are equal at x = 20/3: the change is found there (bisection on the Hermite
    interpolant between samples 0.05 apart) within 1e-6 of the crossing time a 20x finer
    prediction gives (measured 1.4e-9)."""
    w = sp.World(dim=2, G=1.0, dt=1e-3)
    big = w.add_body(4.0, [0.0, 0.0], fixed=True)
    small = w.add_body(1.0, [10.0, 0.0], fixed=True)
    probe = w.add_body(0.0, [3.0, 0.0], [3.0, 0.0])
    w.set_collision("body", "body", "ignore")
    # the probe is pulled: compute where it crosses x = 20/3 from a fine prediction
    pred = w.predict(probe, 2.5, points=51)
    (change,) = pred.changes
    assert (change.before, change.after, change.id) == (big, small, probe)
    fine = w.predict(probe, 2.5, points=2501)
    x = fine.pos[0, :, 0]
    t_cross = np.interp(20.0 / 3.0, x, fine.t)
    assert change.t == pytest.approx(t_cross, abs=1e-8)


def test_an_impact_ends_the_path_where_the_world_meets_it():
    """A ship falling onto a planet (ships destroyed on contact): the predicted impact has
    the time, the body hit and the point of the event the World then reports, the path is
    NaN after it, and the World itself still has the ship."""
    w = sp.World(dim=2, G=1.0, dt=1e-3)
    planet = w.add_body(1.0, [0.0, 0.0], radius=0.5)
    ship = w.add_ship(sp.ShipSpec(dry_mass=1e-3, fuel_mass=0.0, max_thrust=0.0, radius=0.01),
                      [2.0, 0.0], [0.0, 0.2])
    w.set_collision("ship", "planet", "destroy_a")
    w.set_collision("ship", "body", "destroy_a")
    pred = w.predict(ship, 5.0, points=501)
    (impact,) = pred.impacts
    assert impact.id == ship and impact.other == planet and impact.kind == "destroy"
    assert pred.ended[0] == impact.t
    after = pred.t > impact.t
    assert after.any() and np.isnan(pred.pos[0, after]).all()
    assert np.isfinite(pred.pos[0, ~after]).all()
    assert ship in w
    seen = None
    while seen is None:
        w.step(1)
        hits = [e for e in w.events if sp.EVENT_KINDS[e["kind"]] == "destroy"]
        seen = hits[0] if hits else None
    assert seen["time"] == impact.t
    np.testing.assert_array_equal([seen["x"], seen["y"]], impact.point)


def test_the_pericentre_of_a_hyperbolic_flyby_matches_the_closed_form():
    """e = 1.5, 3D: one pericentre, at q = a (1 - e) and the time the elements give, none
    after; the samples are 0.05 of the time to pericentre apart."""
    w = sp.World(dim=3, G=1.0, gravity="central", central_mass=1.0, integrator="gauss_radau")
    body = w.add_body(0.0, np.zeros(3))
    w.set_orbit(body, a=-1.0, e=1.5, i=0.7, Omega=0.2, omega=2.0, f=-1.5)
    el = w.elements(body)
    pred = w.predict(body, 2 * el.time_to_pericentre, points=41, tolerance=1e-12)
    (peri,) = pred.apsides
    assert peri.kind == "pericentre"
    assert peri.distance == pytest.approx(el.pericentre, rel=1e-13)
    assert peri.t == pytest.approx(w.t + el.time_to_pericentre, rel=1e-12)


def test_gauss_radau_prediction_matches_the_closed_form_orbit():
    """The adaptive integrator at tolerance 1e-12 samples a Kepler orbit within 1e-11 of
    Kepler's equation over 3 periods (fixed dt not given: points set the output times)."""
    w, body = _kepler(e=0.9)
    el = w.elements(body)
    pred = w.predict(body, 3 * el.period, points=61, tolerance=1e-12)
    for j in (0, 17, 60):
        dt = pred.t[j] - w.t
        M = el.M + 2 * math.pi * dt / el.period
        r, _ = sp.state_from_elements(el.mu, a=el.a, e=el.e, i=el.i, Omega=el.Omega,
                                      omega=el.omega, M=M)
        assert np.linalg.norm(pred.pos[0, j] - r) < 1e-11 * el.a


def test_predict_async_runs_beside_the_stepping_world_and_equals_predict():
    """The handle's result is the prediction of the state when predict_async was called,
    equal bit for bit to predict() then, while the World went on stepping."""
    w = sp.World(dim=2, G=1.0, integrator="leapfrog", dt=1e-3)
    w.add_body(1.0, [0.0, 0.0])
    body = w.add_body(0.0, [1.0, 0.0], [0.0, 1.0])
    expected = w.predict(body, 2000.0, points=300)
    handle = w.predict_async(body, 2000.0, points=300)
    steps = 0
    while not handle.done():
        w.step(10)
        steps += 10
    got = handle.result(timeout=60)
    assert np.array_equal(got.pos, expected.pos) and np.array_equal(got.t, expected.t)
    assert steps > 0 and w.t == pytest.approx(steps * 1e-3, rel=1e-12)
    # the next prediction reuses the worker's copy, brought up to date: the state now
    again = w.predict_async(body, 20.0, points=30)
    assert np.array_equal(again.result(timeout=60).pos, w.predict(body, 20.0, points=30).pos)
    # a prediction queued behind a running one can be cancelled; its copy is freed
    first = w.predict_async(body, 2000.0, points=300)
    queued = w.predict_async(body, 2000.0, points=300)
    while not (first.running() or first.done()):
        time.sleep(1e-4)
    assert queued.cancel() and not first.cancel()
    first.result(timeout=60)
    last = w.predict_async(body, 20.0, points=30)
    assert np.array_equal(last.result(timeout=60).pos, w.predict(body, 20.0, points=30).pos)


def test_bad_input_is_refused_naming_the_field_and_nothing_changes():
    w, body = _kepler()
    from spacephys.runs import _difference
    gone = w.add_body(0.0, [3.0, 0.0, 0.0])
    w.remove(gone)
    massless = w.add_body(0.0, [5.0, 0.0, 0.0])
    before = w.state()
    for kwargs, match in [
        (dict(ids=body, duration=-1.0), "duration = -1.0"),
        (dict(ids=body, duration=float("nan")), "duration"),
        (dict(ids=body, duration=float("inf")), "duration = inf"),
        (dict(ids=body, duration=1.0, points=1), "points"),
        (dict(ids=gone, duration=1.0), f"ids .*{gone}"),
        (dict(ids=[], duration=1.0), "ids"),
        (dict(ids="ship", duration=1.0), "ids"),
        (dict(ids=body, duration=1.0, target=gone), f"target = {gone}"),
        (dict(ids=body, duration=1.0, about=gone), f"about = {gone}"),
        (dict(ids=body, duration=1.0, about=massless), f"about = {massless}: a massless"),
        (dict(ids=body, duration=1.0, integrator="warp"), "integrator='warp'"),
        (dict(ids=body, duration=1.0, integrator="leapfrog", tolerance=1e-9),
         "tolerance = 1e-09"),
        (dict(ids=body, duration=1.0, dt=0.1), "dt = 0.1"),
        (dict(ids=body, duration=1.0, integrator="leapfrog", dt=-0.1), "dt = -0.1"),
    ]:
        with pytest.raises(ValueError, match=match):
            w.predict(**kwargs)
        with pytest.raises(ValueError, match=match):
            w.predict_async(**kwargs)
    assert _difference(before, w.state(), "") is None


def _fresh(w, *args, **kwargs):
    """A prediction from a fresh copy of the World (its kept copy dropped first)."""
    w.__dict__.pop("_shadows", None)
    return w.predict(*args, **kwargs)


@pytest.mark.parametrize("options", [{}, {"integrator": "gauss_radau", "tolerance": 1e-8},
                                     {"integrator": "rk4", "dt": 3e-3}])
def test_the_kept_copy_predicts_what_a_fresh_copy_predicts(options):
    """World.predict keeps its copy and brings it up to date from the World's arrays before
    each prediction. After every kind of change a game makes between steps (steps, controls,
    set_body, fuel, held forces, drag, dt, a launch, a plan, adding and removing bodies), its
    prediction equals a fresh copy's bit for bit: paths, times and events."""
    w = sp.World(dim=2, G=1.0, integrator="leapfrog", dt=2e-3)
    planet = w.add_body(1.0, [0.0, 0.0], radius=0.2, kind="planet")
    moon = w.add_body(1e-3, [3.0, 0.0], [0.0, 0.58], radius=0.05, kind="moon")
    spec = sp.ShipSpec(dry_mass=1e-3, fuel_mass=1e-3, max_thrust=2e-3, exhaust_speed=2.0,
                       turn_rate=2.0, radius=0.01)
    a = w.add_ship(spec, [1.0, 0.0], [0.0, 1.0])
    b = w.add_ship(spec, [-1.5, 0.0], [0.0, -0.8])
    w.set_collision("ship", "planet", "destroy_a")
    w.set_collision("missile", "ship", "destroy_both")
    missile = sp.MissileSpec(mass=1e-5, thrust=1e-4, fuel_mass=1e-5, exhaust_speed=1.0,
                             guidance="pn", turn_rate=3.0, fuse_radius=0.05, radius=0.005)

    def check():
        got = w.predict([a, moon], 1.5, points=40, target=b, **options)
        fresh = _fresh(w, [a, moon], 1.5, points=40, target=b, **options)
        for name in ("t", "pos", "vel", "ended", "about"):
            assert np.array_equal(getattr(got, name), getattr(fresh, name), equal_nan=True), name
        assert got.events.tobytes() == fresh.events.tobytes()
        key = lambda marks: [(m.id, m.t, m.distance) for m in marks]
        assert key(got.apsides) == key(fresh.apsides)
        assert key(got.approaches) == key(fresh.approaches)

    w.predict([a, moon], 1.5, points=40, target=b, **options)
    ops = [lambda: w.step(7),
           lambda: w.control(a, throttle=0.7, turn=0.5),
           lambda: w.step(3),
           lambda: w.set_body(b, pos=[-1.4, 0.2], vel=[0.1, -0.8]),
           lambda: w.set_fuel(a, 5e-4),
           lambda: w.apply_force(a, [1e-4, 0.0]),
           lambda: setattr(w, "drag", 0.01),
           lambda: w.step(11),
           lambda: setattr(w, "dt", 1e-3),
           lambda: w.launch(b, missile, target=a),
           lambda: w.step(5),
           lambda: w.plan(a, [sp.Burn(w.t + 0.1, 0.2, "retrograde", frame=planet)]),
           lambda: w.control(a, throttle=0.0, turn=0.0),
           lambda: w.step(20),
           lambda: w.add_body(1e-4, [0.0, 2.0], [-0.7, 0.0], radius=0.01),
           lambda: w.step(1)]
    for op in ops:
        op()
        check()


def test_closest_approach_between_samples_and_the_sample_schedule():
    """The closest approach of two straight lines falls between samples (t = 7.9 / 4.49,
    samples 0.1 apart) and is still exact; samples fall on the nearest whole steps, the
    first now and the last at the duration, and a middle row is read where it is."""
    w = sp.World(dim=3, gravity="none", dt=0.01)
    a = w.add_body(1.0, [0.0, 0.0, 0.0], [1.0, 0.0, 0.0])
    b = w.add_body(1.0, [5.0, 3.0, 1.0], [-1.0, 0.7, 0.0])
    w.add_body(1.0, [9.0, 9.0, 9.0])
    pred = w.predict(a, 10.0, points=101, target=b)
    (ap,) = pred.approaches
    r0, v = np.array([5.0, 3.0, 1.0]), np.array([-2.0, 0.7, 0.0])
    t = -r0 @ v / (v @ v)
    assert abs(t / 0.1 - round(t / 0.1)) > 0.1                 # between samples
    assert ap.t == pytest.approx(t, rel=1e-13)
    assert ap.distance == pytest.approx(np.linalg.norm(r0 + v * t), rel=1e-13)
    coarse = sp.World(dim=2, gravity="none", dt=0.1)
    coarse.add_body(1.0, [0.0, 0.0], [1.0, 0.0])
    middle = coarse.add_body(1.0, [5.0, 1.0], [0.0, 2.0])
    coarse.add_body(1.0, [9.0, 9.0])
    pred = coarse.predict(middle, 1.0, points=4)
    np.testing.assert_allclose(pred.t, [0.0, 0.3, 0.7, 1.0], rtol=0, atol=1e-15)
    np.testing.assert_allclose(pred.pos[0, :, 1], 1.0 + 2.0 * pred.t, atol=1e-14)
    np.testing.assert_allclose(pred.pos[0, :, 0], 5.0, atol=0)


def test_what_ends_a_path_and_what_is_an_impact():
    """A merge ends the merged-away body's path, not the survivor's; an expiry ends a path
    without an impact."""
    w = sp.World(dim=2, G=1.0, dt=1e-3, gravity="none")
    big = w.add_body(1.0, [0.0, 0.0], radius=0.1)
    small = w.add_body(0.1, [1.0, 0.0], [-1.0, 0.0], radius=0.1)
    w.set_collision("body", "body", "merge")
    pred = w.predict([big, small], 2.0, points=201)
    (ev,) = [e for e in pred.events if sp.EVENT_KINDS[e["kind"]] == "merge"]
    assert (int(ev["a"]), int(ev["b"])) == (big, small)
    assert pred.ended[0] == np.inf and pred.ended[1] == ev["time"]
    assert [(i.id, i.other, i.kind) for i in pred.impacts] == [(small, big, "merge")]
    w = sp.World(dim=2, gravity="none", dt=0.01)
    b = w.add_body(1.0, [0.0, 0.0], [1.0, 0.0], lifetime=0.505)
    pred = w.predict(b, 1.0, points=11)
    assert pred.impacts == [] and 0.5 <= pred.ended[0] <= 0.52
    assert np.isnan(pred.pos[0, pred.t > pred.ended[0]]).all()


def test_apsides_of_a_massive_pair_take_both_masses():
    """A moon of 0.2 about a star of 1: the relative orbit's mu is G (1 + 0.2); with the
    moon's own mass left out the conic's pericentre would be off by 1e-2."""
    w = sp.World(dim=2, G=1.0, integrator="gauss_radau")
    star = w.add_body(1.0, [0.0, 0.0])
    moon = w.add_body(0.2, [1.0, 0.0], [0.0, 1.3])
    el = w.elements(moon, star)
    assert el.mu == pytest.approx(1.2)
    pred = w.predict(moon, 2.2 * el.period, points=129, tolerance=1e-12)
    peri = [a for a in pred.apsides if a.kind == "pericentre" and a.about == star]
    assert len(peri) >= 2
    assert all(a.distance == pytest.approx(el.pericentre, rel=1e-10) for a in peri)


def _kept_equals_fresh(w, *args, **kwargs):
    got = w.predict(*args, **kwargs)
    fresh = _fresh(w, *args, **kwargs)
    assert np.array_equal(got.pos, fresh.pos, equal_nan=True)
    assert got.events.tobytes() == fresh.events.tobytes()


def _two_ships(integrator="leapfrog"):
    w = sp.World(dim=2, G=1.0, integrator=integrator, dt=2e-3)
    w.add_body(1.0, [0.0, 0.0], radius=0.2, kind="planet")
    spec = sp.ShipSpec(dry_mass=1e-3, fuel_mass=1e-3, max_thrust=2e-3, exhaust_speed=2.0,
                       turn_rate=2.0, radius=0.01)
    return w, w.add_ship(spec, [1.0, 0.0], [0.0, 1.0]), w.add_ship(spec, [-1.5, 0.0],
                                                                   [0.0, -0.8])


def test_the_kept_copy_carries_the_adaptive_step_launches_and_the_origin():
    """More cases for the kept copy, each reusing it (no rebuild between the two
    predictions): a Gauss-Radau World's carried step, a launch not yet reported (the kept
    copy must report it again), and plans about a shifted origin."""
    w, a, b = _two_ships("gauss_radau")
    w.predict(a, 1.5, points=40)
    w.step(5)
    _kept_equals_fresh(w, a, 1.5, points=40)
    w, a, b = _two_ships()
    w.launch(b, sp.MissileSpec(mass=1e-5, thrust=1e-4, fuel_mass=1e-5, exhaust_speed=1.0,
                               guidance="pn", turn_rate=3.0, fuse_radius=0.05, radius=0.005),
             target=a)
    first = w.predict(a, 1.5, points=40)
    assert any(sp.EVENT_KINDS[e["kind"]] == "launch" for e in first.events)
    _kept_equals_fresh(w, a, 1.5, points=40)
    w, a, b = _two_ships()
    w.plan(a, [sp.Burn(0.1, 0.3, "prograde")])
    w.plan(b, [sp.Burn(0.1, 0.3, [1.0, 0.0])])
    w.predict(a, 1.5, points=40)
    w.shift_origin([0.5, 0.25])
    _kept_equals_fresh(w, [a, b], 1.5, points=40)


@pytest.mark.parametrize("dim", [2, 3])
def test_a_coasting_prediction_is_the_path_with_the_controls_released(dim):
    """coast=True during a burn (throttle, turn, strafe held, and a plan ahead): bit for bit
    the prediction of a copy whose ship's controls were released and plan cleared by hand;
    a missile in flight keeps its motor; the World and its own (burning) prediction are
    unchanged, asked in either order, in the foreground and the background."""
    w = sp.World(dim=dim, G=1.0, integrator="leapfrog", dt=1e-3)
    w.add_body(1.0, np.zeros(dim))
    at = lambda *v: np.r_[v, np.zeros(dim - len(v))]
    spec = sp.ShipSpec(dry_mass=1.0, fuel_mass=1.0, max_thrust=0.2, exhaust_speed=1.0,
                       side_thrust=0.05, turn_rate=1.0)
    ship = w.add_ship(spec, at(1.0, 0.0), at(0.0, 1.0))
    w.control(ship, throttle=1.0, turn=0.5 if dim == 2 else (0.0, 0.0, 0.5),
              strafe=0.3 if dim == 2 else (0.3, 0.0))
    w.plan(ship, [sp.Burn(0.5, 0.2)])
    torpedo = w.launch(ship, sp.MissileSpec(mass=0.01, fuel_mass=0.01, thrust=0.01,
                                            exhaust_speed=1.0, launch_speed=0.1))
    w.step(5)
    burning = w.predict([ship, torpedo], 2.0, points=50)
    coasting = w.predict([ship, torpedo], 2.0, points=50, coast=True)
    by_hand = w.copy()
    by_hand.control(ship, throttle=0.0, turn=0.0 if dim == 2 else (0.0, 0.0, 0.0),
                    strafe=0.0 if dim == 2 else (0.0, 0.0))
    by_hand.plan(ship, [])
    want = by_hand.predict([ship, torpedo], 2.0, points=50)
    assert coasting.pos.tobytes() == want.pos.tobytes()
    assert coasting.vel.tobytes() == want.vel.tobytes()
    assert not np.array_equal(coasting.pos[0], burning.pos[0])        # the ship coasts
    # the torpedo (unguided, its motor running) flies the same path either way
    assert np.array_equal(coasting.pos[1], burning.pos[1])
    # asked again, after, in the background: the same; the World still burns
    assert w.predict([ship, torpedo], 2.0, points=50).pos.tobytes() == burning.pos.tobytes()
    again = w.predict_async([ship, torpedo], 2.0, points=50, coast=True).result(60)
    assert again.pos.tobytes() == coasting.pos.tobytes()
    assert w.planned(ship)
    w.step(round((burning.t[1] - burning.t[0]) / w.dt))       # it flies the burning path
    assert w.pos[w.index_of(ship)].tobytes() == burning.pos[0, 1].tobytes()
    with pytest.raises(ValueError, match="coast = 'yes'"):
        w.predict(ship, 1.0, coast="yes")


def _hud():
    """The benchmark's HUD case (spacephys bench predict): a ship on an orbit about the
    fourth of a star's 9 planets, 10 orbits, 1001 samples; and the Gauss-Radau reference."""
    from spacephys.study import prediction as P
    w, (ship,) = P.scene()
    ref = w.predict(ship, P.DURATION, points=P.POINTS, integrator="gauss_radau",
                    tolerance=1e-12).pos[0]
    return w, int(ship), P, ref


@pytest.mark.parametrize("error", [1e-4, 1e-6, 1e-8])
def test_a_prediction_given_an_error_meets_it_at_the_least_cost_tried(error, monkeypatch):
    """error= alone: the path is within error of the reference (relative to the ship's
    distance from its planet, the bench's measure), with the settings kept for the next call,
    which gives the same bits without trials. A tighter error costs more force evaluations
    (planted: a fixed yoshida6 at one step a sample fails 1e-8; a fixed yoshida8 at 4 steps
    a sample is no cheaper at 1e-4)."""
    from spacephys.integrators import get_integrator
    w, ship, P, ref = _hud()
    got = w.predict(ship, P.DURATION, points=P.POINTS, error=error)
    assert np.max(np.linalg.norm(got.pos[0] - ref, axis=1)) / P.R_SHIP <= error
    (name, dt, scale), = w.driver.choices.values()
    from spacephys import prediction_settings
    trials = []
    estimate = prediction_settings._estimate
    monkeypatch.setattr(prediction_settings, "_estimate",
                        lambda *args: trials.append(args) or estimate(*args))
    again = w.predict(ship, P.DURATION, points=P.POINTS, error=error)
    assert np.array_equal(again.pos, got.pos) and len(w.driver.choices) == 1 and not trials
    same = w.predict(ship, P.DURATION, points=P.POINTS, integrator=name, dt=dt)
    assert np.array_equal(same.pos, got.pos)
    per_sample = round(P.DURATION / (P.POINTS - 1) / dt)
    cost = per_sample * get_integrator(name).evaluations
    assert cost == {1e-4: 7, 1e-6: 7, 1e-8: 21}[error]


def test_a_kept_choice_is_made_again_when_the_scene_changes():
    """Moved to another planet (another body pulls hardest), the ship's prediction chooses
    anew; back where it was chosen, the first choice is used again."""
    w, ship, P, ref = _hud()
    w.predict(ship, P.DURATION, points=P.POINTS, error=1e-6)
    planet = w.ids[5]
    rel = w.pos[w.index_of(ship)] - w.pos[3]
    vrel = w.vel[w.index_of(ship)] - w.vel[3]
    w.set_body(ship, pos=w.pos[5] + rel, vel=w.vel[5] + vrel)
    w.predict(ship, P.DURATION, points=P.POINTS, error=1e-6)
    keys = list(w.driver.choices)
    assert len(keys) == 2 and keys[1][5] == np.array([planet], np.int64).tobytes()


def test_error_is_refused_with_settings_or_out_of_range():
    w, ship, P, ref = _hud()
    for bad, message in [(dict(error=0.0), "error = 0.0"), (dict(error=-1.0), "error"),
                         (dict(error=1e-6, integrator="leapfrog"), "not both"),
                         (dict(error=1e-6, dt=0.01), "not both")]:
        with pytest.raises(ValueError, match=message):
            w.predict(ship, 1.0, **bad)
    assert w.driver.choices == {}
