"""Patched conics and time warp (World.coast, World(coast="auto"), World.advance(warp=)):
a coasting body on its dominant body's conic, its sphere-of-influence changes found by time
(against a fine scan of the distance, and the new conic against REBOUND's orbit of the same
relative state), its return to integration (thrust, a planned burn, a surface, an integrated
body nearby), time passing in jumps that give the bits of stepping, a warp capped with its
reason, snapshots, state files, replay and predictions; bad input named, nothing changed."""
import math

import numpy as np
import pytest

import spacephys as sp
from spacephys import events as ev

R_SOI = 2.0 * (1e-2) ** 0.4          # the moon's sphere: a (m / M)^(2/5)
VM = 1.0 / math.sqrt(2.0)            # the moon's circular speed at 2 about M = 1


def _flyby(dim=2, dt=0.01, **world):
    """A star (fixed, mass 1), a moon on rails at 2 (mass 0.01) and a ship on the Hohmann
    ellipse from 1 to 2 timed to meet the moon at apoapsis."""
    w = sp.World(dim, G=1.0, dt=dt, **world)
    star = w.add_body(1.0, (0.0,) * dim, fixed=True, radius=0.05)
    th = math.pi - VM / 2.0 * math.pi * math.sqrt(1.5 ** 3)
    moon = w.add_body(1e-2, (2 * math.cos(th), 2 * math.sin(th)) + (0.0,) * (dim - 2),
                      (-VM * math.sin(th), VM * math.cos(th)) + (0.0,) * (dim - 2),
                      radius=0.01)
    w.set_rails(moon, star)
    ship = w.add_body(1e-9, (1.0,) + (0.0,) * (dim - 1),
                      (0.0, math.sqrt(2.0 - 1.0 / 1.5)) + (0.0,) * (dim - 2), radius=1e-4)
    return w, star, moon, ship


def _events(w, steps, chunk=1):
    got = []
    for _ in range(steps // chunk):
        w.step(chunk)
        got += [e for e in w.events]
    return np.array(got, dtype=ev.EVENT_DTYPE)


def test_sphere_changes_are_found_at_the_time_a_fine_scan_finds_them():
    w, star, moon, ship = _flyby()
    w.coast(ship)
    assert list(w.coasting) == [ship] and w.rails[w.rails["id"] == ship]["about"] == star
    inside, crossings = None, []
    for _ in range(700):
        w.step(1)
        d = float(np.linalg.norm(w.pos[w.index_of(ship)] - w.pos[w.index_of(moon)]))
        now = d < R_SOI
        if inside is not None and now != inside:
            crossings.append(w.t)
        inside = now
        for e in w.events:
            crossings.append(e)
    got = [c for c in crossings if not isinstance(c, float)]
    scan = [c for c in crossings if isinstance(c, float)]
    assert [ev.kind_name(e["kind"]) for e in got] == ["soi_enter", "soi_exit"]
    assert all(e["a"] == ship and e["b"] == moon for e in got)
    # each event inside the step the scan saw it change in (entered: measured 3.2234)
    for e, t in zip(got, scan):
        assert t - w.dt <= e["time"] <= t, (e["time"], t)
        assert e["distance"] == pytest.approx(R_SOI, rel=1e-12)
    # the gravity assist changed the orbit about the star
    after = w.rails[w.rails["id"] == ship][0]
    assert after["about"] == star and after["a"] > 2.0


def test_the_conic_in_the_sphere_is_reboundss_orbit_of_the_relative_state():
    import rebound
    w, star, moon, ship = _flyby(dim=3)
    w.coast(ship)
    for _ in range(400):
        w.step(1)
        if len(w.events):
            break
    entered = w.events[0]
    assert ev.kind_name(entered["kind"]) == "soi_enter"
    row = w.rails[w.rails["id"] == ship][0]
    assert row["about"] == moon
    # the relative state now, from the World, and REBOUND's elements of it
    i, m = w.index_of(ship), w.index_of(moon)
    sim = rebound.Simulation()
    sim.G = 1.0
    sim.add(m=1e-2)
    r, v = w.pos[i] - w.pos[m], w.vel[i] - w.vel[m]
    sim.add(m=1e-9, x=r[0], y=r[1], z=r[2], vx=v[0], vy=v[1], vz=v[2])
    orbit = sim.particles[1].orbit(primary=sim.particles[0])
    assert row["e"] == pytest.approx(orbit.e, rel=1e-9)
    assert row["a"] == pytest.approx(orbit.a, rel=1e-9)
    assert row["a"] * (1 + row["e"]) > R_SOI       # bound to the moon, but leaves its sphere


def test_a_coasting_body_does_not_drift_from_its_conic():
    """Coasting about the star alone (no sphere to change): its place is the Kepler orbit's
    after 10^4 periods (the rails' guarantee, tests/test_rails.py)."""
    w = sp.World(2, G=1.0, dt=0.05)
    star = w.add_body(1.0, (0.0, 0.0), fixed=True)
    ship = w.add_body(0.0, (1.0, 0.0), (0.0, 1.2))
    w.coast(ship)
    period = float(w.rails["period"][0])
    w.step(int(1e4 * period / 0.05))
    from test_rails import _analytic
    x, a = _analytic([1.0, 0.0, 0.0], [0.0, 1.2, 0.0], 1.0, w.t)
    assert np.max(np.abs(w.pos[1] - x[:2].astype(float))) < 1e-9 * a


def test_thrust_returns_it_to_integration_from_its_conic():
    w = sp.World(2, G=1.0, dt=0.01)
    star = w.add_body(1.0, (0.0, 0.0), fixed=True)
    ship = w.add_ship(sp.ShipSpec(max_thrust=0.1, exhaust_speed=1.0, fuel_mass=1.0), (1.0, 0.0), (0.0, 1.0))
    w.coast(ship)
    w.step(100)
    pos, vel = w.pos[1].copy(), w.vel[1].copy()
    w.control(ship, throttle=1.0)
    assert not len(w.coasting)
    assert np.array_equal(w.pos[1], pos) and np.array_equal(w.vel[1], vel)
    w.step(100)                               # integrated, thrusting: off the circle
    assert abs(np.linalg.norm(w.pos[1]) - 1.0) > 1e-4
    with pytest.raises(ValueError, match="thrusts"):
        w.coast(ship)


def test_a_planned_burn_ends_coasting_before_it_starts():
    w = sp.World(2, G=1.0, dt=0.01)
    star = w.add_body(1.0, (0.0, 0.0), fixed=True)
    ship = w.add_ship(sp.ShipSpec(max_thrust=1e-2, exhaust_speed=1.0, fuel_mass=1.0), (1.0, 0.0), (0.0, 1.0))
    w.coast(ship)
    w.plan(ship, [sp.Burn(start=2.0, duration=0.5)])
    w.step(150)
    assert list(w.coasting) == [ship]          # before the burn: coasting
    w.step(100)
    assert not len(w.coasting)
    assert np.linalg.norm(w.vel[1]) > 1.0 + 1e-3   # the burn was flown (prograde)


def test_coming_down_to_the_parent_returns_it_to_integration_before_contact():
    w = sp.World(2, G=1.0, dt=0.001)
    w.set_collision("body", "body", "destroy_b")
    star = w.add_body(1.0, (0.0, 0.0), fixed=True, radius=0.5)
    ship = w.add_body(0.0, (1.0, 0.0), (0.0, 0.5), radius=0.01)   # pericentre 0.14: inside
    w.coast(ship)
    last = None
    for _ in range(3000):
        w.step(1)
        if len(w.events):
            break
        if len(w.coasting):
            last = float(np.linalg.norm(w.pos[1]))
    hit = w.events[0]
    assert ev.kind_name(hit["kind"]) == "destroy" and ship not in w
    # coasting until within a step of the surface (0.51 from the centre, falling at ~1.9)
    assert 0.51 <= last < 0.51 + 2.0 * w.dt


def test_an_integrated_body_nearby_returns_it_to_integration():
    w = sp.World(2, G=1.0, dt=0.01)
    w.coast_near = 0.05
    star = w.add_body(1.0, (0.0, 0.0), fixed=True)
    ship = w.add_body(0.0, (1.0, 0.0), (0.0, 1.0), radius=0.01)
    rock = w.add_body(0.0, (-1.0, 0.0), (0.0, 1.0), radius=0.01)  # the other way round
    w.coast(ship)
    before = None
    for _ in range(400):
        w.step(1)
        gap = float(np.linalg.norm(w.pos[1] - w.pos[2])) - 0.02
        if len(w.coasting):
            before = gap
        else:
            break
    assert not len(w.coasting)
    assert before > 0.05 and gap < 0.05 + 0.05   # released once within near (and a margin)


def test_time_passes_in_jumps_with_the_bits_of_stepping():
    """Everything on rails or coasting: World.step jumps (kernels/rails.jump); a far,
    massless integrated body makes the other World step every step. The bodies on rails
    and the coasting ship end on the same bits, with the same events."""
    a, *_ = _flyby()
    b, *_ = _flyby()
    b.add_body(0.0, (1e6, 0.0))
    for w in (a, b):
        w.coast(2)
    got = [_events(w, 1200, 100) for w in (a, b)]
    assert len(got[0]) == 2 and np.array_equal(got[0][["kind", "a", "b", "time"]],
                                               got[1][["kind", "a", "b", "time"]])
    assert np.array_equal(a.pos[:3], b.pos[:3]) and np.array_equal(a.vel[:3], b.vel[:3])


def test_warp_a_million_with_planets_on_rails_and_ships_coasting():
    w, star, moon, ship = _flyby()
    w.set_body(ship, vel=(0.0, 1.0))            # a circle at 1: inside the moon's orbit
    w.coast(ship)
    w.advance(1 / 60, warp=1e6)
    assert w.warp == (1e6, 1e6, None)
    assert w.t == pytest.approx(1e6 / 60, rel=1e-6) and w.dropped_time == 0.0
    assert list(w.coasting) == [ship]


def test_warp_is_capped_with_its_reason_when_something_is_integrated():
    w, star, moon, ship = _flyby()
    w.max_substeps = 10
    w.advance(1 / 60, warp=1000.0)
    assert w.warp.asked == 1000.0 and w.warp.reason == f"body {ship} (body) is integrated"
    assert w.warp.granted == pytest.approx(10 * w.dt * 60, rel=1e-9)
    assert w.t == pytest.approx(10 * w.dt)
    w.coast(ship)
    w.advance(1 / 60, warp=1000.0)
    assert w.warp == (1000.0, 1000.0, None)


def test_warp_is_cut_when_a_body_must_be_integrated_within_the_frame():
    w = sp.World(2, G=1.0, dt=0.001)
    star = w.add_body(1.0, (0.0, 0.0), fixed=True, radius=0.5)
    ship = w.add_body(0.0, (1.0, 0.0), (0.0, 0.5), radius=0.01)
    w.coast(ship)
    w.max_substeps = 50
    w.advance(1.0, warp=10.0)                   # 10 time units: it comes down within them
    assert not len(w.coasting)
    assert w.warp.granted < 10.0 and "integrated" in w.warp.reason
    assert w.t < 2.0 and w.dropped_time > 8.0


def test_auto_coast_ships_that_do_not_thrust():
    w = sp.World(2, G=1.0, dt=0.01, coast="auto")
    assert w.coast_auto
    star = w.add_body(1.0, (0.0, 0.0), fixed=True)
    ship = w.add_ship(sp.ShipSpec(max_thrust=1e-3, exhaust_speed=1.0, fuel_mass=1.0), (1.0, 0.0), (0.0, 1.0))
    w.step(1)
    assert list(w.coasting) == [ship]
    w.control(ship, throttle=0.5)
    w.step(1)
    assert not len(w.coasting)
    w.control(ship, throttle=0.0)
    w.step(1)
    assert list(w.coasting) == [ship]
    w.coast_auto = False
    w.coast(ship, False)
    w.step(1)
    assert not len(w.coasting)


def test_coasting_in_predictions_snapshots_state_files_and_replay(tmp_path):
    w, star, moon, ship = _flyby()
    w.coast(ship)
    w.step(100)
    p = w.predict(ship, 3.0, points=4)
    assert [ev.kind_name(k) for k in p.events["kind"]] == ["soi_enter"]
    loaded = sp.World.from_state(w.state())
    saved = w.snapshot()
    w.step(300)
    np.testing.assert_array_equal(p.path(ship)[0][-1], _at(loaded, 300, ship))
    assert loaded.digest() == w.digest() and list(loaded.coasting) == [ship]
    after = w.digest()
    w.restore(saved)
    w.step(300)
    assert w.digest() == after
    recorded, *_ = _flyby()
    log = recorded.record(tmp_path / "run.h5")
    recorded.coast(ship)
    for _ in range(40):
        recorded.advance(1 / 60, warp=20.0)
    assert len(recorded.rails) == 2
    log.close()
    assert sp.replay(tmp_path / "run.h5").ok


def _at(w, steps, body):
    w.step(steps)
    return w.pos[w.index_of(body), :w.dim]


@pytest.mark.parametrize("call, message", [
    (lambda w, s, m, p: w.coast(s), "fixed"),
    (lambda w, s, m, p: w.coast(m), "on rails"),
    (lambda w, s, m, p: w.coast([p, 99]), "99"),
    (lambda w, s, m, p: w.advance(0.01, warp=0.0), "warp = 0.0"),
    (lambda w, s, m, p: w.advance(0.01, warp=-2.0), "warp"),
    (lambda w, s, m, p: w.advance(0.01, warp=float("nan")), "warp"),
    (lambda w, s, m, p: w.advance(0.01, warp=float("inf")), "warp"),
    (lambda w, s, m, p: setattr(w, "coast_near", -1.0), "coast_near"),
    (lambda w, s, m, p: setattr(w, "coast_auto", "yes"), "coast_auto"),
])
def test_bad_coasting_and_warp_are_named_and_nothing_changes(call, message):
    w, star, moon, ship = _flyby()
    w.step(3)
    before = w.digest()
    listing = w.rails.copy()
    with pytest.raises(ValueError, match=message):
        call(w, star, moon, ship)
    assert w.digest() == before and np.array_equal(w.rails, listing)


def test_wisdom_holman_refuses_coasting_with_the_reason():
    w = sp.World(2, G=1.0, dt=0.01, integrator="wisdom_holman")
    w.add_body(1.0, (0.0, 0.0))
    ship = w.add_body(0.0, (1.0, 0.0), (0.0, 1.0))
    before = w.digest()
    with pytest.raises(ValueError, match="Wisdom-Holman drifts every body"):
        w.coast(ship)
    assert w.digest() == before and not len(w.coasting)


def test_nothing_is_put_on_rails_about_a_coasting_body():
    w, star, moon, ship = _flyby()
    w.coast(ship)
    other = w.add_body(0.0, (1.0, 0.01), (0.0, 1.1))
    with pytest.raises(ValueError, match="coasts"):
        w.set_rails(other, ship)
    with pytest.raises(ValueError, match="coast"):
        sp.World(2, coast="always")


def test_the_guides_example_runs_as_written(capsys):
    """docs/guide/orbits.md's coasting example: the moon's sphere entered and left, the
    warp granted, then capped once the ship thrusts."""
    import pathlib
    text = (pathlib.Path(__file__).parents[1] / "docs/guide/orbits.md").read_text()
    code = text.split("## Coasting and time warp")[1].split("```python\n")[1].split("```")[0]
    exec(compile(code, "orbits.md", "exec"), {})
    out = capsys.readouterr().out.splitlines()
    assert out[0] == "soi_enter 1 3.223" and out[1] == "soi_exit 1 5.619"
    assert out[2] == "Warp(asked=10.0, granted=10.0, reason=None)"
    assert "reason='body 2 (ship) is integrated'" in out[-1] and "granted=9.59" in out[-1]


def test_predictions_and_recordings_of_jumps_take_the_frames_stepping_would(tmp_path):
    """A prediction and a run log sample a jump at their own step counts
    (kernels/rails.jump_frames): the bits a stepped World (a far, massless integrated body
    makes it step) takes at the same counts, its sphere changes included."""
    a, *_ = _flyby()
    b, *_ = _flyby()
    b.add_body(0.0, (1e6, 0.0))
    for w in (a, b):
        w.coast(2)
    pa, pb = a.predict(2, 6.0, points=50), b.predict(2, 6.0, points=50)
    assert np.array_equal(pa.t, pb.t) and np.array_equal(pa.pos[0], pb.pos[0])
    assert [ev.kind_name(k) for k in pa.events["kind"]] == ["soi_enter", "soi_exit"]
    assert np.array_equal(pa.events[["kind", "time"]], pb.events[["kind", "time"]])
    runs = []
    for w, name in ((a, "a.h5"), (b, "b.h5")):
        with w.record(tmp_path / name, every=7):
            w.step(600)
        runs.append(sp.open_run(tmp_path / name))
    assert len(runs[0]) == len(runs[1]) > 80
    for k in range(len(runs[0])):
        assert np.array_equal(runs[0].frame(k).pos[:3], runs[1].frame(k).pos[:3])
