"""Ready-made scenes: the reference problems of the tests and benchmarks, and the default demo.

Each function returns a new World; keyword arguments not listed go to World (integrator, dt...).
"""
import numpy as np

from .kernels import libm
from .orbits import elements_to_state, period
from .world import World


def uniform_sphere(n, *, seed=0, softening=1e-3, **world):
    """n equal masses 1/n at rest, uniform in the unit sphere, G = 1 (the gravity benchmark)."""
    rng = np.random.default_rng(seed)
    p = rng.normal(size=(n, 3))
    p *= (libm.each("cbrt", rng.random(n)) / np.linalg.norm(p, axis=1))[:, None]
    w = World(dim=3, softening=softening, **world)
    w.add_bodies(np.full(n, 1.0 / n), p, kind="asteroid")
    return w


def plummer_model(n, *, seed=0, r_max=20.0):
    """(pos (n, 3), vel (n, 3), mass (n,)): n equal masses drawn from Plummer's sphere in
    equilibrium, G = M = a = 1 (mass 1/n each; radii cut at r_max), centre of mass at rest at
    the origin. Radii by inverting the cumulative mass, speeds by rejection from
    f(q) ~ q^2 (1 - q^2)^(7/2), q the speed over the escape speed (Aarseth, Henon and
    Wielen 1974). Kinetic energy 3 pi / 64, potential -3 pi / 32; crossing time about 3.1
    (the virial radius 16 / (3 pi) over the rms speed sqrt(3 pi / 32))."""
    rng = np.random.default_rng(seed)

    def directions(k):
        d = rng.normal(size=(k, 3))
        return d / np.linalg.norm(d, axis=1)[:, None]

    r = np.empty(0)
    while r.size < n:
        x = rng.uniform(1e-12, 1.0, 2 * n)
        c = libm.each("cbrt", x)                # x^(-2/3) = 1 / c^2
        cand = 1.0 / np.sqrt(1.0 / (c * c) - 1.0)
        r = np.concatenate([r, cand[cand <= r_max]])
    r = r[:n]
    q = np.empty(0)
    while q.size < n:
        x, y = rng.uniform(0.0, 1.0, 2 * n), rng.uniform(0.0, 0.1, 2 * n)
        t = 1.0 - x * x                        # (1 - x^2)^(7/2) = t^3 sqrt(t)
        q = np.concatenate([q, x[y < x * x * (t * t * t * np.sqrt(t))]])
    speed = q[:n] * np.sqrt(2.0) / np.sqrt(np.sqrt(1.0 + r * r))
    pos, vel = r[:, None] * directions(n), speed[:, None] * directions(n)
    pos -= pos.mean(axis=0)
    vel -= vel.mean(axis=0)
    return pos, vel, np.full(n, 1.0 / n)


def cold_disc_model(n, *, seed=0, scale=0.3, r_max=1.5):
    """(pos (n, 3), vel (n, 3), mass (n,)): n equal masses (total 1, G = 1) in an exponential
    disc of scale length `scale` in the plane z = 0, cut at r_max, on circular orbits about the
    centre with the speed of the mass inside (no random motion: cold)."""
    rng = np.random.default_rng(seed)
    r = np.empty(0)
    while r.size < n:
        cand = rng.gamma(2.0, scale, 2 * n)          # surface density ~ exp(-r / scale)
        r = np.concatenate([r, cand[cand <= r_max]])
    r = np.sort(r[:n])
    th = rng.uniform(0.0, 2 * np.pi, n)
    inside = np.arange(n) / n
    speed = np.sqrt(inside / np.maximum(r, 1e-12))
    cos, sin = libm.each("cos", th), libm.each("sin", th)
    pos = np.c_[r * cos, r * sin, np.zeros(n)]
    vel = np.c_[-speed * sin, speed * cos, np.zeros(n)]
    return pos, vel, np.full(n, 1.0 / n)


def plummer_sphere(n, *, seed=0, softening=0.01, **world):
    """A World (3D, G = 1) of Plummer's sphere, plummer_model(n, seed); gravity="tree" by
    default."""
    pos, vel, mass = plummer_model(n, seed=seed)
    world.setdefault("gravity", "tree")
    w = World(dim=3, G=1.0, softening=softening, capacity=n, **world)
    w.add_bodies(mass, pos, vel, kind="star")
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


# Keplerian elements of the planets at J2000 (E. M. Standish, "Keplerian elements for approximate
# positions of the major planets", JPL/SSD, Table 1): a [AU], e, I, L, long. of perihelion,
# long. of ascending node [deg], ecliptic frame; masses [solar masses] from the IAU 2015 nominal
# values (Earth: the Earth-Moon barycentre).
PLANETS = {
    "mercury": (0.38709927, 0.20563593, 7.00497902, 252.25032350, 77.45779628, 48.33076593, 1.6601e-7),
    "venus": (0.72333566, 0.00677672, 3.39467605, 181.97909950, 131.60246718, 76.67984255, 2.4478e-6),
    "earth": (1.00000261, 0.01671123, -0.00001531, 100.46457166, 102.93768193, 0.0, 3.0404e-6),
    "mars": (1.52371034, 0.09339410, 1.84969142, -4.55343205, -23.94362959, 49.55953891, 3.2272e-7),
    "jupiter": (5.20288700, 0.04838624, 1.30439695, 34.39644051, 14.72847983, 100.47390909, 9.5479e-4),
    "saturn": (9.53667594, 0.05386179, 2.48599187, 49.95424423, 92.59887831, 113.66242448, 2.8589e-4),
    "uranus": (19.18916464, 0.04725744, 0.77263783, 313.23810451, 170.95427630, 74.01692503, 4.3662e-5),
    "neptune": (30.06992276, 0.00859048, 1.77004347, -55.12002969, 44.96476227, 131.78422574, 5.1514e-5),
}


def solar_system(planets=tuple(PLANETS), **world):
    """The Sun and planets at J2000 from their Keplerian elements, heliocentric elements turned
    into barycentric state vectors; units au-msun-yr (G from the Gaussian constant)."""
    world.setdefault("units", "au-msun-yr")
    w = World(dim=3, **world)
    w.add_body(1.0, np.zeros(3), radius=0.00465, kind="star")
    for name in planets:
        a, e, inc, L, varpi, node, m = PLANETS[name]
        omega, M = np.radians(varpi - node), np.radians(L - varpi)
        pos, vel = elements_to_state(w.G * (1.0 + m), a, e, np.radians(inc), np.radians(node),
                                     omega, M=M)
        w.add_body(m, pos, vel, kind="planet")
    w.move_to_center_of_mass()
    return w


def outer_solar_system(**world):
    """Sun (with the inner planets' mass), Jupiter, Saturn, Uranus, Neptune at 1994-09-05: the
    initial values of Hairer, Lubich & Wanner, Geometric Numerical Integration (2006), I.2.4,
    positions [AU] and velocities [AU/day] turned to AU/yr; units au-msun-yr."""
    world.setdefault("units", "au-msun-yr")
    w = World(dim=3, **world)
    masses = [1.00000597682, 0.000954786104043, 0.000285583733151, 0.0000437273164546,
              0.0000517759138449]
    pos = [[0.0, 0.0, 0.0], [-3.5023653, -3.8169847, -1.5507963],
           [9.0755314, -3.0458353, -1.6483708], [8.3101420, -16.2901086, -7.2521278],
           [11.4707666, -25.7294829, -10.8169456]]
    vel = np.array([[0.0, 0.0, 0.0], [0.00565429, -0.00412490, -0.00190589],
                    [0.00168318, 0.00483525, 0.00192462], [0.00354178, 0.00137102, 0.00055029],
                    [0.00288930, 0.00114527, 0.00039677]]) * 365.25
    w.add_bodies(masses, pos, vel, kind=["star"] + ["planet"] * 4)
    w.move_to_center_of_mass()
    return w


def fleet_battle(*, ships=200, missiles=2000, debris=50_000, seed=0, **world):
    """Two fleets fighting around a star (2D, game units, G = 1): a star and nine planets
    (the 10 massive bodies), `ships` ships in two counter-rotating bands, `missiles` missiles
    with proportional navigation, each fired from a ship of one fleet at a ship of the other,
    and `debris` particles from earlier explosions; collisions on (missiles and ships destroy
    each other, anything hitting a planet is destroyed, ships bounce off each other; destroyed
    ships and missiles explode). The scene of the fleet-battle benchmark."""
    from .entities import ExplosionSpec, MissileSpec, ShipSpec
    world.setdefault("dt", 1 / 60)
    w = World(dim=2, seed=seed, **world)
    rng = np.random.default_rng(seed)
    star_mass = 1e7
    w.add_body(star_mass, (0.0, 0.0), radius=60.0, kind="star")
    for k in range(9):
        a = 900.0 + 500.0 * k
        pos, vel = elements_to_state(star_mass, a, 0.0, f=2.0 * np.pi * rng.random())
        w.add_body(1e3 * (1 + k % 4), pos[:2], vel[:2], radius=15.0 + 2.0 * (k % 4),
                   kind="planet")
    for a, b, response in (("missile", "ship", "destroy_both"), ("missile", "planet", "destroy_a"),
                           ("missile", "star", "destroy_a"), ("ship", "planet", "destroy_a"),
                           ("ship", "star", "destroy_a"), ("debris", "planet", "destroy_a"),
                           ("debris", "star", "destroy_a")):
        w.set_collision(a, b, response)
    w.set_collision("ship", "ship", "bounce", restitution=0.5)
    boom = ExplosionSpec(count=100, speed=20.0, lifetime=5.0, lifetime_spread=0.5)
    hull = ShipSpec(dry_mass=10.0, fuel_mass=10.0, max_thrust=200.0, exhaust_speed=300.0,
                    side_thrust=50.0, turn_rate=2.0, radius=4.0, explosion=boom)
    fleets = []
    for side, (r, sense) in enumerate(((2900.0, 1.0), (3100.0, -1.0))):
        ids = []
        for k in range(ships // 2 + (side < ships % 2)):
            angle = rng.uniform(0.0, 0.6) + np.pi * side
            radius = r + rng.uniform(-60.0, 60.0)
            pos = radius * np.array([libm.py.cos(angle), libm.py.sin(angle)])
            speed = np.sqrt(star_mass / radius)
            vel = sense * speed * np.array([-libm.py.sin(angle), libm.py.cos(angle)])
            ship = w.add_ship(hull, pos, vel, heading=rng.uniform(-np.pi, np.pi))
            w.control(ship, throttle=rng.uniform(0.0, 0.3), turn=rng.uniform(-0.2, 0.2))
            ids.append(ship)
        fleets.append(ids)
    warhead = MissileSpec(mass=1.0, fuel_mass=2.0, thrust=300.0, exhaust_speed=500.0,
                          guidance="pn", turn_rate=4.0, launch_speed=20.0, lifetime=20.0,
                          arming_delay=0.5, fuse_radius=8.0, radius=1.0,
                          explosion=ExplosionSpec(count=20, speed=10.0, lifetime=2.0))
    for k in range(missiles):
        side = k % 2
        if not fleets[side] or not fleets[1 - side]:
            break
        shooter = fleets[side][rng.integers(len(fleets[side]))]
        target = fleets[1 - side][rng.integers(len(fleets[1 - side]))]
        w.launch(shooter, warhead, target=target, heading=rng.uniform(-np.pi, np.pi))
    # debris of earlier fights: explosions of bodies made for the purpose, along the bands
    cloud = ExplosionSpec(count=500, speed=30.0, lifetime=60.0, lifetime_spread=0.5,
                          radius=0.5)
    for k in range(debris // cloud.count):
        angle = rng.uniform(0.0, 2.0 * np.pi)
        radius = rng.uniform(2700.0, 3300.0)
        pos = radius * np.array([libm.py.cos(angle), libm.py.sin(angle)])
        vel = np.sqrt(star_mass / radius) * np.array([-libm.py.sin(angle), libm.py.cos(angle)])
        w.explode(w.add_body(1.0, pos, vel, radius=5.0), cloud)
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
    "fleet_battle": (fleet_battle, 10.0, "leapfrog", 1 / 60),
}
