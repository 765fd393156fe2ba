"""Bodies on rails (World.set_rails): Kepler orbits that do not drift (after 10^6 periods the
place is the analytic orbit's, computed here in 80-bit long doubles), nested rails, every
integrator seeing the rails at its own stage times (the order of convergence of a body
orbiting a railed planet), collisions, predictions, snapshots, state files and replay; bad
input named, nothing changed."""
import math

import numpy as np
import pytest

import spacephys as sp

L = np.longdouble
TWO_PI = L("6.283185307179586476925286766559005768")


def _analytic(r0, v0, mu, t):
    """The Kepler orbit of relative state r0, v0 (3,) about mu at time t (from 0), in long
    doubles: (place (3,), |a|)."""
    r0, v0, mu, t = np.array(r0, L), np.array(v0, L), L(mu), L(t)
    r = np.sqrt((r0 * r0).sum())
    alpha = 2 / r - (v0 * v0).sum() / mu
    a = 1 / abs(alpha)
    n = np.sqrt(mu * abs(alpha) ** 3)
    h = np.cross(r0, v0)
    ev = np.cross(v0, h) / mu - r0 / r
    e = np.sqrt((ev * ev).sum())
    P = ev / e
    Q = np.cross(h / np.sqrt((h * h).sum()), P)
    x, y = (r0 * P).sum(), (r0 * Q).sum()
    if e < 1:
        b = a * np.sqrt(1 - e * e)
        E = np.arctan2(y / b, x / a + e)
        M = E - e * np.sin(E) + n * t
        M = M - TWO_PI * np.floor(M / TWO_PI + L(0.5))
        for _ in range(80):
            E = E - (E - e * np.sin(E) - M) / (1 - e * np.cos(E))
        return a * (np.cos(E) - e) * P + b * np.sin(E) * Q, float(a)
    b = a * np.sqrt(e * e - 1)
    H = np.arcsinh(y / b)
    M = e * np.sinh(H) - H + n * t
    H = np.arcsinh(M / e)
    for _ in range(200):
        H = H - (e * np.sinh(H) - H - M) / (e * np.cosh(H) - 1)
    return a * (e - np.cosh(H)) * P + b * np.sinh(H) * Q, float(a)


@pytest.mark.parametrize("speed", [0.8, 1.2, 1.4, 1.6])
def test_a_body_on_rails_does_not_drift_in_a_million_periods(speed):
    """Ellipses of e 0.35, 0.45, 0.97 and a hyperbola (e 1.57), 1000 steps of 1000.3
    periods each (the hyperbola: of 1000.3 / n). Measured: 4e-13, 2e-12, 7e-11 of a, and
    2e-15 of the hyperbola's distance."""
    mu = 1.0                                   # G m_star: the star is fixed
    w = sp.World(3, G=1.0, dt=1.0)
    star = w.add_body(1.0, (0.0, 0.0, 0.0), fixed=True)
    body = w.add_body(1e-3, (1.0, 0.0, 0.0), (0.0, speed, 0.1))
    w.set_rails(body, star)
    orbit = w.rails[0]
    n = 2.0 * math.pi / orbit["period"] if orbit["e"] < 1 else \
        math.sqrt(mu / abs(orbit["a"]) ** 3)
    w.dt = 1000.3 * 2.0 * math.pi / n
    w.step(1000)
    want, a = _analytic([1.0, 0.0, 0.0], [0.0, speed, 0.1], mu, w.t)
    # of the orbit's size: a ellipse's a; a hyperbola's distance by then (10^6 a and more)
    size = a if orbit["e"] < 1 else float(np.sqrt((want.astype(float) ** 2).sum()))
    error = np.abs(w.pos[1] - want.astype(float)).max() / size
    print(f"speed {speed}: e {orbit['e']:.3f}, error {error:.1e} of the orbit's size")
    # the issue asks 1e-9; the mean motion as a plain double gives 3e-10, 2e-10, 3e-9
    assert error <= 1e-10


def test_nested_rails_a_moon_about_a_planet_about_a_star():
    w = sp.World(2, G=1.0, dt=0.05)
    star = w.add_body(1.0, (0.0, 0.0), fixed=True)
    planet = w.add_body(1e-3, (10.0, 0.0), (0.0, math.sqrt(1.001 / 10.0)))
    moon = w.add_body(1e-6, (10.1, 0.0), (0.0, math.sqrt(1.001 / 10.0) + 0.09))
    w.set_rails(moon, planet)                  # the child first: order does not matter
    w.set_rails(planet, star)
    rails = w.rails
    assert list(rails["id"]) == [moon, planet] and list(rails["about"]) == [planet, star]
    w.step(2000)
    v = math.sqrt(1.001 / 10.0)
    p, _ = _analytic([10.0, 0.0, 0.0], [0.0, v, 0.0], 1.0, w.t)
    m, _ = _analytic([0.1, 0.0, 0.0], [0.0, 0.09, 0.0], 1e-3 + 1e-6, w.t)
    np.testing.assert_allclose(w.pos[1, :2], p[:2].astype(float), rtol=0, atol=1e-12)
    np.testing.assert_allclose(w.pos[2, :2], (p + m)[:2].astype(float), rtol=0, atol=1e-12)


def _ship_about_a_railed_planet(integrator, dt, railed=True):
    """A massless ship on a circular orbit about a planet that circles a fixed star on rails
    (or integrated): 2D, G = 1."""
    w = sp.World(2, G=1.0, dt=dt, integrator=integrator)
    star = w.add_body(1.0, (0.0, 0.0), fixed=True)
    planet = w.add_body(1e-2, (1.0, 0.0), (0.0, math.sqrt(1.01)))
    ship = w.add_body(0.0, (1.05, 0.0), (0.0, math.sqrt(1.01) + math.sqrt(1e-2 / 0.05)))
    if railed:
        w.set_rails(planet, star)
    return w, ship


def _reference():
    """The same ship, planet integrated with Gauss-Radau (its orbit Kepler's: nothing else
    pulls it), to t = 1."""
    w, ship = _ship_about_a_railed_planet("gauss_radau", 1e-3, railed=False)
    w.step(1000)
    return w.pos[w.index_of(ship)]


@pytest.mark.parametrize("integrator, order", [("leapfrog", 2), ("yoshida4", 4), ("rk4", 4)])
def test_every_integrator_sees_the_rails_at_its_stage_times(integrator, order):
    """The ship's error against the reference falls as dt^order: stages seeing the planet
    where it was at the step's start would make every method first order."""
    ref = _reference()
    errors = []
    for dt in (1 / 200, 1 / 400):
        w, ship = _ship_about_a_railed_planet(integrator, dt)
        w.step(round(1.0 / dt))
        errors.append(float(np.abs(w.pos[w.index_of(ship)] - ref).max()))
    ratio = errors[0] / errors[1]
    assert ratio == pytest.approx(2.0 ** order, rel=0.25), errors


def test_gauss_radau_on_rails_agrees_with_the_planet_integrated():
    ref = _reference()
    w, ship = _ship_about_a_railed_planet("gauss_radau", 1e-3)
    w.step(1000)
    assert np.abs(w.pos[w.index_of(ship)] - ref).max() < 1e-11


def test_wisdom_holman_refuses_rails_with_the_reason():
    w = sp.World(2, G=1.0, dt=0.01, integrator="wisdom_holman")
    star = w.add_body(1.0, (0.0, 0.0))
    planet = w.add_body(1e-3, (1.0, 0.0), (0.0, 1.0))
    with pytest.raises(ValueError, match="Jacobi"):
        w.set_rails(planet, star)
    assert not len(w.rails)
    w2 = sp.World(2, G=1.0, dt=0.01)
    star = w2.add_body(1.0, (0.0, 0.0))
    planet = w2.add_body(1e-3, (1.0, 0.0), (0.0, 1.0))
    w2.set_rails(planet, star)
    w2.integrator = "wisdom_holman"
    with pytest.raises(ValueError, match="rails"):
        w2.step(1)


def test_off_rails_it_flies_on_from_where_its_rails_had_it():
    w, ship = _ship_about_a_railed_planet("gauss_radau", 1e-3)
    w.step(500)
    planet = int(w.ids[1])
    where, speed = w.pos[1].copy(), w.vel[1].copy()
    w.set_rails(planet, None)
    assert not len(w.rails)
    np.testing.assert_array_equal(w.pos[1], where)
    np.testing.assert_array_equal(w.vel[1], speed)
    w.step(500)
    ref = _reference()
    assert np.abs(w.pos[w.index_of(ship)] - ref).max() < 1e-9


def test_a_ship_hits_a_railed_planet_which_keeps_its_orbit():
    w = sp.World(2, G=1.0, dt=1e-3)
    w.set_collision("ship", "planet", "destroy_a")
    star = w.add_body(1.0, (0.0, 0.0), fixed=True)
    planet = w.add_body(1e-3, (1.0, 0.0), (0.0, 1.1), kind="planet", radius=0.05)
    ship = w.add_body(1.0, (1.0, 0.5), (0.0, -2.0), kind="ship", radius=0.01)
    w.set_rails(planet, star)
    hit = None
    for _ in range(1000):
        w.step(1)
        if len(w.events):
            hit = w.events[0]
            break
    assert hit is not None and hit["a"] == ship and ship not in w
    w.step(10)
    x, _ = _analytic([1.0, 0.0, 0.0], [0.0, 1.1, 0.0], 1.0, w.t)
    np.testing.assert_allclose(w.pos[w.index_of(planet), :2], x[:2].astype(float), rtol=0,
                               atol=1e-12)


def test_rails_in_predictions_snapshots_state_files_and_replay(tmp_path):
    w = sp.World(2, G=1.0, dt=1e-3)
    log = w.record(tmp_path / "run.h5")
    star = w.add_body(1.0, (0.0, 0.0), fixed=True)
    planet = w.add_body(1e-2, (1.0, 0.0), (0.0, math.sqrt(1.01)))
    ship = w.add_body(0.0, (1.05, 0.0), (0.0, math.sqrt(1.01) + math.sqrt(0.2)))
    w.set_rails(planet, star)
    w.step(100)
    path = w.predict(ship, 0.2, points=3).path(ship)[0]
    loaded = sp.World.from_state(w.state())
    w.step(200)
    loaded.step(200)
    assert loaded.digest() == w.digest() and len(loaded.rails) == 1
    np.testing.assert_array_equal(path[-1], w.pos[w.index_of(ship)])
    log.close()
    assert sp.replay(tmp_path / "run.h5").ok
    saved = loaded.snapshot()
    loaded.step(50)
    after = loaded.digest()
    loaded.restore(saved)
    loaded.step(50)
    assert loaded.digest() == after


def test_removing_the_parent_takes_the_child_off_rails():
    w = sp.World(2, G=1.0, dt=1e-3)
    star = w.add_body(1.0, (0.0, 0.0))
    planet = w.add_body(1e-3, (1.0, 0.0), (0.0, 1.0))
    w.set_rails(planet, star)
    w.step(1)
    w.remove(star)
    w.step(10)
    assert not len(w.rails)
    assert w.vel[w.index_of(planet)][1] == pytest.approx(1.0, rel=1e-3)   # flies straight on


@pytest.mark.parametrize("call, message", [
    (lambda w, s, p, m: w.set_rails(p, p), "about itself"),
    (lambda w, s, p, m: w.set_rails(p, 99), "about = 99"),
    (lambda w, s, p, m: w.set_rails(99, s), "id = 99"),
    (lambda w, s, p, m: w.set_rails(s, p), "a cycle"),
    (lambda w, s, p, m: w.set_rails(s, m), "fixed"),
    (lambda w, s, p, m: w.set_rails(m, p), "radial"),
    (lambda w, s, p, m: w.set_body(p, pos=(2.0, 0.0)), "on rails"),
])
def test_bad_rails_are_named_and_nothing_changes(call, message):
    w = sp.World(2, G=1.0, dt=1e-3)
    star = w.add_body(1.0, (0.0, 0.0), fixed=True)
    planet = w.add_body(1e-3, (1.0, 0.0), (0.0, 1.0))
    moon = w.add_body(1e-6, (1.1, 0.0), (0.2, 1.0))       # straight out from the planet
    w.set_rails(planet, star)
    before = w.digest()
    listing = w.rails.copy()
    with pytest.raises(ValueError, match=message):
        call(w, star, planet, moon)
    assert w.digest() == before and np.array_equal(w.rails, listing)


def test_a_massless_pair_has_no_orbit():
    w = sp.World(2, G=1.0, dt=1e-3)
    a = w.add_body(0.0, (0.0, 0.0))
    b = w.add_body(0.0, (1.0, 0.0), (0.0, 1.0))
    with pytest.raises(ValueError, match="no mass"):
        w.set_rails(b, a)
    assert not len(w.rails)


def test_ships_fly_on_their_engines_not_on_rails():
    w = sp.World(2, G=1.0, dt=1e-3)
    star = w.add_body(1.0, (0.0, 0.0), fixed=True)
    ship = w.add_ship(sp.ShipSpec(), (3.0, 0.0), (0.0, 0.6))
    with pytest.raises(ValueError, match="ship or missile"):
        w.set_rails(ship, star)
    assert not len(w.rails)


def test_the_guides_example_runs_as_written(capsys):
    """docs/guide/orbits.md's rails example: the moon's period about the planet."""
    import pathlib
    text = (pathlib.Path(__file__).parents[1] / "docs/guide/orbits.md").read_text()
    code = text.split("## Rails")[1].split("```python\n")[1].split("```")[0]
    exec(compile(code, "orbits.md", "exec"), {})
    lines = capsys.readouterr().out.splitlines()
    assert lines[-1] == "[6.2832 0.5609]"


def test_rails_drop_the_neighbours_pull_by_the_amount_the_models_page_says():
    """docs/models.md: a Saturn on rails beside an integrated Jupiter, against the full run:
    0.019 of its orbit off after one orbit, 0.19 after ten."""
    def scene(rails):
        w = sp.World(2, G=1.0, dt=0.05, integrator="gauss_radau")
        sun = w.add_body(1.0, (0.0, 0.0))
        w.add_body(1e-3, (5.2, 0.0), (0.0, math.sqrt(1.001 / 5.2)))
        saturn = w.add_body(3e-4, (0.0, 9.5), (-math.sqrt(1.0003 / 9.5), 0.0))
        w.move_to_center_of_mass()
        if rails:
            w.set_rails(saturn, sun)
        return w
    full, railed = scene(False), scene(True)
    period = 2.0 * math.pi * 9.5 ** 1.5
    for orbits, want in ((1, 0.019), (10, 0.19)):
        n = round((orbits * period - full.t) / full.dt)
        full.step(n)
        railed.step(n)
        off = np.abs((full.pos[2] - full.pos[0]) - (railed.pos[2] - railed.pos[0])).max()
        assert off / 9.5 == pytest.approx(want, rel=0.05)
