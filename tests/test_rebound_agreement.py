"""Same initial conditions, same method: spacephys and REBOUND (the real package) agree."""
import numpy as np
import pytest
import rebound

import spacephys as sp
from spacephys.study import rebound as peer
from spacephys.scenes import figure_eight, uniform_sphere


def _state(sim):
    xyz, v = np.empty((sim.N, 3)), np.empty((sim.N, 3))
    sim.serialize_particle_data(xyz=xyz, vxvyvz=v)
    return xyz, v


def test_rebound_is_the_pinned_version():
    assert rebound.__version__.startswith("5.2.")


@pytest.mark.parametrize("n,steps", [(64, 200), (300, 50)])
def test_leapfrog_matches_rebound_leapfrog(n, steps):
    # REBOUND's leapfrog is drift-kick-drift with Plummer softening, as ours
    w = uniform_sphere(n, seed=11, dt=1e-3, softening=0.05)
    sim = peer.simulation(w, "leapfrog", gravity="basic")
    w.step(steps)
    sim.steps(steps)
    pos, vel = _state(sim)
    assert np.max(np.abs(w.pos - pos)) < 1e-12
    assert np.max(np.abs(w.vel - vel)) < 1e-11 * np.max(np.abs(vel))


def test_test_particles_match_rebound_active_split():
    w = uniform_sphere(50, seed=12, dt=1e-3, softening=0.05)
    rng = np.random.default_rng(13)
    w.add_bodies(0.0, rng.normal(size=(200, 3)), rng.normal(scale=0.2, size=(200, 3)))
    sim = peer.simulation(w, "leapfrog", gravity="basic", n_active=50)
    w.step(100)
    sim.steps(100)
    pos, _ = _state(sim)
    assert np.max(np.abs(w.pos - pos)) < 1e-12


@pytest.mark.parametrize("name", [n for n, s in sp.INTEGRATORS.items()
                                  if s.family != "wisdom_holman"])
def test_figure_eight_period_against_rebound_ias15(name):
    # one period of the figure-eight; REBOUND's IAS15 is the reference trajectory
    T = 6.32591398
    sim = peer.simulation(figure_eight(), "ias15", dt=1e-3)     # REBOUND's own first step
    sim.integrate(T)
    ias15, _ = _state(sim)
    # about 3x the error measured with 2000 steps (euler 0.42, symplectic_euler 5.1e-3,
    # leapfrog 3.8e-5, rk4 3.2e-10, yoshida4 1.4e-9, yoshida6 7.6e-14, yoshida8 1.1e-13,
    # gauss_radau 7.2e-16): a method of lower order than declared misses by orders of magnitude
    bound = {"euler": 1.0, "symplectic_euler": 0.015, "leapfrog": 1e-4, "rk4": 1e-9,
             "yoshida4": 4e-9, "yoshida6": 3e-13, "yoshida8": 4e-13, "gauss_radau": 3e-15}[name]
    w = figure_eight(integrator=name, dt=T / 2000)
    w.step(2000)
    err = np.max(np.abs(w.pos - ias15[:, :2]))
    assert err < bound, err


def test_wisdom_holman_refuses_a_singular_jacobi_orbit_and_keeps_the_state():
    # the figure-eight's middle body starts at the centre of mass of the other two
    w = figure_eight(integrator="wisdom_holman", dt=1e-3)
    pos, vel = w.pos.copy(), w.vel.copy()
    with pytest.raises(FloatingPointError, match="Jacobi orbit is singular"):
        w.step(10)
    assert np.array_equal(w.pos, pos) and np.array_equal(w.vel, vel) and w.t == 0.0
