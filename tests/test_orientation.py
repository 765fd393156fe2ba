"""Orientation for every body (issue 43, item 4): set_heading and set_body(angular_velocity=)
on any body, not only ships and missiles. A body given one (a rotor) turns at its angular
velocity under every integrator, is in snapshots, state files and recorded replays, bit for
bit; bodies never given one carry none; bad input is named and changes nothing."""
import math

import numpy as np
import pytest

import spacephys as sp


def _pair(dim=2, integrator="leapfrog", record=None):
    """A star and an asteroid on a circular orbit about it; the asteroid spins at 2 rad/time."""
    w = sp.World(dim, integrator=integrator, dt=0.01)
    log = None if record is None else w.record(record)
    z = (0.0,) * (dim - 2)
    w.add_body(1.0, (0.0, 0.0) + z, radius=0.5, kind="star")
    rock = w.add_body(1e-6, (1.0, 0.0) + z, (0.0, 1.0) + z, radius=0.1, kind="asteroid")
    w.set_body(rock, angular_velocity=2.0 if dim == 2 else (0.0, 0.0, 2.0))
    return w, log, rock


@pytest.mark.parametrize("integrator", ["leapfrog", "rk4", "yoshida6", "gauss_radau",
                                        "wisdom_holman"])
def test_a_spinning_asteroid_turns_at_its_rate_under_every_integrator(integrator):
    w, _, rock = _pair(integrator=integrator)
    w.step(150)
    angle = 2.0 * w.t
    assert w.t == pytest.approx(1.5)
    assert w.heading(rock) == pytest.approx(math.remainder(angle, 2 * math.pi), abs=1e-12)
    assert w.angular_velocity(rock) == 2.0                    # no torque acts on a rotor
    assert w.is_ship(rock) is False and rock not in w.actor_ids


def test_a_pulling_spinning_star_is_not_a_ship_to_wisdom_holman():
    """Wisdom-Holman refuses pulling ships (their mass changes); a spinning star is none."""
    w, _, _ = _pair(integrator="wisdom_holman")
    star = int(w.ids[0])
    w.set_body(star, angular_velocity=0.1)
    w.step(10)
    assert w.heading(star) == pytest.approx(0.1 * w.t, abs=1e-14)


def test_in_3d_a_tilted_body_spins_about_its_own_axis():
    """Pointed along +y, spinning about its body z (the world's z): its x axis sweeps the
    plane from +y toward -x."""
    w = sp.World(3, gravity="none", dt=0.01)
    body = w.add_body(1.0, (0.0, 0.0, 0.0))
    w.set_heading(body, (0.0, 1.0, 0.0))
    w.set_body(body, angular_velocity=(0.0, 0.0, 0.5))
    w.step(100)
    np.testing.assert_allclose(w.heading(body), [-math.sin(0.5), math.cos(0.5), 0.0],
                               atol=1e-14)
    np.testing.assert_array_equal(w.angular_velocity(body), [0.0, 0.0, 0.5])
    assert np.linalg.norm(w.orientation(body)) == pytest.approx(1.0, abs=1e-15)


@pytest.mark.parametrize("dim", [2, 3])
def test_bodies_never_given_an_orientation_carry_none(dim):
    w = sp.World(dim, gravity="none")
    body = w.add_body(1.0, np.zeros(dim))
    assert w.heading(body) == 0.0 if dim == 2 else list(w.heading(body)) == [1, 0, 0]
    assert list(w.orientation(body)) == [1.0, 0.0, 0.0, 0.0]
    assert np.all(w.angular_velocity(body) == 0.0)
    w.step(3)
    assert "quat" not in w._b.columns and "quat" not in w.state()["bodies"]["columns"]


def test_set_heading_points_any_body_and_stops_its_spin():
    w, _, rock = _pair()
    w.set_heading(rock, 1.0)
    w.step(10)
    assert (w.heading(rock), w.angular_velocity(rock)) == (pytest.approx(1.0, abs=1e-15), 0.0)


def test_a_rotor_launches_along_its_heading_and_its_mass_stays_editable():
    w = sp.World(2, gravity="none", dt=0.01)
    turret = w.add_body(10.0, (0.0, 0.0), radius=1.0, kind="planet")
    w.set_heading(turret, math.pi / 2)
    missile = w.launch(turret, sp.MissileSpec(mass=0.1, radius=0.1, launch_speed=5.0))
    np.testing.assert_allclose(w.get(missile).vel, [0.0, 5.0], atol=1e-14)
    w.set_body(turret, mass=20.0)                      # a ship's mass is dry + fuel; not so here
    assert w.get(turret).mass == 20.0
    for call in (lambda: w.control(turret, throttle=1.0), lambda: w.fuel(turret)):
        with pytest.raises(ValueError, match="not a ship or missile"):
            call()


def test_a_ship_with_physical_rotation_takes_an_angular_velocity():
    w = sp.World(2, gravity="none", dt=0.01)
    spec = sp.ShipSpec(dry_mass=1.0, fuel_mass=1.0, max_thrust=1.0, exhaust_speed=10.0,
                       moment_of_inertia=1.0, torque=1.0)
    ship = w.add_ship(spec, (0.0, 0.0))
    w.set_body(ship, angular_velocity=0.3)
    w.step(100)
    assert w.heading(ship) == pytest.approx(0.3, abs=1e-14)
    w.control(ship, turn=1.0)                          # its thrusters still turn it
    w.step(100)
    assert w.angular_velocity(ship) == pytest.approx(1.3, abs=1e-12)


@pytest.mark.parametrize("dim", [2, 3])
def test_rotors_survive_snapshots_state_files_and_replay(tmp_path, dim):
    w, log, rock = _pair(dim, record=tmp_path / "run.h5")
    w.step(7)
    w.set_heading(int(w.ids[0]), 0.25 if dim == 2 else (0.0, 0.0, 1.0))
    w.step(30)
    log.close()
    assert sp.replay(tmp_path / "run.h5").ok
    w, _, rock = _pair(dim)
    w.step(7)
    snap = w.snapshot()
    loaded = sp.World.from_state(w.state())
    w.step(30)
    after = w.digest()
    w.restore(snap)
    w.step(30)
    loaded.step(30)
    assert w.digest() == loaded.digest() == after
    assert np.array_equal(w.orientation(rock), loaded.orientation(rock))
    assert w.orientation(rock)[0] != 1.0


@pytest.mark.parametrize("dim, call, message", [
    (2, lambda w, b, s: w.set_body(b, angular_velocity=float("nan")), "angular_velocity"),
    (2, lambda w, b, s: w.set_body(b, angular_velocity=(1.0, 2.0)), "angular_velocity"),
    (3, lambda w, b, s: w.set_body(b, angular_velocity=1.0), "angular_velocity"),
    (2, lambda w, b, s: w.set_body(b, radius=-1.0, angular_velocity=1.0), "radius"),
    (2, lambda w, b, s: w.set_body(s, angular_velocity=1.0), "arcade.*moment_of_inertia"),
    (2, lambda w, b, s: w.set_heading(b, "north"), "heading"),
    (3, lambda w, b, s: w.set_heading(b, (0.0, 0.0, 0.0)), "cannot be zero"),
    (2, lambda w, b, s: w.set_heading(99, 1.0), "body = 99"),
])
def test_bad_orientations_are_named_and_nothing_changes(dim, call, message):
    w = sp.World(dim, gravity="none")
    body = w.add_body(1.0, np.zeros(dim))
    ship = w.add_ship(sp.ShipSpec(dry_mass=1.0, fuel_mass=1.0, max_thrust=1.0,
                                  exhaust_speed=10.0, turn_rate=1.0), np.ones(dim))
    before, columns = w.digest(), set(w._b.columns)
    with pytest.raises(ValueError, match=message):
        call(w, body, ship)
    assert w.digest() == before and set(w._b.columns) == columns


@pytest.mark.parametrize("dim", [2, 3])
def test_headings_reads_every_body_at_once(dim):
    w, _, rock = _pair(dim)
    ship = w.add_ship(sp.ShipSpec(dry_mass=1.0, fuel_mass=1.0, max_thrust=1.0,
                                  exhaust_speed=10.0, turn_rate=1.0), np.full(dim, 3.0),
                      heading=2.5 if dim == 2 else (0.0, -1.0, 1.0))
    w.step(13)
    got = w.headings
    assert np.isnan(got[0]).all()                          # the star has none
    for body in (rock, ship):
        np.testing.assert_allclose(got[w.index_of(body)], w.heading(body), atol=1e-15)
