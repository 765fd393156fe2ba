"""A prediction's tape (spacephys/tape.py, kernels/tape.py): the pulling bodies' future,
recorded by one prediction and played back by the next while the World flies the same steps.
Every prediction here equals a fresh copy's bit for bit (paths, velocities, events), whether
the tape played, recorded, or stopped; the counter of played steps says which happened."""
import numba
import numpy as np
import pytest

import spacephys as sp


def _scene(integrator="yoshida4"):
    """A star, two planets, a ship on a plan and a passive ship headed into the inner planet."""
    w = sp.World(dim=3, G=1.0, integrator=integrator, dt=4e-3)
    w.add_body(1.0, [0.0, 0.0, 0.0], radius=0.05, kind="star")
    inner = w.add_body(1e-3, [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], radius=0.02, kind="planet")
    w.add_body(2e-3, [0.0, 1.6, 0.1], [-0.79, 0.0, 0.0], radius=0.03, kind="planet")
    spec = sp.ShipSpec(dry_mass=1e-9, fuel_mass=1e-9, max_thrust=1e-9, exhaust_speed=3.0,
                       radius=0.001)
    ship = w.add_ship(spec, [1.05, 0.0, 0.0], [0.0, 1.14, 0.0])
    w.plan(ship, [sp.Burn(0.2, 0.3, "prograde", frame=inner)])
    probe = w.add_ship(spec, [1.0, 0.1, 0.0], [0.0, 0.7, 0.0])
    return w, inner, ship, probe


def _played(w):
    return w.__dict__["_shadows"][False, False].tape.played


def _same(w, ids, **options):
    """w.predict (its kept copy and tape) against a fresh copy's prediction."""
    got = w.predict(ids, 0.8, points=50, **options)
    fresh = w.copy().predict(ids, 0.8, points=50, **options)
    assert np.array_equal(got.pos, fresh.pos, equal_nan=True)
    assert np.array_equal(got.vel, fresh.vel, equal_nan=True)
    assert got.events.tobytes() == fresh.events.tobytes()
    return got


@pytest.mark.parametrize("integrator", ["yoshida4", "rk4"])
def test_a_prediction_plays_the_tape_back_and_equals_the_full_run(integrator):
    """The second prediction plays all 200 steps back; then from 7 steps on, after the World
    flew them; after a plan is edited (the ship moves no pulling body); and it records anew
    when a held force moves a planet, the softening changes, a planet is fixed, or the World
    flies another integrator's steps."""
    w, inner, ship, probe = _scene(integrator)
    ids = [ship, probe, inner]
    _same(w, ids)
    assert _played(w) == 0                       # the first one records
    _same(w, ids)
    assert _played(w) == 200
    w.step(7)
    _same(w, ids)
    assert _played(w) == 200 + 193               # the tape's steps 7..199, then recording
    w.plan(ship, [sp.Burn(w.t + 0.1, 0.2, "retrograde", frame=inner)])
    _same(w, ids)
    assert _played(w) == 200 + 193 + 200
    w.apply_force(inner, [1e-6, 0.0, 0.0])
    _same(w, ids)
    assert _played(w) == 200 + 193 + 200         # recorded anew
    for change in (lambda: setattr(w, "softening", 1e-3),
                   lambda: w.set_body(inner, fixed=True)):
        change()
        before = _played(w)
        _same(w, ids)
        assert _played(w) == before              # recorded anew
    w.integrator = "leapfrog" if integrator != "leapfrog" else "yoshida4"   # other steps
    w.step(3)
    before = _played(w)
    _same(w, ids, integrator=integrator)
    assert _played(w) == before


def test_a_collision_that_moves_a_pulling_body_plays_as_recorded_or_stops():
    """The probe merges into the inner planet mid-prediction, changing its mass and velocity.
    Predicted again, the merge happens as recorded and the tape plays on; with the probe
    moved off its course, the planet is not where the recording's merge left it, and the
    tape stops there."""
    w, inner, ship, probe = _scene()
    w.set_collision("ship", "planet", "merge")
    first = _same(w, [ship, inner])
    merges = [e for e in first.events if sp.EVENT_KINDS[e["kind"]] == "merge"]
    assert len(merges) == 1 and merges[0]["b"] == probe
    _same(w, [ship, inner])
    assert _played(w) == 200
    w.set_body(probe, vel=[0.5, 0.7, 0.0])
    moved = _same(w, [ship, inner])
    assert not any(sp.EVENT_KINDS[e["kind"]] == "merge" for e in moved.events)
    assert 200 < _played(w) < 400


def test_a_periodic_box_plays_the_tape():
    """A periodic box wraps every position every step (its last bits change, crossing or not):
    the tape compares the pulling bodies after the wrap with the recording's and plays."""
    w, inner, ship, probe = _scene()
    w.set_boundary("periodic", lo=(-3.3, -3.3, -3.3), hi=(3.7, 3.7, 3.7))
    _same(w, [ship, inner])
    _same(w, [ship, inner])
    assert _played(w) == 200
    w.step(5)                                    # the World's state is after the wrap too
    _same(w, [ship, inner])
    assert _played(w) == 200 + 195


def test_a_destroyed_ship_leaves_the_tape_playing():
    """A ship destroyed on a planet does not move it: the tape plays on past the impact."""
    w, inner, ship, probe = _scene()
    w.set_collision("ship", "planet", "destroy_a")
    _same(w, [ship, probe])
    _same(w, [ship, probe])
    assert _played(w) == 200


def test_scenes_without_a_tape_predict_as_before():
    """Gauss-Radau (its steps depend on every body), Wisdom-Holman (Jacobi coordinates of
    every body) and user forces keep no tape; their predictions equal a fresh copy's."""
    w, inner, ship, probe = _scene("gauss_radau")
    _same(w, [ship, inner])
    _same(w, [ship, inner])
    assert w.__dict__["_shadows"][False, False].tape is None
    w, inner, ship, probe = _scene()
    w.add_force(_nudge, [1e-6])
    _same(w, [ship, inner])
    _same(w, [ship, inner])
    assert w.__dict__["_shadows"][False, False].tape is None


@numba.njit
def _nudge(t, pos, vel, mass, ids, params, out):
    for i in range(pos.shape[0]):
        out[i, 0] += params[0]


def test_a_pulling_body_destroyed_mid_prediction_stops_the_tape():
    """An asteroid (it pulls, a row before the planets) falls into the star. The tape is
    recorded while it swings by; then a rule destroys it there: the star does not move, but
    a pulling body left, so the tape stops (its rows no longer fit the bodies)."""
    w = sp.World(dim=3, G=1.0, integrator="yoshida4", dt=4e-3)
    w.add_body(1.0, [0.0, 0.0, 0.0], radius=0.05, kind="star")
    rock = w.add_body(1e-4, [0.02, -0.3, 0.0], [0.0, 0.5, 0.0], radius=0.01, kind="asteroid")
    planet = w.add_body(1e-3, [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], radius=0.02, kind="planet")
    w.add_body(2e-3, [0.0, 1.6, 0.1], [-0.79, 0.0, 0.0], radius=0.03, kind="planet")
    ship = w.add_ship(sp.ShipSpec(dry_mass=1e-9, fuel_mass=0.0, max_thrust=0.0),
                      [1.05, 0.0, 0.0], [0.0, 1.14, 0.0])
    _same(w, [ship, planet])
    w.set_collision("asteroid", "star", "destroy_a")
    first = _same(w, [ship, planet])
    assert [sp.EVENT_KINDS[e["kind"]] for e in first.events if e["a"] == rock] == ["destroy"]
    assert 0 < _played(w) < 200


def test_a_pulling_ship_keeps_no_tape():
    """A ship that pulls moves the pulling bodies by its controls and plans, which the tape
    cannot know: predictions run in full."""
    w, inner, ship, probe = _scene()
    big = w.add_ship(sp.ShipSpec(dry_mass=1e-4, fuel_mass=1e-4, max_thrust=1e-3,
                                 exhaust_speed=3.0, active=True), [0.0, -1.2, 0.0],
                     [0.9, 0.0, 0.0])
    w.plan(big, [sp.Burn(0.1, 0.3, "prograde")])
    _same(w, [ship, big])
    w.plan(big, [sp.Burn(0.1, 0.3, "retrograde")])
    _same(w, [ship, big])
    assert _played(w) == 0


def test_a_pulling_body_killed_in_place_stops_the_tape():
    """A missile's fuse kills the inner planet where it is (its state does not change, it
    only dies): a pulling body left, so the tape recorded without the missile stops there."""
    w, inner, ship, probe = _scene()
    _same(w, [ship, probe])
    w.launch(probe, sp.MissileSpec(mass=1e-9, thrust=1e-8, fuel_mass=1e-9, exhaust_speed=1.0,
                                   guidance="pn", turn_rate=5.0, fuse_radius=0.05,
                                   radius=0.001), target=inner, heading=[0.0, -1.0, 0.0])
    with pytest.warns(RuntimeWarning, match="is gone"):      # the ship's burn's frame
        got = _same(w, [ship, probe])
    kills = [e for e in got.events if sp.EVENT_KINDS[e["kind"]] == "detonation"]
    assert len(kills) == 1 and kills[0]["b"] == inner
    assert 0 < _played(w) < 200


def _fleet(fuse=0.0):
    """_scene's star and planets, 12 ships (half of them on plans that burn their fuel out at
    different times), a passive target and a rock nobody predicts."""
    w, inner, ship, probe = _scene()
    spec = sp.ShipSpec(dry_mass=1e-9, fuel_mass=1e-10, max_thrust=1e-9, exhaust_speed=3.0,
                       radius=0.001)
    missile = sp.MissileSpec(mass=1e-9, fuse_radius=fuse, radius=0.001) if fuse else None
    ships = [ship, probe]
    for k in range(10):
        r = 1.1 + 0.02 * k
        pos, vel = [r, 0.0, 0.01 * k], [0.0, 1.0 / np.sqrt(r) + 0.01, 0.0]
        ships.append(w.add_ship(spec, pos, vel))
        if k % 2:
            w.plan(ships[-1], [sp.Burn(0.4 - 0.03 * k, 0.5, "prograde", frame=inner)])
    target = w.add_ship(spec, [0.0, -1.2, 0.0], [0.9, 0.0, 0.0])
    w.add_body(0.0, [0.0, 2.5, 0.0], [-0.6, 0.0, 0.0], radius=0.01)        # the rock
    if missile is not None:
        w.launch(ships[0], missile, target=target)
        w.step(1)                               # launched with this step
    return w, ships, target


def _compare(got, fresh):
    assert np.array_equal(got.pos, fresh.pos, equal_nan=True)
    assert np.array_equal(got.vel, fresh.vel, equal_nan=True)
    assert np.array_equal(got.about, fresh.about)
    assert got.events.tobytes() == fresh.events.tobytes()
    for name in ("apsides", "changes", "approaches", "impacts"):
        mine, theirs = getattr(got, name), getattr(fresh, name)
        assert len(mine) == len(theirs) and all(
            str(a) == str(b) for a, b in zip(mine, theirs)), name


def test_many_ships_are_predicted_in_two_halves_on_two_threads_bit_for_bit():
    """With the planets' future on the tape, 12 ships (6 burning their fuel out: events) are
    predicted in two halves side by side (predict._Halves), the rock left out: paths,
    dominant bodies, markers, the closest approach to a ship that is not predicted and the
    events in time order equal a fresh copy's full run. Each half plays all 200 steps back
    (the tape's counter books both); a run the tape does not cover is one run (it records
    the rest)."""
    w, ships, target = _fleet()
    options = dict(points=60, target=target)
    first = w.predict(ships, 0.8, **options)
    assert _played(w) == 0
    got = w.predict(ships, 0.8, **options)
    halves = w.__dict__["_shadows"][False, False].halves
    assert _played(w) == 2 * 200
    assert [c.n for c in halves.copies] == [3 + 1 + 6, 3 + 6]    # no rock
    fresh = w.copy().predict(ships, 0.8, **options)
    _compare(got, fresh)
    _compare(first, fresh)
    assert sum(sp.EVENT_KINDS[e["kind"]] == "fuel_empty" for e in got.events) >= 3
    assert len(got.approaches) == 12
    w.step(5)               # a HUD's next frame: the tape ends 5 steps short, one run
    got = w.predict(ships, 0.8, **options)
    assert _played(w) == 2 * 200 + 195
    _compare(got, w.copy().predict(ships, 0.8, **options))
    got = w.predict(ships, 0.8, **options)   # now it covers the run: halves, loaded anew
    assert _played(w) == 2 * 200 + 195 + 2 * 200
    _compare(got, w.copy().predict(ships, 0.8, **options))


def test_ships_coupled_otherwise_are_predicted_in_one_run():
    """A missile with a proximity fuse reads its target: no halves; the tape plays once."""
    w, ships, target = _fleet(fuse=0.01)
    w.predict(ships, 0.8, points=60)
    got = w.predict(ships, 0.8, points=60)
    assert _played(w) == 200
    assert "halves" not in w.__dict__["_shadows"][False, False].__dict__
    _compare(got, w.copy().predict(ships, 0.8, points=60))
