"""Tethers (issue 43, item 6, the spring tethers): World.tether joins two bodies with a
spring, a rope (slack below its length) or a rod; every integrator integrates it at its own
order; its energy is in potential_energy; it breaks past its break force with a tether_break
event; it is in snapshots, state files and replays; bad input is named and changes nothing."""
import math

import numpy as np
import pytest

import spacephys as sp

K, M1, M2 = 30.0, 1.0, 3.0
OMEGA = math.sqrt(K * (M1 + M2) / (M1 * M2))          # of the stretch, about the reduced mass


def _rod(integrator, dt=0.001, dim=2):
    """Two bodies on a rod of length 1 stretched to 1.1, falling in a uniform field (which
    leaves their separation alone but keeps accelerations from all vanishing together:
    Gauss-Radau's error control measures against them)."""
    z = (0.0,) * (dim - 2)
    w = sp.World(dim, gravity="uniform", g=(0.0, -1.0) + z, integrator=integrator, dt=dt)
    a = w.add_body(M1, (0.0, 0.0) + z)
    b = w.add_body(M2, (1.1, 0.0) + z)
    w.tether(a, b, 1.0, stiffness=K, rigid=True)
    return w


@pytest.mark.parametrize("integrator, tolerance", [
    ("leapfrog", 5e-7), ("rk4", 5e-12), ("yoshida4", 5e-11), ("yoshida6", 1e-14),
    ("gauss_radau", 1e-14)])
def test_a_rod_oscillates_as_its_spring_does_under_every_integrator(integrator, tolerance):
    """The stretch is 0.1 cos(omega t) (a harmonic oscillator of the reduced mass), to each
    method's order at dt = 0.001 over 2 time units (leapfrog's error 1.7e-7, rk4's 1.3e-12)."""
    w = _rod(integrator)
    w.step(2000)
    r = w.pos[1, 0] - w.pos[0, 0]
    assert abs(r - (1.0 + 0.1 * math.cos(OMEGA * w.t))) < tolerance
    assert abs(w.momentum()[0]) < 1e-14                   # equal and opposite


def test_a_rope_is_slack_below_its_length():
    w = sp.World(2, gravity="none", dt=0.01)
    a = w.add_body(1.0, (0.0, 0.0), (-0.5, 0.0))
    b = w.add_body(1.0, (0.5, 0.0), (0.5, 0.0))
    w.tether(a, b, 2.0, stiffness=100.0)
    w.step(140)                                          # r = 0.5 + t: slack until t = 1.5
    assert list(w.vel[:, 0]) == [-0.5, 0.5] and w.potential_energy() == 0.0
    w.step(30)                                            # taut from t = 1.5: pulled back
    assert w.vel[0, 0] > -0.5 and w.vel[1, 0] < 0.5
    assert w.potential_energy() > 0.0


@pytest.mark.parametrize("rigid, bound", [(True, 3e-7), (False, 1.5e-2)])
def test_a_pendulums_energy_stays_bounded(rigid, bound):
    """A bob dropped from the horizontal on a stiff tether (k = 2000, m = 1, L = 1) swings
    for 100 time units under leapfrog at dt = 0.002: the rod keeps the energy to 1.9e-7 of
    m g L; the rope, whose force has a kink where it goes slack, to 7.8e-3 (docs)."""
    w = sp.World(2, gravity="uniform", g=(0.0, -9.81), dt=0.002)
    anchor = w.add_body(1.0, (0.0, 0.0), fixed=True)
    bob = w.add_body(1.0, (1.0, 0.0))
    w.tether(anchor, bob, 1.0, stiffness=2000.0, rigid=rigid)
    E0, worst = w.energy(), 0.0
    for _ in range(40):
        w.step(1250)
        worst = max(worst, abs(w.energy() - E0) / 9.81)
    assert worst < bound
    assert w.pos[1, 1] < 0.0 or worst > 0.0               # it swung
    assert np.linalg.norm(w.pos[1]) < 1.05                 # held on the rope


def test_a_tether_breaks_past_its_break_force():
    """Two bodies pulled apart: the rope breaks at the step whose tension passes 50, the
    event carries the spring's energy, and the bodies fly on freely."""
    w = sp.World(2, gravity="none", dt=0.001)
    a = w.add_body(1.0, (0.0, 0.0), (-2.0, 0.0))
    b = w.add_body(1.0, (1.0, 0.0), (2.0, 0.0))          # enough energy to stretch it 0.089
    k = w.tether(a, b, 1.0, stiffness=1000.0, break_force=50.0)
    w.step(200)
    breaks = w.events[w.events["kind"] == sp.events.TETHER_BREAK]
    assert len(breaks) == 1 and len(w.tethers) == 0
    e = breaks[0]
    assert (e["a"], e["b"]) == (a, b) and sp.EVENT_KINDS[e["kind"]] == "tether_break"
    stretch = e["distance"] - 1.0
    assert 50.0 < 1000.0 * stretch < 50.0 + 1000.0 * 4.0 * 0.001     # passed within a step
    assert e["energy_lost"] == pytest.approx(0.5 * 1000.0 * stretch ** 2, rel=1e-12)
    v = w.vel.copy()
    w.step(10)
    np.testing.assert_array_equal(w.vel, v)               # free: nothing pulls any more
    with pytest.raises(ValueError, match=f"tether = {k}: no such tether"):
        w.untether(k)


def test_removing_an_end_removes_the_tether_and_untether_removes_one():
    w = sp.World(2, gravity="none", dt=0.01)
    ids = w.add_bodies(1.0, [(0.0, 0.0), (1.0, 0.0), (2.0, 0.0)])
    first = w.tether(int(ids[0]), int(ids[1]), stiffness=1.0)
    second = w.tether(int(ids[1]), int(ids[2]), stiffness=1.0)
    assert list(w.tethers["id"]) == [first, second] and list(w.tethers["length"]) == [1.0, 1.0]
    w.remove(int(ids[0]))
    w.step(1)
    assert list(w.tethers["id"]) == [second]
    w.untether(second)
    assert len(w.tethers) == 0


@pytest.mark.parametrize("dim", [2, 3])
def test_tethers_survive_snapshots_state_files_replay_and_predictions(dim, tmp_path):
    w = sp.World(dim, dt=0.01)
    log = w.record(tmp_path / "run.h5")
    planet = w.add_body(100.0, (0.0,) * dim)
    ship = w.add_body(1.0, (10.0, 0.0, 0.0)[:dim], (0.0, math.sqrt(10.0), 0.0)[:dim],
                      active=False)
    pod = w.add_body(0.5, (11.0, 0.0, 0.0)[:dim], (0.0, math.sqrt(10.0), 0.5)[:dim],
                     active=False)
    w.tether(ship, pod, 1.0, stiffness=20.0, break_force=1e3)
    w.step(30)
    path = w.predict(pod, 0.5, points=51).path(pod)[0]
    loaded = sp.World.from_state(w.state())
    w.step(50)
    loaded.step(50)
    assert loaded.digest() == w.digest()
    np.testing.assert_array_equal(path[-1], w.pos[w.index_of(pod)])   # flown as predicted
    log.close()
    assert sp.replay(tmp_path / "run.h5").ok
    fresh = sp.World.from_state(loaded.state())
    saved = fresh.snapshot()
    fresh.step(20)
    after = fresh.digest()
    fresh.restore(saved)
    fresh.step(20)
    assert fresh.digest() == after and len(fresh.tethers) == 1
    # the spring's energy is in the potential energy
    loose = fresh.copy()
    loose.untether(int(fresh.tethers["id"][0]))
    r = np.linalg.norm(fresh.pos[fresh.index_of(pod)] - fresh.pos[fresh.index_of(ship)])
    spring = 0.5 * 20.0 * max(r - 1.0, 0.0) ** 2
    assert spring > 0.0 and planet in fresh
    assert fresh.potential_energy() - loose.potential_energy() == pytest.approx(spring,
                                                                                rel=1e-9)


@pytest.mark.parametrize("call, message", [
    (lambda w, a, b, c: w.tether(a, a, stiffness=1.0), "a = b"),
    (lambda w, a, b, c: w.tether(a, 99, stiffness=1.0), "b = 99"),
    (lambda w, a, b, c: w.tether(a, b, stiffness=-1.0), "stiffness"),
    (lambda w, a, b, c: w.tether(a, b, -1.0, stiffness=1.0), "length"),
    (lambda w, a, b, c: w.tether(a, b, stiffness=float("nan")), "stiffness"),
    (lambda w, a, b, c: w.tether(a, b, stiffness=1.0, rigid=1), "rigid = 1"),
    (lambda w, a, b, c: w.tether(a, b, stiffness=1.0, break_force=0.0), "break_force"),
    (lambda w, a, b, c: w.tether(a, c, stiffness=1.0), "has mass 0"),
    (lambda w, a, b, c: w.untether(3), "tether = 3: no such tether"),
])
def test_bad_tethers_are_named_and_nothing_changes(call, message):
    w = sp.World(2, gravity="none")
    a, b = w.add_body(1.0, (0.0, 0.0)), w.add_body(1.0, (1.0, 0.0))
    c = w.add_body(0.0, (2.0, 0.0))
    w.tether(a, b, stiffness=2.0)
    before = w.digest()
    with pytest.raises(ValueError, match=message):
        call(w, a, b, c)
    assert w.digest() == before and len(w.tethers) == 1


def test_a_tether_to_a_removed_body_is_refused_at_either_end():
    w = sp.World(3, gravity="none")
    a = w.add_body(1.0, (0.0, 0.0, 0.0))
    gone = w.add_body(1.0, (1.0, 0.0, 0.0))
    w.remove(gone)
    before = w.digest()
    with pytest.raises(ValueError, match=f"b = {gone} names no live body"):
        w.tether(a, gone, stiffness=1.0)
    with pytest.raises(ValueError, match=f"a = {gone} names no live body"):
        w.tether(gone, a, rigid=True)
    assert w.digest() == before and len(w.tethers) == 0


# ----------------------------------------------------------------------------- inextensible

def _pendulum(integrator, rigid=False, dt=0.002, break_force=None):
    """A bob of mass 1 dropped from the horizontal on an inextensible tether of length 1."""
    w = sp.World(2, gravity="uniform", g=(0.0, -9.81), integrator=integrator, dt=dt)
    anchor = w.add_body(1.0, (0.0, 0.0), fixed=True)
    bob = w.add_body(1.0, (1.0, 0.0))
    w.tether(anchor, bob, rigid=rigid, break_force=break_force)
    return w, bob


@pytest.mark.parametrize("integrator, bound", [
    ("leapfrog", 2e-5), ("yoshida4", 4e-4), ("rk4", 1e-9), ("gauss_radau", 1e-14)])
def test_an_inextensible_pendulum_holds_its_length_and_energy(integrator, bound):
    """100 time units (about 30 swings) at dt = 0.002: the length exact after every step
    (the projection), the energy to the method's order (measured: leapfrog 9.7e-6 of m g L,
    yoshida4 2.0e-4: a splitting kicks with the velocity it has, and the constraint's force
    reads it; RK4 5.3e-10, Gauss-Radau 9e-16)."""
    w, bob = _pendulum(integrator)
    E0, worst = w.energy(), 0.0
    for _ in range(40):
        w.step(1250)
        assert abs(np.linalg.norm(w.pos[1]) - 1.0) < 1e-15
        worst = max(worst, abs(w.energy() - E0) / 9.81)
    assert worst < bound
    assert w.tethers["stiffness"][0] == np.inf


def test_a_rope_snapping_taut_jerks_and_a_slack_one_lets_go():
    """A body thrown outward from the anchor flies free until the rope is taut, then loses
    its radial speed (inelastic) and keeps its tangential one."""
    w = sp.World(2, gravity="none", dt=0.01)
    anchor = w.add_body(1.0, (0.0, 0.0), fixed=True)
    ball = w.add_body(1.0, (0.5, 0.0), (1.0, 0.1))
    w.tether(anchor, ball, 1.0)
    w.step(30)                                            # r < 1 until t ~ 0.5
    np.testing.assert_array_equal(w.vel[1], [1.0, 0.1])
    w.step(40)
    r = w.pos[1] / np.linalg.norm(w.pos[1])
    assert np.linalg.norm(w.pos[1]) == pytest.approx(1.0, abs=1e-15)
    assert abs(np.dot(w.vel[1], r)) < 1e-12               # no radial speed left
    assert np.linalg.norm(w.vel[1]) < 0.5                 # the radial part went in the jerk


def test_a_double_pendulum_chain_holds_both_links():
    """Two inextensible rods in a chain (solved together): both lengths exact, energy to
    Gauss-Radau's precision over 10 time units of chaotic swinging."""
    w = sp.World(2, gravity="uniform", g=(0.0, -9.81), integrator="gauss_radau", dt=0.01)
    anchor = w.add_body(1.0, (0.0, 0.0), fixed=True)
    a = w.add_body(1.0, (1.0, 0.0))
    b = w.add_body(1.0, (2.0, 0.0))
    w.tether(anchor, a, rigid=True)
    w.tether(a, b, rigid=True)
    E0 = w.energy()
    for _ in range(10):
        w.step(100)
        assert abs(np.linalg.norm(w.pos[1]) - 1.0) < 1e-14
        assert abs(np.linalg.norm(w.pos[2] - w.pos[1]) - 1.0) < 1e-14
    assert abs(w.energy() - E0) / 9.81 < 1e-9
    assert w.pos[2, 1] < -0.5                             # it swung


def test_an_inextensible_rope_breaks_where_its_tension_passes():
    """Dropped from the horizontal, the rope's tension is 3 m g sin(theta) at theta below
    the horizontal: a break force of 2 m g parts it at sin(theta) = 2/3."""
    w, bob = _pendulum("rk4", dt=0.0005, break_force=2 * 9.81)
    w.step(1000)
    e = w.events[w.events["kind"] == sp.events.TETHER_BREAK]
    assert len(e) == 1 and len(w.tethers) == 0
    angle = math.asin(-2.0 * e[0]["y"])                   # the midpoint: half the bob's
    assert angle == pytest.approx(math.asin(2 / 3), abs=2e-3)


def test_wisdom_holman_refuses_an_inextensible_tether():
    w = sp.World(2, integrator="wisdom_holman", dt=0.01)
    sun = w.add_body(1.0, (0.0, 0.0))
    planet = w.add_body(1e-3, (1.0, 0.0), (0.0, 1.0))
    before = w.digest()
    with pytest.raises(ValueError, match="stiffness = None with integrator 'wisdom_holman'"):
        w.tether(sun, planet)
    assert w.digest() == before
    w.tether(sun, planet, stiffness=1e-3)                 # a spring it takes
    w.integrator = "leapfrog"
    k = w.tether(sun, planet, rigid=True)
    w.integrator = "wisdom_holman"
    before = w.digest()
    with pytest.raises(ValueError, match="inextensible tether"):
        w.step(1)
    assert w.digest() == before and w.t == 0.0
    w.untether(k)
    w.step(1)


def test_the_guides_example_runs_as_written(capsys):
    """docs/guide/gravity.md's tether example: the rope parts, as it says."""
    import pathlib
    text = (pathlib.Path(__file__).parents[1] / "docs/guide/gravity.md").read_text()
    code = text.split("## Tethers")[1].split("```python\n")[1].split("```")[0]
    exec(compile(code, "gravity.md", "exec"), {})
    printed = capsys.readouterr().out
    assert printed.count("(14,") == 1                     # one tether_break event
