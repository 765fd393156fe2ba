"""Compound hitboxes (sp.Circles): circles fixed in a body's frame, turning with it. Contacts
are found circle by circle (a ball through the gap of a dumbbell misses it), a bounce's
impulse turns the body by its moment of inertia (angular momentum and, elastic, energy
conserved to rounding), walls too; events name the circles; the shapes are in snapshots,
state files and replays; bad input is named and changes nothing."""
import math

import numpy as np
import pytest

import spacephys as sp

STICK = sp.Circles([[1.0, 0.0], [-1.0, 0.0]], [0.25, 0.25])


def _scene(dim=2, response="elastic", restitution=None):
    w = sp.World(dim, gravity="none", dt=0.01)
    w.add_kind("rock")
    w.set_collision("rock", "rock", response, restitution)
    return w


def _momenta(w, stick, I):
    """Linear momentum (dim,) and angular momentum about the origin (z in 2D), the stick's
    spin included."""
    m, x, v = w.mass, w.pos, w.vel
    p = (m[:, None] * v).sum(axis=0)
    if w.dim == 2:
        L = float((m * (x[:, 0] * v[:, 1] - x[:, 1] * v[:, 0])).sum())
        return p, L + I * w.angular_velocity(stick)
    L = (m[:, None] * np.cross(x, v)).sum(axis=0)
    return p, L + I * _world_spin(w, stick)


def _world_spin(w, body):
    """The body's angular velocity in the world frame (3,)."""
    q = w.orientation(body)
    wv = np.asarray(w.angular_velocity(body), float)
    x = q[1:]
    t = 2.0 * np.cross(x, wv)
    return wv + q[0] * t + np.cross(x, t)


@pytest.mark.parametrize("e", [1.0, 0.5])
def test_a_ball_on_a_sticks_tip_spins_it_as_the_impulse_law_says(e):
    w = _scene(response="elastic" if e == 1.0 else "bounce",
               restitution=None if e == 1.0 else e)
    stick = w.add_body(1.0, (0.0, 0.0), kind="rock", shape=STICK)
    ball = w.add_body(2.0, (1.0, 3.0), (0.0, -1.0), kind="rock", radius=0.25)
    I = STICK.gyration()                 # mass 1: discs of r 0.25 at +-1
    p0, L0 = _momenta(w, stick, I)
    E0 = 0.5 * 2.0
    w.step(300)
    # the impulse law: J = (1 + e) v / (1/m1 + 1/m2 + arm^2 / I), arm 1, normal along y
    J = (1.0 + e) * 1.0 / (1.0 + 0.5 + 1.0 / I)
    v_stick = w.vel[w.index_of(stick)]
    v_ball = w.vel[w.index_of(ball)]
    assert v_stick[1] == pytest.approx(-J, rel=1e-12) and abs(v_stick[0]) < 1e-15
    assert v_ball[1] == pytest.approx(-1.0 + J / 2.0, rel=1e-12)
    assert w.angular_velocity(stick) == pytest.approx(-J / I, rel=1e-12)
    p1, L1 = _momenta(w, stick, I)
    np.testing.assert_allclose(p1, p0, atol=1e-15)
    assert L1 == pytest.approx(L0, abs=1e-14)
    E1 = 0.5 * (w.mass * (w.vel ** 2).sum(axis=1)).sum() \
        + 0.5 * I * w.angular_velocity(stick) ** 2
    lost = (1.0 - e * e) / (2.0 * (1.0 + 0.5 + 1.0 / I))
    assert E1 == pytest.approx(E0 - lost, abs=1e-14)


def test_the_event_names_the_circle_hit():
    w = _scene()
    stick = w.add_body(1.0, (0.0, 0.0), kind="rock", shape=STICK)
    ball = w.add_body(1.0, (-1.0, 3.0), (0.0, -1.0), kind="rock", radius=0.25)
    seen = []
    for _ in range(300):
        w.step(1)
        seen.extend(w.events.tolist())
    bounce = [ev for ev in seen if ev[0] == sp.events.BOUNCE]
    assert len(bounce) == 1
    ev = np.array(bounce, sp.EVENT_DTYPE)[0]
    assert (ev["a"], ev["b"]) == (stick, ball)
    assert (ev["circle_a"], ev["circle_b"]) == (1, -1)     # the circle at -1, the round ball
    # the point is on the circle's surface, the normal between the circles' centres
    assert (ev["x"], ev["y"]) == pytest.approx((-1.0, 0.25), abs=2e-3)
    assert (ev["nx"], ev["ny"]) == pytest.approx((0.0, 1.0), abs=2e-3)
    assert ev["distance"] == pytest.approx(0.5, abs=1e-9)


def test_a_ball_through_the_gap_misses_and_the_heading_turns_the_circles():
    w = _scene()
    stick = w.add_body(1.0, (0.0, 0.0), kind="rock", shape=STICK)
    ball = w.add_body(1.0, (0.0, 3.0), (0.0, -1.0), kind="rock", radius=0.25)
    assert w.get(stick).radius == 1.25       # the bounding circle would meet the ball
    w.step(600)
    assert not len(w.events)
    assert w.vel[w.index_of(ball)][1] == -1.0
    # turned a quarter: the circles lie along y, and the same ball meets the upper one
    w2 = _scene()
    stick = w2.add_body(1.0, (0.0, 0.0), kind="rock", shape=STICK)
    w2.set_heading(stick, math.pi / 2)
    ball = w2.add_body(1.0, (0.0, 3.0), (0.0, -1.0), kind="rock", radius=0.25)
    np.testing.assert_allclose(w2.circles(stick)[0], [[0.0, 1.0], [0.0, -1.0]], atol=1e-15)
    w2.step(300)
    # head on through both centres: no spin, the equal masses swap velocities
    assert w2.vel[w2.index_of(ball)][1] == pytest.approx(0.0, abs=1e-15)
    assert w2.angular_velocity(stick) == pytest.approx(0.0, abs=1e-15)


def test_a_spinning_stick_sweeps_into_a_ball_where_its_tip_gets_there():
    """The tip turns on an arc; each step's chord finds the contact within a step's turn."""
    I = STICK.gyration()
    # the tip (cos a, sin a) touches a ball of radius 0.25 at (0, 1.4) when
    # |tip - ball| = 0.5: 1 + 1.96 - 2.8 sin a = 0.25
    w = _scene()
    stick = w.add_body(1.0, (0.0, 0.0), kind="rock", shape=STICK)
    w.set_body(stick, angular_velocity=2.0)
    ball = w.add_body(1.0, (0.0, 1.4), kind="rock", radius=0.25)
    p0, L0 = _momenta(w, stick, I)
    for _ in range(200):
        w.step(1)
        if len(w.events):
            break
    angle = math.asin((1.0 + 1.96 - 0.25) / 2.8)
    t_hit = angle / 2.0
    assert w.events[0]["time"] == pytest.approx(t_hit, abs=1e-4)
    assert w.events[0]["circle_a"] == 0
    p1, L1 = _momenta(w, stick, I)
    np.testing.assert_allclose(p1, p0, atol=1e-14)
    assert L1 == pytest.approx(L0, abs=1e-14)
    assert w.vel[w.index_of(ball)][1] > 0.0           # knocked away, the stick slowed
    assert 0.0 < w.angular_velocity(stick) < 2.0


def test_a_tilted_stick_bounces_off_a_wall_and_spins_energy_kept():
    w = sp.World(2, gravity="none", dt=0.001)
    stick = w.add_body(1.0, (0.0, 2.0), (0.0, -1.0), shape=STICK)
    w.set_heading(stick, math.radians(30.0))
    w.add_plane((0.0, 0.0), (0.0, 1.0), restitution=1.0)
    I = STICK.gyration()
    w.step(3000)
    assert w.angular_velocity(stick) != 0.0 and w.vel[0, 1] > 0.0      # bounced, spinning
    E = 0.5 * (w.vel[0] ** 2).sum() + 0.5 * I * w.angular_velocity(stick) ** 2
    assert E == pytest.approx(0.5, rel=1e-12)


def test_a_wall_event_names_the_circle():
    w = sp.World(2, gravity="none", dt=0.001)
    stick = w.add_body(1.0, (0.0, 2.0), (0.0, -1.0), shape=STICK)
    w.set_heading(stick, math.radians(30.0))
    w.add_plane((0.0, 0.0), (0.0, 1.0), restitution=1.0)
    events = []
    for _ in range(3000):
        w.step(1)
        events.extend(w.events.tolist())
    first = np.array(events[:1], sp.EVENT_DTYPE)[0]
    assert first["kind"] == sp.events.WALL and first["a"] == stick
    assert first["circle_a"] == 1 and first["circle_b"] == -1   # (-1, 0) turned 30: below
    # the circle's lowest point touches y = 0: its centre 0.25 up
    assert first["y"] == pytest.approx(0.0, abs=1e-9)


def test_three_dimensions_spheres_spin_about_the_right_axis():
    w = _scene(dim=3)
    rod = sp.Circles([[1.0, 0.0, 0.0], [-1.0, 0.0, 0.0]], [0.25, 0.25])
    stick = w.add_body(1.0, (0.0, 0.0, 0.0), kind="rock", shape=rod)
    w.add_body(1.0, (1.0, 0.0, 3.0), (0.0, 0.0, -1.0), kind="rock", radius=0.25)
    I = rod.gyration()
    p0, L0 = _momenta(w, stick, I)
    w.step(300)
    spin = np.asarray(w.angular_velocity(stick))
    # a push down (-z) on the tip at +x turns it about +y
    assert spin[1] > 0.0 and abs(spin[0]) < 1e-15 and abs(spin[2]) < 1e-15
    p1, L1 = _momenta(w, stick, I)
    np.testing.assert_allclose(p1, p0, atol=1e-15)
    np.testing.assert_allclose(L1, L0, atol=1e-14)


def test_ships_take_spin_by_their_moment_of_inertia_arcade_ships_none():
    hull = sp.Circles([[1.0, 0.0], [-1.0, 0.0]], [0.25, 0.25])
    for inertia in (None, 3.0):
        w = _scene()
        spec = sp.ShipSpec(shape=hull, kind="rock", moment_of_inertia=inertia,
                           torque=0.0 if inertia is None else 1.0)
        ship = w.add_ship(spec, (0.0, 0.0))
        assert w.shape(ship) == hull and w.get(ship).radius == 1.25
        w.add_body(1.0, (1.0, 3.0), (0.0, -1.0), kind="rock", radius=0.25)
        w.step(300)
        if inertia is None:
            assert w.angular_velocity(ship) == 0.0
        else:
            J = 2.0 / (1.0 + 1.0 + 1.0 / inertia)
            assert w.angular_velocity(ship) == pytest.approx(-J / inertia, rel=1e-12)


@pytest.mark.parametrize("dim", [2, 3])
def test_shapes_survive_snapshots_state_files_and_replay(dim, tmp_path):
    def at(*xy):
        return xy + (0.0,) * (dim - 2)

    stick_shape = STICK if dim == 2 else sp.Circles([at(1.0, 0.0), at(-1.0, 0.0)],
                                                    [0.25, 0.25])
    w = _scene(dim)
    log = w.record(tmp_path / "run.h5")
    stick = w.add_body(1.0, at(0.0, 0.0), kind="rock", shape=stick_shape)
    w.add_body(1.0, at(1.0, 3.0), at(0.0, -1.0), kind="rock", radius=0.25)
    other = w.add_body(1.0, at(5.0, 0.0), kind="rock")
    w.set_body(other, shape=sp.Circles([at(0.0, 0.5), at(0.0, -0.5)], [0.3, 0.3]))
    w.step(150)
    loaded = sp.World.from_state(w.state())
    assert loaded.shape(stick) == stick_shape and loaded.shape(other) == w.shape(other)
    w.step(200)
    loaded.step(200)
    assert loaded.digest() == w.digest() and np.any(w.angular_velocity(stick) != 0.0)
    log.close()
    assert sp.replay(tmp_path / "run.h5").ok
    saved = loaded.snapshot()
    loaded.step(50)
    after = loaded.digest()
    loaded.restore(saved)
    loaded.step(50)
    assert loaded.digest() == after
    # round again
    loaded.set_body(other, shape=False)
    assert loaded.shape(other) is None


@pytest.mark.parametrize("call, message", [
    (lambda w, a: w.add_body(1.0, (0.0, 0.0), shape=sp.Circles([[0, 0, 0]], [1.0])),
     "3 coordinates in a 2D World"),
    (lambda w, a: w.add_body(1.0, (0.0, 0.0), radius=2.0, shape=STICK), "radius"),
    (lambda w, a: w.add_body(1.0, (0.0, 0.0), shape="stick"), "shape = 'stick'"),
    (lambda w, a: w.add_bodies(1.0, np.zeros((2, 2)), shape=[STICK]), "list of 2"),
    (lambda w, a: w.set_body(a, radius=3.0), "radius of"),
    (lambda w, a: w.set_body(a, shape=sp.Circles([[0, 0, 0]], [1.0])), "3 coordinates"),
    (lambda w, a: sp.Circles([], []), "at least one circle"),
    (lambda w, a: sp.Circles([[float("nan"), 0.0]], [1.0]), r"offsets\[0\]\[0\] = nan"),
    (lambda w, a: sp.Circles([[0.0, 0.0]], [0.0]), r"radii\[0\] = 0.0"),
    (lambda w, a: sp.Circles([[0.0, 0.0], [1.0, 0.0]], [1.0]), "offsets has shape"),
    (lambda w, a: sp.ShipSpec(shape=STICK, radius=1.0), "radius = 1.0 with a shape"),
])
def test_bad_shapes_are_named_and_nothing_changes(call, message):
    w = _scene()
    a = w.add_body(1.0, (0.0, 0.0), kind="rock", shape=STICK)
    before = w.digest()
    with pytest.raises(ValueError, match=message):
        call(w, a)
    assert w.digest() == before and w.shape(a) == STICK


def test_the_guides_example_runs_as_written(capsys):
    """docs/guide/collisions.md's compound example: the ball through the gap passes, the one
    on the tip spins the bar."""
    import pathlib
    text = (pathlib.Path(__file__).parents[1] / "docs/guide/collisions.md").read_text()
    code = text.split("## Compound hitboxes")[1].split("```python\n")[1].split("```")[0]
    exec(compile(code, "collisions.md", "exec"), {})
    lines = capsys.readouterr().out.splitlines()
    assert lines[0] == "[ 0. -1.]"
    assert float(lines[1].split()[0]) > 0.0


def test_a_sensor_sees_each_circle_pass_and_the_gap_between():
    """A bar sliding through a sensor zone: each circle begins and ends its overlap at the
    times its centre comes within r + R of the zone's (the gap between them: apart)."""
    w = sp.World(2, gravity="none", dt=0.01)
    w.add_kind("rock")
    w.add_kind("zone")
    w.set_collision("rock", "zone", "sensor")
    bar = w.add_body(1.0, (-5.0, 0.0), (1.0, 0.0), kind="rock", shape=STICK)
    zone = w.add_body(0.0, (0.0, 0.0), kind="zone", radius=0.5)
    events = []
    for _ in range(1000):
        w.step(1)
        events.extend(w.events.tolist())
    ev = np.array(events, sp.EVENT_DTYPE)
    assert list(ev["kind"]) == [sp.events.SENSOR_BEGIN, sp.events.SENSOR_END] * 2
    assert set(ev["a"]) == {bar} and set(ev["b"]) == {zone}
    assert list(ev["circle_a"]) == [0, 0, 1, 1]
    # circle 0 at x = -4 + t, circle 1 at -6 + t: within 0.75 of the zone's centre
    np.testing.assert_allclose(ev["time"], [3.25, 4.75, 5.25, 6.75], atol=1e-9)
