"""Contacts checked against hand-computed answers: a ball bouncing under gravity (uniform
field and a point mass), where the velocity at the time of impact differs from the step's end
velocity, and several contacts of one body within one step, where every event's time and
point and the end-of-step state are exact (straight lines, no gravity).

test_collisions.py checks conserved totals and single gravity-free contacts; these check the
timing and the state a contact leaves behind.

Under gravity, over a step each body moves on the chord from its start to its end position
(the documented model), and a contact responds to the velocity interpolated to its time. In a
uniform field the integrators are exact at the step ends, so the only departure from the
analytic motion is the chord's sag below the parabola, at most g dt^2 / 8: the impact comes
early by at most sag / (impact speed). The tolerances below are derived from that bound or
measured (the measured value with the right code is in a comment beside each)."""
import math

import numpy as np
import pytest

import spacephys as sp
from spacephys import events as ev

# ----------------------------------------------------------------------------- helpers

G0 = 9.8                 # the uniform field [length / time^2]
R_BIG, R_BALL = 1.0, 0.25


def uniform_drop(h, dt, *, target="ball", e=None, x0=0.0, integrator="leapfrog"):
    """A ball of radius R_BALL dropped from rest, its centre h above the height at which it
    touches the target below: a fixed ball of radius R_BIG at the origin (target="ball", the
    pair path) or the floor y = R_BIG (target="plane", the wall path); uniform field (0, -G0).
    e : None for an elastic contact, else the restitution. x0: the horizontal offset of the
    drop (a fixed ball only). Returns (world, ball id)."""
    w = sp.World(dim=2, gravity="uniform", g=(0.0, -G0), dt=dt, integrator=integrator)
    w.add_kind("ball")
    if target == "ball":
        w.add_kind("brick")
        w.set_collision("ball", "brick", "elastic" if e is None else "bounce", restitution=e)
        w.add_body(5.0, (0.0, 0.0), radius=R_BIG, kind="brick", fixed=True)
        y_touch = math.sqrt((R_BIG + R_BALL) ** 2 - x0 ** 2)
    else:
        assert x0 == 0.0
        w.add_plane((0.0, R_BIG), (0.0, 1.0), restitution=1.0 if e is None else e)
        y_touch = R_BIG + R_BALL
    ball = w.add_body(2.0, (x0, y_touch + h), radius=R_BALL, kind="ball")
    return w, ball


def sag_time(dt, speed):
    """How early a contact on the chord can come: the chord's largest sag below the parabola,
    g dt^2 / 8, over the closing speed."""
    return G0 * dt * dt / 8.0 / speed


def assert_rel(actual, expected, rel, what):
    """|actual - expected| <= rel * max(|expected|, 1), elementwise, with a readable message."""
    actual, expected = np.asarray(actual, float), np.asarray(expected, float)
    scale = np.maximum(np.abs(expected), 1.0)
    err = np.max(np.abs(actual - expected) / scale)
    assert err <= rel, f"{what}: {actual} vs {expected} (error {err:.3g} > {rel:.3g})"


def uniform_chord_contact(h, dt):
    """The documented model's first contact of a ball dropped from rest h above its touching
    height: the integrators are exact at the step ends in a uniform field (y_k = h - g t_k^2 / 2
    above it), the ball moves on the chord between them, so the contact is at the fraction s
    of the step k whose chord crosses the touching height. Returns (time, speed there)."""
    k = int(math.sqrt(2.0 * h / G0) / dt)
    while True:
        y0 = h - 0.5 * G0 * (k * dt) ** 2
        y1 = h - 0.5 * G0 * ((k + 1) * dt) ** 2
        if y0 > 0.0 >= y1:
            break
        k += 1 if y1 > 0.0 else -1
    s = y0 / (y0 - y1)
    return (k + s) * dt, G0 * dt * (k + s)


# ----------------------------------------------------------------------------- under gravity


@pytest.mark.parametrize("target", ["ball", "plane"])
def test_elastic_bounces_in_a_uniform_field_keep_the_energy_and_the_analytic_times(target):
    """A ball dropped from rest onto a fixed ball (pair path) or a floor (wall path), elastic,
    bouncing three times: the contact must reverse the normal velocity AT the time of impact.
    On the chord with the interpolated velocity the total energy at every step end is then
    exact algebraically (measured 1.8e-15); responding with the step's end velocity instead
    gains 1-2 % per bounce. Each bounce k comes at (2k+1) t* (t* = sqrt(2h/g)), early by at
    most the chord's sag per crossing, (2k+1) g dt^2 / (8 v*) (measured 0.97, 0.91, 0.77 of
    it), with the impact speed v* = g t* to g dt^2 / 8 / v* * g (measured 0.97 of it). The
    first contact also lands where the chord crosses the touching height, to 1e-12 (measured
    2e-16 in time, 1.3e-15 in speed): the model docs/guide/collisions.md documents."""
    dt, h = 1 / 240, 1.0
    w, ball = uniform_drop(h, dt, target=target)
    t_star = math.sqrt(2 * h / G0)
    v_star = G0 * t_star
    E0 = w.energy()
    events, starts = [], []
    for _ in range(int(6 * t_star / dt)):
        t_start = w.t
        w.step(1)
        events.extend(w.events)
        starts.extend([t_start] * len(w.events))
        assert w.energy() == pytest.approx(E0, rel=1e-13, abs=0)
    events = np.array(events, dtype=sp.EVENT_DTYPE)
    kind = ev.BOUNCE if target == "ball" else ev.WALL
    assert events["kind"].tolist() == [kind] * 3
    sag = sag_time(dt, v_star)
    for k, (e, t_start) in enumerate(zip(events, starts)):
        assert abs(e["time"] - (2 * k + 1) * t_star) <= 1.5 * (2 * k + 1) * sag, k
        assert e["t_in_step"] == pytest.approx(e["time"] - t_start, abs=1e-12)
        assert abs(e["speed"] - v_star) <= 1.5 * G0 * sag, k
        assert e["energy_lost"] == 0.0
        # the contact point is the top of the target, whatever the timing
        assert [e["x"], e["y"]] == pytest.approx([0.0, R_BIG], abs=1e-12)
        if target == "ball":
            assert (e["a"], e["b"]) == (0, ball)
            assert [e["nx"], e["ny"]] == pytest.approx([0.0, 1.0], abs=1e-12)
        else:
            assert (e["a"], e["b"]) == (ball, -1)
            assert [e["nx"], e["ny"]] == pytest.approx([0.0, -1.0], abs=1e-12)
    t_chord, v_chord = uniform_chord_contact(h, dt)
    assert events[0]["time"] == pytest.approx(t_chord, rel=1e-12)
    assert events[0]["speed"] == pytest.approx(v_chord, rel=1e-12)


@pytest.mark.parametrize("integrator", ["leapfrog", "rk4", "yoshida4", "yoshida8", "gauss_radau"])
def test_every_integrator_exact_in_a_uniform_field_bounces_at_the_chord_contact(integrator):
    """Each family hands the collision pass its own start and end of the step (Gauss-Radau:
    of the output interval). These integrators are exact at the step ends in a uniform field,
    so each must put the first contact where the chord crosses the touching height (to 1e-12;
    measured 1.8e-15 at worst) and keep the energy through three elastic bounces (to
    1e-13; measured 7.9e-15 at worst, Yoshida 8)."""
    dt, h = 1 / 240, 1.0
    w, _ = uniform_drop(h, dt, integrator=integrator)
    E0 = w.energy()
    times = []
    for _ in range(int(6 * math.sqrt(2 * h / G0) / dt)):
        w.step(1)
        times.extend(w.events["time"])
        assert w.energy() == pytest.approx(E0, rel=1e-13, abs=0)
    assert len(times) == 3
    assert times[0] == pytest.approx(uniform_chord_contact(h, dt)[0], rel=1e-12)


@pytest.mark.parametrize("target", ["ball", "plane"])
@pytest.mark.parametrize("e", [0.5, 0.8])
def test_a_bounce_in_a_uniform_field_leaves_e_times_the_impact_speed(target, e):
    """Restitution e under gravity: the rebound speed is e times the speed at impact, v* = g t*
    from free fall. Checked on the next impact (at t* + 2 e v* / g with speed e v*, free flight
    keeping the speed), on the energy left after the bounce (1/2 m (e v*)^2 above the contact
    height) and on the energy the event says was lost, (1 - e^2) m v*^2 / 2. Measured with the
    right code: second impact speed 8.3e-6 (e = 0.5) and 5.5e-7 relative; its time 0.54 and
    1.44 of the sag unit g dt^2 / (8 v*), within the bound (1 + 2e + 1/e) of it; the energy
    after the bounce 6.2e-5 and 1.2e-5 relative; energy_lost 2.1e-5. Responding with the step's
    end velocity changes the rebound speed by g dt (1 - s) (5e-3 relative here)."""
    dt, h, m = 1 / 240, 1.0, 2.0
    w, ball = uniform_drop(h, dt, target=target, e=e)
    t_star = math.sqrt(2 * h / G0)
    v_star = G0 * t_star
    y_touch = R_BIG + R_BALL
    t_second = t_star + 2 * e * v_star / G0
    events = []
    energy_after_first = []
    while w.t < t_second + 0.5 * (t_second - t_star):
        w.step(1)
        events.extend(w.events)
        if len(events) == 1:
            b = w.get(ball)
            energy_after_first.append(0.5 * m * b.vel @ b.vel + m * G0 * (b.pos[1] - y_touch))
    events = np.array(events, dtype=sp.EVENT_DTYPE)
    assert len(events) >= 2
    first, second = events[:2]
    sag = sag_time(dt, v_star)
    assert abs(first["time"] - t_star) <= 1.5 * sag
    assert first["speed"] == pytest.approx(v_star, rel=2e-4)              # 1.0e-5 measured
    assert first["energy_lost"] == pytest.approx(0.5 * m * (1 - e * e) * v_star ** 2,
                                                 rel=4e-4)               # 2.1e-5 measured
    assert second["speed"] == pytest.approx(e * v_star, rel=1e-4)        # 8.3e-6 measured
    assert abs(second["time"] - t_second) <= 1.5 * (1 + 2 * e + 1 / e) * sag
    assert energy_after_first, "no step ended between the first two bounces"
    np.testing.assert_allclose(energy_after_first, 0.5 * m * (e * v_star) ** 2,
                               rtol=1e-3)                                # 6.2e-5 measured


def test_an_oblique_drop_onto_a_fixed_ball_leaves_along_the_reflected_parabola():
    """Dropped from rest 0.5 to the side of a fixed ball's top: the contact point and normal are
    set by the geometry alone (exact), the velocity at impact (0, -v*) is reflected about the
    normal, and the ball flies on the parabola from the contact point with it. Its state 0.25
    after the impact against that parabola: measured 1.6e-5 in position, 7.7e-5 in velocity
    (the impact early by the chord's sag), energy to 7e-16. Responding with the step's end
    velocity puts 0.09 into the velocity."""
    dt, h, x0 = 1 / 240, 1.0, 0.5
    w, ball = uniform_drop(h, dt, x0=x0)
    t_star = math.sqrt(2 * h / G0)
    v_star = G0 * t_star
    y_touch = math.sqrt((R_BIG + R_BALL) ** 2 - x0 ** 2)
    n = np.array([x0, y_touch]) / (R_BIG + R_BALL)
    v_in = np.array([0.0, -v_star])
    v_out = v_in - 2 * (v_in @ n) * n
    E0 = w.energy()
    w.step(int(round((t_star + 0.25) / dt)))
    (e,) = w.events
    assert e["kind"] == ev.BOUNCE
    assert abs(e["time"] - t_star) <= 1.5 * sag_time(dt, v_star)
    assert [e["x"], e["y"]] == pytest.approx(R_BIG * n, abs=1e-12)
    assert [e["nx"], e["ny"]] == pytest.approx(n, abs=1e-12)
    assert e["speed"] == pytest.approx(v_star * n[1], rel=2e-4)
    tau = w.t - t_star
    b = w.get(ball)
    np.testing.assert_allclose(b.pos, [x0, y_touch] + v_out * tau - [0, 0.5 * G0 * tau ** 2],
                               rtol=0, atol=2e-4)
    np.testing.assert_allclose(b.vel, v_out - [0, G0 * tau], rtol=0, atol=1e-3)
    assert w.energy() == pytest.approx(E0, rel=1e-13)


GM, R_STAR, R_PROBE, R0 = 1.0, 1.0, 0.1, 3.0


def radial_fall_time(r_top, r):
    """Time to fall from rest at r_top to r < r_top toward a point mass GM (Kepler's radial
    orbit): sqrt(r_top^3 / 2GM) (sqrt(x (1 - x)) + arccos sqrt(x)), x = r / r_top."""
    x = r / r_top
    return math.sqrt(r_top ** 3 / (2 * GM)) * (math.sqrt(x * (1 - x)) + math.acos(math.sqrt(x)))


@pytest.mark.parametrize("e", [None, 0.6])
def test_a_radial_fall_onto_an_attracting_fixed_star(e):
    """Point-mass gravity: a probe dropped from rest at R0 = 3 onto the fixed star that pulls it
    (leapfrog, dt = 1e-3). Impact at the closed-form radial fall time, speed
    sqrt(2GM (1/r_c - 1/R0)) (measured 5.8e-8 and 3.1e-8 relative). Elastic: it climbs back to
    R0 (measured 6.5e-6 short) and the energy stays within leapfrog's own 2.6e-6 all along.
    e = 0.6: the next impact has speed e v* (measured 8.7e-7 relative), after the radial flight
    up to r_1 (1/r_1 = 1/r_c - (e v*)^2 / 2GM) and back (measured 3.0e-6), and the event says
    (1 - e^2) m v*^2 / 2 was lost (6.2e-8). The pull at the surface is 0.83, so the step's end
    velocity differs from the one at impact by up to 8e-4."""
    dt = 1e-3
    w = sp.World(dim=2, dt=dt, G=1.0)
    w.add_kind("probe")
    w.set_collision("probe", "star", "elastic" if e is None else "bounce", restitution=e)
    star = w.add_body(GM, (0.0, 0.0), radius=R_STAR, kind="star", fixed=True)
    probe = w.add_body(1.0, (0.0, R0), radius=R_PROBE, kind="probe", active=False)
    r_c = R_STAR + R_PROBE
    t_star = radial_fall_time(R0, r_c)
    v_star = math.sqrt(2 * GM * (1 / r_c - 1 / R0))
    E0 = w.energy()
    events, top = [], 0.0
    if e is None:
        horizon, r_top = 2 * t_star, R0
    else:
        r_top = 1 / (1 / r_c - (e * v_star) ** 2 / (2 * GM))
        t_second = t_star + 2 * radial_fall_time(r_top, r_c)
        horizon = t_second + 0.1
    for _ in range(int(horizon / dt)):
        w.step(1)
        events.extend(w.events)
        if e is None:
            assert w.energy() == pytest.approx(E0, rel=3e-5)            # 2.6e-6 measured
        if events:
            top = max(top, w.get(probe).pos[1])
    events = np.array(events, dtype=sp.EVENT_DTYPE)
    assert len(events) == (1 if e is None else 2)
    first = events[0]
    assert (first["kind"], first["a"], first["b"]) == (ev.BOUNCE, star, probe)
    assert first["time"] == pytest.approx(t_star, abs=1e-6)
    assert first["speed"] == pytest.approx(v_star, rel=1e-6)
    assert [first["x"], first["y"]] == pytest.approx([0.0, R_STAR], abs=1e-12)
    assert top == pytest.approx(r_top, abs=1e-4)                         # 6.5e-6 measured
    if e is not None:
        second = events[1]
        assert first["energy_lost"] == pytest.approx(0.5 * (1 - e * e) * v_star ** 2,
                                                     rel=1e-6)
        assert second["speed"] == pytest.approx(e * v_star, rel=1e-5)
        assert second["time"] == pytest.approx(t_second, abs=5e-5)


# ----------------------------------------------------------------------------- several contacts
# a step, no gravity: straight lines, every time and position exact to rounding. The step is
# DT = 0.5 (not 1, where a time fraction and a time are the same number): velocities are
# written as lengths per step over DT, times as fractions of the step times DT.

DT = 0.5


def free_world():
    w = sp.World(dim=2, gravity="none", dt=DT)
    w.add_kind("ball")
    return w


def idle_then(w, velocities):
    """Take one step with everything at rest (nothing happens), then set the velocities
    {id: v}: the contacts then fall in the second step, at time dt + t_in_step."""
    w.step(1)
    assert len(w.events) == 0
    for body, v in velocities.items():
        w.set_body(body, vel=v)
    return w.t


def by_time(events):
    return events[np.argsort(events["time"], kind="stable")]


def assert_event(e, kind, a, b, time, t_in_step, point, normal, speed, lost=0.0):
    """One event against its hand-computed fields, to 1e-12 (measured: 9e-15 at worst, the
    contact point on a segment)."""
    assert (int(e["kind"]), int(e["a"]), int(e["b"])) == (kind, a, b)
    assert_rel(e["time"], time, 1e-12, "time")
    assert_rel(e["t_in_step"], t_in_step, 1e-12, "t_in_step")
    assert_rel([e["x"], e["y"]], point, 1e-12, "contact point")
    assert_rel([e["nx"], e["ny"]], normal, 1e-12, "normal")
    assert_rel(e["speed"], speed, 1e-12, "speed")
    assert_rel(e["energy_lost"], lost, 1e-12, "energy lost")


def test_newtons_cradle_passes_the_velocity_down_the_chain_within_one_step():
    """A (2 per step) hits B at rest, which then hits C at rest, all in one step: equal masses
    swap their velocities, so A stops at its contact (0.15 of the step), B stops at its (0.35)
    and C leaves from there. Each event's time and point, and the end positions and
    velocities (exact swaps: bit for bit), to 1e-12."""
    w = free_world()
    w.set_collision("ball", "ball", "elastic")
    a, b, c = w.add_bodies(1.0, [[0.0, 1.0], [1.3, 1.0], [2.7, 1.0]], radius=0.5, kind="ball")
    v = 2.0 / DT
    t0 = idle_then(w, {a: (v, 0.0)})
    w.step(1)
    events = by_time(w.events)
    assert len(events) == 2
    assert_event(events[0], ev.BOUNCE, a, b, t0 + 0.15 * DT, 0.15 * DT, (0.8, 1.0), (1, 0), v)
    assert_event(events[1], ev.BOUNCE, b, c, t0 + 0.35 * DT, 0.35 * DT, (2.2, 1.0), (1, 0), v)
    assert_rel(w.pos, [[0.3, 1.0], [1.7, 1.0], [2.7 + 2 * 0.65, 1.0]], 1e-12, "positions")
    assert w.vel.tolist() == [[0.0, 0.0], [0.0, 0.0], [v, 0.0]]


def test_a_heavy_striker_hits_the_middle_ball_twice_within_one_step():
    """Masses 3, 1, 1, elastic; per step of length: A (2) hits B (0.15 of the step: A 1, B 3),
    B hits C (0.25: B 0, C 3), A catches B again (0.45: A 0.5, B 1.5). B takes three contacts
    and A two in one step; every event and the end state by hand, to 1e-12."""
    w = free_world()
    w.set_collision("ball", "ball", "elastic")
    a, b, c = w.add_bodies([3.0, 1.0, 1.0], [[0.0, 0.0], [1.3, 0.0], [2.6, 0.0]], radius=0.5,
                           kind="ball")
    t0 = idle_then(w, {a: (2.0 / DT, 0.0)})
    P0 = w.momentum()
    w.step(1)
    events = by_time(w.events)
    assert len(events) == 3
    assert_event(events[0], ev.BOUNCE, a, b, t0 + 0.15 * DT, 0.15 * DT, (0.8, 0.0), (1, 0),
                 2.0 / DT)
    assert_event(events[1], ev.BOUNCE, b, c, t0 + 0.25 * DT, 0.25 * DT, (2.1, 0.0), (1, 0),
                 3.0 / DT)
    assert_event(events[2], ev.BOUNCE, a, b, t0 + 0.45 * DT, 0.45 * DT, (1.1, 0.0), (1, 0),
                 1.0 / DT)
    assert_rel(w.pos, [[0.875, 0.0], [2.425, 0.0], [4.85, 0.0]], 1e-12, "positions")
    assert_rel(w.vel, np.array([[0.5, 0.0], [1.5, 0.0], [3.0, 0.0]]) / DT, 1e-12, "velocities")
    np.testing.assert_allclose(w.momentum(), P0, rtol=1e-15)


def bounce_between(x, v, lo, hi, e):
    """A point moving on a line between stops at lo and hi (its centre's contact positions),
    reversing with restitution e at each, over one step from fraction 0 to 1 (v in lengths
    per step): the contacts [(fraction, side +1 at hi / -1 at lo, speed per step)] and the end
    position and velocity per step."""
    t, hits = 0.0, []
    while True:
        t_hit = t + ((hi - x) / v if v > 0 else (lo - x) / v)
        if t_hit > 1.0:
            return hits, x + v * (1.0 - t), v
        x, t = (hi if v > 0 else lo), t_hit
        hits.append((t, 1 if v > 0 else -1, abs(v)))
        v = -e * v


@pytest.mark.parametrize("e", [1.0, 0.7])
@pytest.mark.parametrize("walls", ["planes", "segments", "box"])
def test_a_ball_between_two_walls_bounces_off_both_within_one_step(walls, e):
    """A ball (r = 0.5) in a channel 2 wide, moving (5, 1) per step: the right wall at 0.1 of
    the step, then the left, ... five wall contacts in one step when elastic, three with
    e = 0.7. Every event's time, contact point (on the wall, at the height the ball had
    reached), normal, speed and energy lost, and the end state, against the hand-followed
    line, to 1e-12."""
    w = free_world()
    if walls == "planes":
        w.add_plane((0.0, 0.0), (1.0, 0.0), restitution=e)
        w.add_plane((2.0, 0.0), (-1.0, 0.0), restitution=e)
    elif walls == "segments":
        w.add_segment((0.0, -10.0), (0.0, 10.0), restitution=e)
        w.add_segment((2.0, -10.0), (2.0, 10.0), restitution=e)
    else:
        w.set_boundary("reflect", lo=(0.0, -10.0), hi=(2.0, 10.0), restitution=e)
    m = 1.5
    ball = w.add_body(m, (1.0, 0.0), radius=0.5, kind="ball")
    t0 = idle_then(w, {ball: (5.0 / DT, 1.0 / DT)})
    w.step(1)
    hits, x_end, vx_end = bounce_between(1.0, 5.0, 0.5, 1.5, e)
    assert len(hits) == (5 if e == 1.0 else 3)
    events = by_time(w.events)
    assert len(events) == len(hits)
    for got, (t, side, speed) in zip(events, hits):
        assert_event(got, ev.WALL, ball, -1, t0 + t * DT, t * DT, (1.0 + side, t), (side, 0),
                     speed / DT, 0.5 * m * (1 - e * e) * (speed / DT) ** 2)
    assert_rel(w.get(ball).pos, [x_end, 1.0], 1e-12, "end position")
    assert_rel(w.get(ball).vel, [vx_end / DT, 1.0 / DT], 1e-12, "end velocity")


@pytest.mark.parametrize("e", [None, 0.7])
def test_a_ball_between_two_fixed_balls_bounces_off_both_within_one_step(e):
    """The same channel made of two fixed balls (radius 1 at x = -2 and 2): the pair path,
    one body meeting two partners several times in one step (0.1, 0.3, ... of it when
    elastic). Each event (a = the fixed ball, normal toward the moving one, the point on the
    fixed ball's surface) and the end state to 1e-12."""
    w = free_world()
    w.set_collision("ball", "ball", "elastic" if e is None else "bounce", restitution=e)
    left, right = w.add_bodies(10.0, [[-2.0, 0.5], [2.0, 0.5]], radius=1.0, kind="ball",
                               fixed=True)
    ball = w.add_body(1.0, (0.0, 0.5), radius=0.5, kind="ball")
    t0 = idle_then(w, {ball: (5.0 / DT, 0.0)})
    w.step(1)
    e_ = 1.0 if e is None else e
    hits, x_end, vx_end = bounce_between(0.0, 5.0, -0.5, 0.5, e_)
    assert len(hits) == (5 if e is None else 3)
    events = by_time(w.events)
    assert len(events) == len(hits)
    for got, (t, side, speed) in zip(events, hits):
        wall = right if side > 0 else left
        assert_event(got, ev.BOUNCE, wall, ball, t0 + t * DT, t * DT, (side * 1.0, 0.5),
                     (-side, 0), speed / DT, 0.5 * 1.0 * (1 - e_ * e_) * (speed / DT) ** 2)
    assert_rel(w.get(ball).pos, [x_end, 0.5], 1e-12, "end position")
    assert_rel(w.get(ball).vel, [vx_end / DT, 0.0], 1e-12, "end velocity")


def test_ball_wall_ball_chain_within_one_step():
    """A (4 per step) hits B at rest (0.05 of the step: A stops), B hits the wall at x = 3
    (0.375) and comes back into A (0.7: B stops, A leaves backwards): a pair contact, a wall
    contact and a pair contact again, mixed in one step. Events and end state by hand, to
    1e-12."""
    w = free_world()
    w.set_collision("ball", "ball", "elastic")
    w.add_plane((3.0, 0.0), (-1.0, 0.0))
    a, b = w.add_bodies(2.0, [[0.0, -1.0], [1.2, -1.0]], radius=0.5, kind="ball")
    v = 4.0 / DT
    t0 = idle_then(w, {a: (v, 0.0)})
    w.step(1)
    events = by_time(w.events)
    assert len(events) == 3
    assert_event(events[0], ev.BOUNCE, a, b, t0 + 0.05 * DT, 0.05 * DT, (0.7, -1.0), (1, 0), v)
    assert_event(events[1], ev.WALL, b, -1, t0 + 0.375 * DT, 0.375 * DT, (3.0, -1.0), (1, 0), v)
    assert_event(events[2], ev.BOUNCE, a, b, t0 + 0.7 * DT, 0.7 * DT, (0.7, -1.0), (1, 0), v)
    assert_rel(w.pos, [[-1.0, -1.0], [1.2, -1.0]], 1e-12, "positions")
    assert_rel(w.vel, [[-v, 0.0], [0.0, 0.0]], 1e-12, "velocities")
