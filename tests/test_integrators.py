"""Every integrator of the registry: its table, its order, its energy behaviour, its invariants."""
import numpy as np
import pytest

import spacephys as sp
from spacephys.scenes import kepler, uniform_sphere

ALL = list(sp.INTEGRATORS)
SYMPLECTIC = [n for n, s in sp.INTEGRATORS.items() if s.symplectic]
NOT_SYMPLECTIC = [n for n, s in sp.INTEGRATORS.items() if not s.symplectic]


def test_registry_lists_the_ladder():
    expected = {"euler": 1, "symplectic_euler": 1, "leapfrog": 2, "rk4": 4, "yoshida4": 4,
                "yoshida6": 6, "yoshida8": 8}
    assert {n: s.order for n, s in sp.INTEGRATORS.items()} == expected
    assert SYMPLECTIC == ["symplectic_euler", "leapfrog", "yoshida4", "yoshida6", "yoshida8"]
    assert not any(s.adaptive for s in sp.INTEGRATORS.values())


def test_unknown_name_lists_the_valid_ones():
    with pytest.raises(ValueError, match="integrator='verlet' is not known; valid: euler, "
                                         "symplectic_euler, leapfrog, rk4, yoshida4"):
        sp.get_integrator("verlet")


@pytest.mark.parametrize("name", ALL)
def test_tables_are_consistent(name):
    spec = sp.INTEGRATORS[name]
    if spec.family == "splitting":
        # one step drifts and kicks by exactly dt in total
        assert spec.drift.sum() == pytest.approx(1.0, abs=1e-14)
        assert spec.kick.sum() == pytest.approx(1.0, abs=1e-14)
        assert spec.drift.shape == spec.kick.shape
        assert spec.evaluations == np.count_nonzero(spec.kick)
        if name != "symplectic_euler":       # the others are time-symmetric compositions
            assert np.allclose(spec.drift, spec.drift[::-1], atol=1e-15)
            assert np.allclose(spec.kick[:-1], spec.kick[:-1][::-1], atol=1e-15)
    else:
        assert spec.b.sum() == pytest.approx(1.0, abs=1e-15)
        assert np.all(np.triu(spec.a) == 0)   # explicit
    table = spec.drift if spec.family == "splitting" else spec.b
    assert not table.flags.writeable       # a registry entry cannot be edited by accident


# Steps per 2 time units chosen so the error sits between round-off and the pre-asymptotic
# regime (measured: slopes within 0.05 of the order there); five points spanning a factor 4.
_N0 = {1: 1280, 2: 160, 4: 160, 6: 20, 8: 20}


def _phase_error(name, nsteps, t_end=2.0, e=0.5):
    w = kepler(e, integrator=name, dt=t_end / nsteps)
    w.step(nsteps)
    r, v = sp.kepler_state(1.0, 1.0, e, w.t)
    return np.linalg.norm(w.pos[1] - r[:2]) + np.linalg.norm(w.vel[1] - v[:2])


@pytest.mark.parametrize("name", ALL)
def test_convergence_order_on_kepler_orbit(name):
    spec = sp.INTEGRATORS[name]
    steps = np.round(_N0[spec.order] * 2.0 ** (np.arange(5) / 2)).astype(int)
    errors = [_phase_error(name, int(n)) for n in steps]
    slope = -np.polyfit(np.log(steps), np.log(errors), 1)[0]
    assert abs(slope - spec.order) <= 0.3, (name, slope, errors)


def _energy_windows(name, steps_per_orbit, total=100_000, every=7):
    """Max |dE/E| over the first and the last tenth of `total` steps (sampled off-period)."""
    w = kepler(0.5, planet_mass=1e-3, integrator=name, dt=2 * np.pi / steps_per_orbit)
    E0 = w.energy()
    errs = np.empty(total // every)
    for k in range(errs.size):
        w.step(every)
        errs[k] = abs(w.energy() / E0 - 1)
    tenth = errs.size // 10
    return errs[:tenth].max(), errs[-tenth:].max()


@pytest.mark.parametrize("name", SYMPLECTIC)
def test_symplectic_energy_error_stays_bounded(name):
    # 1e5 steps = 1000 orbits at 100 steps per orbit: the error oscillates, it does not grow
    first, last = _energy_windows(name, 100)
    assert last <= 1.05 * first, (first, last)
    assert last < 0.2


@pytest.mark.parametrize("name,steps_per_orbit", [("euler", 10_000), ("rk4", 100)])
def test_non_symplectic_energy_error_drifts(name, steps_per_orbit):
    assert name in NOT_SYMPLECTIC
    first, last = _energy_windows(name, steps_per_orbit)
    assert last > 3 * first, (first, last)


def _cluster(name, n=60):
    """n unequal masses with random velocities, centre of mass at rest at the origin."""
    rng = np.random.default_rng(4)
    w = sp.World(dim=3, softening=0.05, integrator=name, dt=1e-3)
    w.add_bodies(rng.uniform(0.5, 2.0, n) / n, rng.normal(size=(n, 3)),
                 rng.normal(scale=0.3, size=(n, 3)))
    w.move_to_center_of_mass()
    return w


@pytest.mark.parametrize("name", ALL)
def test_momentum_conserved_to_round_off(name):
    w = _cluster(name)
    scale = np.sum(w.mass * np.linalg.norm(w.vel, axis=1))
    P0 = w.momentum()
    w.step(300)
    assert np.linalg.norm(w.momentum() - P0) <= 1e-14 * scale


@pytest.mark.parametrize("name", ALL)
def test_translation_and_boost_invariance(name):
    a = _cluster(name)
    b = sp.World(dim=3, softening=0.05, integrator=name, dt=1e-3)
    shift, boost = np.array([123.0, -45.0, 6.0]), np.array([0.5, -0.25, 2.0])
    b.add_bodies(a.mass, a.pos + shift, a.vel + boost)
    a.step(200)
    b.step(200)
    moved = shift + boost * b.t
    assert np.max(np.abs(b.pos - moved - a.pos)) < 1e-10
    assert np.max(np.abs(b.vel - boost - a.vel)) < 1e-10


@pytest.mark.parametrize("name", ALL)
def test_identical_runs_are_bitwise_identical(name):
    # 300 bodies: the force loop runs on threads
    runs = [uniform_sphere(300, seed=7, integrator=name, dt=1e-3) for _ in range(2)]
    for w in runs:
        w.step(20)
    assert np.array_equal(runs[0].pos, runs[1].pos)
    assert np.array_equal(runs[0].vel, runs[1].vel)


@pytest.mark.parametrize("name", ALL)
def test_test_particles_do_not_move_massive_bodies(name):
    alone = uniform_sphere(200, seed=5, integrator=name, dt=1e-3)
    crowd = alone.copy()
    rng = np.random.default_rng(6)
    crowd.add_bodies(0.0, rng.normal(size=(3000, 3)), rng.normal(size=(3000, 3)))
    # passive bodies with real inertial mass (ships) feel gravity but do not pull either
    crowd.add_bodies(5.0, rng.normal(size=(50, 3)), kind="ship", active=False)
    alone.step(50)
    crowd.step(50)
    assert np.array_equal(crowd.pos[:200], alone.pos)
    assert np.array_equal(crowd.vel[:200], alone.vel)
    ships = crowd.vel[-50:]                  # they started at rest and fell toward the cluster
    assert np.all(np.linalg.norm(ships, axis=1) > 0)
