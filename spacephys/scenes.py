"""Ready-made scenes: the reference problems of the tests and benchmarks, and the default demo.

Each function returns a new World; keyword arguments not listed go to World (integrator, dt...).
"""
import numpy as np

from .orbits import elements_to_state, period
from .world import World


def uniform_sphere(n, *, seed=0, softening=1e-3, **world):
    """n equal masses 1/n at rest, uniform in the unit sphere, G = 1 (the gravity benchmark)."""
    rng = np.random.default_rng(seed)
    p = rng.normal(size=(n, 3))
    p *= (rng.random(n) ** (1.0 / 3.0) / np.linalg.norm(p, axis=1))[:, None]
    w = World(dim=3, softening=softening, **world)
    w.add_bodies(np.full(n, 1.0 / n), p, kind="asteroid")
    return w


def kepler(e=0.5, *, a=1.0, mu=1.0, planet_mass=0.0, dim=2, **world):
    """A star of mass mu (G = 1) and a planet at pericentre of an orbit (a, e).

    With planet_mass = 0 the planet is a test particle, the star stays put and the orbit is
    exactly Keplerian: compare with orbits.kepler_state(mu, a, e, t). With a planet mass the
    pair orbits its centre of mass, which rests at the origin.
    """
    w = World(dim=dim, **world)
    w.add_body(mu, np.zeros(dim), kind="star")
    pos, vel = elements_to_state(mu + planet_mass, a, e, f=0.0)
    w.add_body(planet_mass, pos[:dim], vel[:dim], kind="planet")
    if planet_mass > 0:
        w.move_to_center_of_mass()
    return w


# Chenciner & Montgomery (2000), Ann. Math. 152, 881; initial conditions of C. Simo (2002).
FIGURE_EIGHT_PERIOD = 6.32591398


def figure_eight(**world):
    """Three equal masses (1, G = 1) on the figure-eight choreography; period 6.32591398."""
    x1 = np.array([0.97000436, -0.24308753])
    v3 = np.array([-0.93240737, -0.86473146])
    w = World(dim=2, **world)
    w.add_bodies([1.0, 1.0, 1.0], [x1, -x1, [0.0, 0.0]], [-v3 / 2, -v3 / 2, v3])
    return w


def pythagorean(**world):
    """Burrau's problem: masses 3, 4, 5 at rest at (1, 3), (-2, -1), (1, -1), G = 1."""
    w = World(dim=2, **world)
    w.add_bodies([3.0, 4.0, 5.0], [[1.0, 3.0], [-2.0, -1.0], [1.0, -1.0]])
    return w


def star_system(*, asteroids=2000, seed=1, dim=2, **world):
    """The demo: a star, four planets, a moon, a comet (e = 0.9) and an asteroid belt of test
    particles, in game units (G = 1, star mass 1, inner planet at 1 with period 2 pi).
    """
    w = World(dim=dim, **world)
    w.add_body(1.0, np.zeros(dim), radius=0.05, kind="star")
    planets = [(1.0, 3e-6, 0.02), (1.6, 3e-7, 0.08), (3.2, 1e-3, 0.05), (5.5, 3e-4, 0.03)]
    states = {}
    for k, (a, m, e) in enumerate(planets):
        pos, vel = elements_to_state(1.0 + m, a, e, omega=1.3 * k, f=2.1 * k)
        states[k] = (pos, vel, m)
        w.add_body(m, pos[:dim], vel[:dim], radius=0.01, kind="planet")
    # a moon of the giant (planet 2), well inside its Hill radius a (m/3)^(1/3) = 0.22
    pos, vel, m = states[2]
    mp, vp = elements_to_state(m, 0.03, 0.0, f=0.0)
    w.add_body(1e-8, (pos + mp)[:dim], (vel + vp)[:dim], radius=0.002, kind="moon")
    pos, vel = elements_to_state(1.0, 4.0, 0.9, omega=2.5, f=0.5)
    w.add_body(0.0, pos[:dim], vel[:dim], kind="body")
    rng = np.random.default_rng(seed)
    a, e, omega, f = (rng.uniform(2.0, 2.6, asteroids), rng.uniform(0, 0.1, asteroids),
                      rng.uniform(0, 2 * np.pi, asteroids), rng.uniform(0, 2 * np.pi, asteroids))
    belt = [elements_to_state(1.0, ak, ek, omega=ok, f=fk) for ak, ek, ok, fk in zip(a, e, omega, f)]
    if belt:
        pos, vel = (np.array(x)[:, :dim] for x in zip(*belt))
        w.add_bodies(0.0, pos, vel, kind="asteroid")
    w.move_to_center_of_mass()
    return w


# Scenes `spacephys run` knows: name -> (function building the World, duration [time],
# integrator and dt suited to it). The Pythagorean problem waits for the adaptive integrator:
# its close encounters defeat any fixed step.
SCENES = {
    "star_system": (star_system, 20 * period(1.0, 1.0), "yoshida4", 2e-3),
    "figure_eight": (figure_eight, 10 * FIGURE_EIGHT_PERIOD, "yoshida6", 1e-3),
    "kepler": (lambda **kw: kepler(0.5, planet_mass=1e-3, **kw), 10 * period(1.0, 1.0),
               "leapfrog", 1e-3),
    "cluster": (lambda **kw: uniform_sphere(1024, **kw), 0.1, "leapfrog", 1e-4),
}
