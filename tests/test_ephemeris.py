"""Ephemerides (sp.Ephemeris): fitted to a run within their tolerance (at the steps and
between them), flown as rails (a probe in their field follows the full run's path), saved
and loaded, in state files, snapshots and replay; stepping past their end refused."""
import math

import numpy as np
import pytest

import spacephys as sp


def _system(dt=0.01):
    """A sun, a Jupiter and a Saturn about their centre of mass (2D, G = 1), Gauss-Radau."""
    w = sp.World(2, G=1.0, dt=dt, integrator="gauss_radau")
    sun = w.add_body(1.0, (0.0, 0.0))
    jupiter = w.add_body(1e-3, (5.2, 0.0), (0.0, math.sqrt(1.001 / 5.2)))
    saturn = w.add_body(3e-4, (0.0, 9.5), (-math.sqrt(1.0003 / 9.5), 0.0))
    w.move_to_center_of_mass()
    return w, [sun, jupiter, saturn]


@pytest.fixture(scope="module")
def fitted():
    w, ids = _system()
    return w, ids, sp.Ephemeris.fit(w, ids, 200.0, tolerance=1e-10)


def test_the_fit_is_within_its_tolerance_at_and_between_the_steps(fitted):
    w, ids, eph = fitted
    assert eph.covers(0.0, 200.0) and eph.start == w.t == 0.0
    # at the steps: the run it was fitted to
    run = w.copy()
    run.step(20000)
    # between them: the same system stepped at half the step (Gauss-Radau: the same path to
    # its own error, 1e-13 here), at the half steps
    half, _ = _system(dt=0.005)
    half.step(10001)
    for k, body in enumerate(ids):
        size = 9.5 if k == 2 else (5.2 if k == 1 else 0.01)
        for world in (run, half):
            p, v = eph.state(body, world.t)
            assert np.abs(p - world.pos[k]).max() <= 1e-10 * size
            assert np.abs(v - world.vel[k]).max() <= 1e-9 * size
    # and a tolerance a coarse fit cannot meet is refused, with what it reached
    with pytest.raises(ValueError, match="tolerance = 1e-16"):
        sp.Ephemeris.fit(w, ids, 20.0, tolerance=1e-16, terms=4)


def test_a_probe_in_the_field_of_an_ephemeris_follows_the_full_run(fitted):
    w, ids, eph = fitted
    flown = w.copy()
    probe = flown.add_body(0.0, (3.0, 0.0), (0.0, math.sqrt(1.0 / 3.0)))
    full = flown.copy()
    for body in ids:
        flown.set_rails(body, ephemeris=eph)
    assert list(flown.rails["about"]) == [-1, -1, -1]
    flown.step(20000)
    full.step(20000)
    k = flown.index_of(probe)
    assert np.abs(flown.pos[k] - full.pos[k]).max() < 1e-12
    assert np.abs(flown.pos[:3] - full.pos[:3]).max() < 1e-11
    # the ephemeris ends at t = 200: a step past it is refused, nothing changed
    before = flown.digest()
    with pytest.raises(ValueError, match="ephemerides flown end at t = 200"):
        flown.step(1)
    assert flown.digest() == before


def test_saved_and_loaded_it_gives_the_same_bits(fitted, tmp_path):
    _, ids, eph = fitted
    eph.save(tmp_path / "system.h5")
    back = sp.Ephemeris.load(tmp_path / "system.h5")
    times = np.linspace(0.0, 200.0, 77)
    for body in ids:
        for a, b in zip(eph.state(body, times), back.state(body, times)):
            np.testing.assert_array_equal(a, b)
    with pytest.raises(ValueError, match="covers 0.0 to 200.0"):
        back.state(ids[0], 201.0)


def test_flown_ephemerides_in_state_files_snapshots_and_replay(fitted, tmp_path):
    w, ids, eph = fitted
    flown = w.copy()
    log = flown.record(tmp_path / "run.h5")
    probe = flown.add_body(0.0, (3.0, 0.0), (0.0, math.sqrt(1.0 / 3.0)))
    flown.set_rails(ids[1], ephemeris=eph)
    flown.set_rails(ids[2], ephemeris=eph)
    flown.step(300)
    loaded = sp.World.from_state(flown.state())
    flown.step(300)
    loaded.step(300)
    assert loaded.digest() == flown.digest() and probe in loaded
    log.close()
    assert sp.replay(tmp_path / "run.h5").ok
    saved = loaded.snapshot()
    loaded.step(100)
    after = loaded.digest()
    loaded.restore(saved)
    loaded.step(100)
    assert loaded.digest() == after


def test_bad_ephemeris_requests_are_named_and_change_nothing(fitted):
    w, ids, eph = fitted
    flown = w.copy()
    other = flown.add_body(1e-6, (2.0, 0.0), (0.0, 0.7))
    before = flown.digest()
    for call, message in (
            (lambda: flown.set_rails(other, ephemeris=eph), f"body = {other}: not in"),
            (lambda: flown.set_rails(ids[1], ids[0], ephemeris=eph), "with an ephemeris"),
            (lambda: flown.set_rails(ids[1], ephemeris="eph"), "expected an sp.Ephemeris")):
        with pytest.raises(ValueError, match=message):
            call()
        assert flown.digest() == before and not len(flown.rails)
    late = w.copy()
    late.step(1)
    shifted = sp.Ephemeris(eph.ids, 5.0, eph.length, eph.coef, 2)
    with pytest.raises(ValueError, match="not the World's time"):
        late.set_rails(ids[1], ephemeris=shifted)


def test_the_guides_example_runs_as_written(capsys, tmp_path, monkeypatch):
    """docs/guide/orbits.md's ephemeris example."""
    import pathlib
    monkeypatch.chdir(tmp_path)
    text = (pathlib.Path(__file__).parents[1] / "docs/guide/orbits.md").read_text()
    code = text.split("## Ephemerides")[1].split("```python\n")[1].split("```")[0]
    exec(compile(code, "orbits.md", "exec"), {})
    lines = capsys.readouterr().out.splitlines()
    assert lines == ["(3, 16, 3, 14)", "True"]
    assert sp.Ephemeris.load(tmp_path / "system.h5").coef.shape == (3, 16, 3, 14)


def test_the_fitted_ephemeris_agrees_with_reboundss_ias15_on_the_same_bodies(fitted):
    """The oracle: REBOUND's IAS15 from the same initial state, sampled at 40 times over the
    200 time units; the ephemeris (fitted to our Gauss-Radau run, asked for 1e-10 of each
    orbit) is within 1e-11 of each orbit's size of it (measured: 2e-14, 6e-14, 1.3e-13 for
    the sun, Jupiter, Saturn)."""
    import rebound
    w, ids, eph = fitted
    sim = rebound.Simulation()
    sim.G = 1.0
    sim.integrator = "ias15"
    for k in range(3):
        x, y = w.pos[k]
        vx, vy = w.vel[k]
        sim.add(m=float(w.mass[k]), x=x, y=y, vx=vx, vy=vy)
    worst = 0.0
    for t in np.linspace(5.0, 200.0, 40):
        sim.integrate(t, exact_finish_time=1)
        for k, (body, size) in enumerate(zip(ids, (0.01, 5.2, 9.5))):
            p, _ = eph.state(body, t)
            there = np.array([sim.particles[k].x, sim.particles[k].y])
            worst = max(worst, float(np.abs(p - there).max()) / size)
    assert 0.0 < worst <= 1e-11
