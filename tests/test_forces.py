"""The force contract's additions: held per-body forces and accelerations, user forces
(numba functions called inside the kernels), the J2 example against REBOUND's IAS15 with the
same force as a Python additional_forces callback."""
import numba
import numpy as np
import pytest
import rebound

import spacephys as sp
from spacephys.study import rebound as peer
from spacephys.userforces import j2

ALL = list(sp.INTEGRATORS)


# ----------------------------------------------------------------------------- held forces

@pytest.mark.parametrize("name", ALL)
def test_a_held_acceleration_moves_a_free_body_along_the_parabola(name):
    """No gravity acting: x = x0 + v0 t + a t^2 / 2, exact for every method of order >= 2
    (the parabola is in each one's exact space), within a dt^1 error for the first-order
    ones; a held force gives force / mass."""
    T, n = 1.0, 64
    w = sp.World(dim=3, integrator=name, dt=T / n)
    a = w.add_body(0.0, (1.0, 2.0, 3.0), (0.5, -1.0, 0.25))
    b = w.add_body(2.0, (0.0, 0.0, 0.0), (1.0, 0.0, 0.0), active=False)
    w.apply_acceleration(a, (0.3, -0.2, 0.1))
    w.apply_force(b, (0.0, 1.0, -0.5))                # a = F / m = (0, 0.5, -0.25)
    w.step(n)
    want_a = np.array([1.0, 2.0, 3.0]) + np.array([0.5, -1.0, 0.25]) * T + \
        0.5 * np.array([0.3, -0.2, 0.1]) * T * T
    want_b = np.array([1.0, 0.0, 0.0]) * T + 0.5 * np.array([0.0, 0.5, -0.25]) * T * T
    order = sp.INTEGRATORS[name].order
    tol = 1e-13 if order >= 2 else 0.5 * 0.5 * (T / n) * T * 1.01   # |a| dt T / 2
    assert np.abs(w.get(a).pos - want_a).max() <= tol
    assert np.abs(w.get(b).pos - want_b).max() <= tol
    np.testing.assert_allclose(w.get(b).vel, [1.0, 0.5, -0.25], rtol=0, atol=1e-13)


@pytest.mark.parametrize("name", ["wisdom_holman", "gauss_radau", "leapfrog"])
def test_a_held_acceleration_on_a_binary_moves_its_centre_of_mass(name):
    """The same acceleration on both bodies of an orbiting pair: their centre of mass
    follows the parabola, their relative orbit is that of the pair alone (Wisdom-Holman's
    centre of mass included: its acceleration is the mass-weighted mean, not zero)."""
    def pair(push):
        w = sp.World(dim=2, integrator=name, dt=2 * np.pi / 200)
        star = w.add_body(1.0, (0.0, 0.0))
        planet = w.add_body(1e-3, (1.0, 0.0), (0.0, 1.0))
        if push:
            for body in (star, planet):
                w.apply_acceleration(body, (0.05, -0.02))
        w.step(200)
        return w
    pushed, alone = pair(True), pair(False)
    T = 2 * np.pi
    com = pushed.center_of_mass() - alone.center_of_mass()
    np.testing.assert_allclose(com, 0.5 * np.array([0.05, -0.02]) * T * T, rtol=1e-10)
    rel = lambda w: w.pos[1] - w.pos[0]
    np.testing.assert_allclose(rel(pushed), rel(alone), rtol=0, atol=1e-9)


def test_held_forces_are_held_changed_and_journaled(tmp_path):
    w = sp.World(dim=2, gravity="none", dt=0.1)
    body = w.add_body(1.0, (0.0, 0.0))
    log = w.record(tmp_path / "held.h5")
    w.apply_force(body, (1.0, 0.0))
    w.step(10)
    assert w.get(body).vel[0] == pytest.approx(1.0, rel=1e-14)
    w.apply_force(body, (0.0, 0.0))                     # released
    w.step(10)
    assert w.get(body).vel[0] == pytest.approx(1.0, rel=1e-14)
    assert np.array_equal(w.applied(body)[0], [0.0, 0.0])
    log.close()
    assert sp.replay(tmp_path / "held.h5").ok
    calls = [entry["call"] for entry in sp.open_run(tmp_path / "held.h5").inputs()]
    assert calls.count("apply_force") == 2


@pytest.mark.parametrize("call,message", [
    (lambda w, b, s, f: w.apply_force(b, (1.0, float("nan"))), r"force\[1\] = nan"),
    (lambda w, b, s, f: w.apply_force(b, (1.0, 2.0, 3.0)), r"force has shape \(3,\)"),
    (lambda w, b, s, f: w.apply_force(s, (1.0, 0.0)), "mass 0"),
    (lambda w, b, s, f: w.apply_force(f, (1.0, 0.0)), "fixed"),
    (lambda w, b, s, f: w.apply_acceleration(f, (1.0, 0.0)), "fixed"),
    (lambda w, b, s, f: w.apply_acceleration(12345, (1.0, 0.0)), "body = 12345 names no"),
    (lambda w, b, s, f: w.apply_acceleration(b, "up"), "acceleration = 'up'"),
])
def test_bad_held_forces_are_refused_and_change_nothing(call, message):
    w = sp.World(dim=2, dt=0.1)
    body = w.add_body(1.0, (0.0, 0.0))
    speck = w.add_body(0.0, (1.0, 0.0))
    post = w.add_body(1.0, (2.0, 0.0), fixed=True)
    w.apply_acceleration(body, (0.5, 0.5))
    before = w.state()["bodies"]["columns"]
    with pytest.raises(ValueError, match=message):
        call(w, body, speck, post)
    after = w.state()["bodies"]["columns"]
    assert all(np.array_equal(before[k], after[k]) for k in before)


# ----------------------------------------------------------------------------- user forces

@numba.njit(cache=True)
def stark(t, pos, vel, mass, ids, params, out):
    """A constant acceleration params[:3] on every body: the Stark problem's force."""
    for i in range(pos.shape[0]):
        out[i, 0] += params[0]
        out[i, 1] += params[1]
        out[i, 2] += params[2]


@numba.njit(cache=True)
def linear_drag(t, pos, vel, mass, ids, params, out):
    """-k v: World's own drag, as a user force (velocity-dependent)."""
    for i in range(pos.shape[0]):
        for c in range(3):
            out[i, c] -= params[0] * vel[i, c]


@pytest.mark.parametrize("name", ALL)
def test_a_user_force_acts_like_the_held_acceleration_it_equals(name):
    """stark(a) and apply_acceleration(a) on every body give the same motion, for every
    integrator, to round-off."""
    def run(user):
        w = sp.World(dim=3, integrator=name, dt=0.05)
        w.add_body(1.0, (0.0, 0.0, 0.0))
        ids = w.add_bodies(0.0, [[1.0, 0.0, 0.0], [0.0, 1.5, 0.2]],
                           [[0.0, 1.0, 0.0], [-0.8, 0.0, 0.1]])
        if user:
            w.add_force(stark, [0.01, -0.02, 0.005])
        else:
            for body in [w.ids[0], *ids]:
                w.apply_acceleration(int(body), (0.01, -0.02, 0.005))
        w.step(40)
        return w.pos
    np.testing.assert_allclose(run(True), run(False), rtol=0, atol=1e-13)


def _user_and_own_drag(name, n, T=3.0):
    """(pos with -k v as a user force, pos with World's drag) after T."""
    out = []
    for user in (True, False):
        w = sp.World(dim=2, integrator=name, dt=T / n, drag=0.0 if user else 0.4)
        w.add_body(1.0, (0.0, 0.0))
        w.add_body(0.0, (1.0, 0.0), (0.0, 1.2))
        if user:
            w.add_force(linear_drag, [0.4])
        w.step(n)
        out.append(w.pos)
    return out


@pytest.mark.parametrize("name", ["gauss_radau", "rk4"])
def test_a_velocity_dependent_user_force_sees_the_stage_velocities(name):
    """-k v as a user force matches World's drag toward a still wind to round-off for
    Gauss-Radau and RK4, which both evaluate it at their stages' velocities."""
    user, own = _user_and_own_drag(name, 300)
    assert np.abs(user - own).max() < 1e-10


def test_a_splitting_kicks_with_the_velocity_it_has():
    """A splitting's kick uses the velocity at the kick: a velocity-dependent user force is
    first order there (documented; World's own drag is exact in every kick)."""
    errors = [np.abs(np.subtract(*_user_and_own_drag("yoshida4", n))).max()
              for n in (300, 600)]
    assert errors[0] / errors[1] == pytest.approx(2.0, rel=0.1)


def _moons(j2_on, integrator="gauss_radau", **kw):
    """A planet (mass 1, radius 0.1, J2 = 0.05) and three moons on inclined orbits, one of
    them massive, 3D, G = 1, 20 time units (about nine orbits of the innermost)."""
    w = sp.World(dim=3, integrator=integrator, dt=20.0, **kw)
    planet = w.add_body(1.0, (0.0, 0.0, 0.0), kind="planet")
    w.add_body(1e-4, (0.5, 0.0, 0.0), (0.0, 1.2, 0.6), kind="moon")
    w.add_bodies(0.0, [[0.0, 0.7, 0.1], [-0.9, 0.0, -0.2]],
                 [[-1.0, 0.1, 0.5], [0.05, -0.9, 0.4]], kind="asteroid")
    if j2_on:
        w.add_force(j2, [planet, 0.05 * 1.0 * 0.1 ** 2])
    return w


def test_j2_matches_rebound_ias15_with_the_same_force_as_a_callback():
    w = _moons(True)
    sim = peer.add_j2(peer.simulation(w, "ias15"), 0.05 * 0.1 ** 2)
    assert rebound.__version__.startswith("5.2")
    P0 = w.momentum()
    w.step(1)
    sim.integrate(20.0)
    ours, theirs = w.pos, peer.positions(sim)
    without = _moons(False)
    without.step(1)
    effect = np.abs(without.pos - ours).max()
    agreement = np.abs(ours - theirs).max()
    assert effect > 1e-2                       # J2 moved the moons visibly
    assert agreement < 1e-10, agreement        # and both codes moved them the same way
    # the planet takes the moon's reaction: momentum is conserved
    assert np.abs(w.momentum() - P0).max() < 1e-15


def test_j2_precesses_the_node_at_the_textbook_rate():
    """A low-eccentricity orbit inclined 30 degrees: its node regresses at
    -3/2 n J2 (R/a)^2 cos i (Vallado, Fundamentals of Astrodynamics, 4th ed., eq. 9-41)."""
    J2, R, a, inc = 1e-3, 0.1, 0.5, np.radians(30.0)
    n = np.sqrt(1.0 / a ** 3)
    w = sp.World(dim=3, integrator="gauss_radau", dt=50.0)
    planet = w.add_body(1.0, (0.0, 0.0, 0.0))
    moon = w.add_body(0.0, (a, 0.0, 0.0), (0.0, n * a * np.cos(inc), n * a * np.sin(inc)))
    w.add_force(j2, [planet, J2 * R ** 2])
    w.step(1)
    r, v = w.get(moon).pos, w.get(moon).vel
    h = np.cross(r, v)
    node = np.arctan2(h[0], -h[1])                     # the ascending node's longitude
    expected = -1.5 * n * J2 * (R / a) ** 2 * np.cos(inc) * 50.0
    assert node == pytest.approx(expected, rel=0.02)


def _plain(t, pos, vel, mass, ids, params, out):
    pass


@numba.njit(cache=True)
def _two_args(pos, out):
    pass


@numba.njit(cache=True)
def _returns(t, pos, vel, mass, ids, params, out):
    return 1.0


@pytest.mark.parametrize("fn,params,message", [
    (_plain, (), "must be a numba function"),
    (_two_args, (), "does not compile as a user force"),
    (_returns, (), "returns float64"),
    (stark, (1.0, float("nan"), 0.0), r"params\[1\] = nan"),
    (stark, [[1.0]], r"params has shape \(1, 1\)"),
])
def test_bad_user_forces_are_refused_and_change_nothing(fn, params, message):
    w = sp.World(dim=2, dt=0.1)
    w.add_body(1.0, (0.0, 0.0))
    w.add_force(stark, [0.0, 1.0, 0.0])
    with pytest.raises(ValueError, match=message):
        w.add_force(fn, params)
    assert len(w.forces) == 1
    with pytest.raises(ValueError, match="k = 3"):
        w.set_force_params(3, [1.0])
    with pytest.raises(ValueError, match="k = 1"):
        w.remove_force(1)
    w.step(1)
    assert w.vel[0, 1] == pytest.approx(0.1)


def test_user_forces_save_load_and_replay(tmp_path):
    w = _moons(True, integrator="leapfrog")
    w.dt = 0.01
    w.step(10)
    w.save(tmp_path / "moons.h5")
    back = sp.World.load(tmp_path / "moons.h5")
    assert back.forces[0][0] is j2
    w.step(50)
    back.step(50)
    assert np.array_equal(w.pos, back.pos)
    log = back.record(tmp_path / "run.h5")
    back.set_force_params(0, [back.ids[0], 0.0])
    back.step(20)
    log.close()
    assert sp.replay(tmp_path / "run.h5").ok
