"""The one World -> REBOUND adapter of the study tools and tests: REBOUND (GPL-3.0) is used as
an oracle and a benchmark peer only, through its public Python API."""
import numpy as np


def load():
    """The rebound module; extras.MissingExtra saying how to install it."""
    from ..extras import require
    require("comparing with REBOUND", "rebound")
    import rebound
    return rebound


def simulation(w, integrator="ias15", *, dt=None, n_active=None, gravity=None, **settings):
    """A REBOUND Simulation with w's bodies (in row order: masses, radii, positions and
    velocities), G, softening and dt; settings go
    to sim.integrator's attributes (corrector=3, safe_mode=0, ...). n_active: only the first
    that many bodies pull (the others as test particles that feel but do not pull, as in
    spacephys); gravity: REBOUND's gravity routine ("basic": direct summation, as ours)."""
    rebound = load()
    sim = rebound.Simulation()
    if gravity is not None:
        sim.gravity = gravity
    sim.G = w.G
    sim.softening = w.softening
    sim.integrator = integrator
    sim.dt = w.dt if dt is None else dt
    for key, value in settings.items():
        setattr(sim.integrator, key, value)
    pos = np.zeros((w.n, 3))
    vel = np.zeros((w.n, 3))
    pos[:, :w.dim], vel[:, :w.dim] = w.pos, w.vel
    for m, r, p, v in zip(w.mass, w.radius, pos, vel):
        sim.add(m=float(m), r=float(r), x=p[0], y=p[1], z=p[2], vx=v[0], vy=v[1], vz=v[2])
    if n_active is not None:
        sim.N_active = n_active
        sim.testparticle_type = 0
    return sim


def positions(sim):
    """(N, 3) positions of a REBOUND simulation."""
    xyz = np.empty((sim.N, 3))
    sim.serialize_particle_data(xyz=xyz)
    return xyz


def velocities(sim):
    """(N, 3) velocities of a REBOUND simulation."""
    v = np.empty((sim.N, 3))
    sim.serialize_particle_data(vxvyvz=v)
    return v


def add_j2(sim, k):
    """Give sim (its particle 0 the planet) the J2 force of spacephys.userforces.j2 as a
    Python additional_forces callback: k = J2 mu R^2; the planet takes the reaction of every
    body with mass."""
    ps = sim.particles

    def force(reb_sim):
        p = ps[0]
        for i in range(1, sim.N):
            q = ps[i]
            x, y, z = q.x - p.x, q.y - p.y, q.z - p.z
            r2 = x * x + y * y + z * z
            s = 5.0 * z * z / r2
            c = -1.5 * k / (r2 * r2 * r2 ** 0.5)
            ax, ay, az = c * x * (1 - s), c * y * (1 - s), c * z * (3 - s)
            q.ax += ax
            q.ay += ay
            q.az += az
            if q.m > 0:
                p.ax -= q.m / p.m * ax
                p.ay -= q.m / p.m * ay
                p.az -= q.m / p.m * az

    sim.additional_forces = force
    sim.force_is_velocity_dependent = 0
    return sim


def adaptive_per_step(w, sim, duration):
    """Seconds per step of w.step(1) (an adaptive World whose dt is the duration) and of
    sim.integrate(duration), timed one after the other, and the steps each took."""
    import time
    start = time.perf_counter()
    w.step(1)
    ours = time.perf_counter() - start
    start = time.perf_counter()
    sim.integrate(duration)
    theirs = time.perf_counter() - start
    steps, rsteps = w.integrator_stats["steps"], int(sim.steps_done)
    return ours / steps, theirs / rsteps, steps, rsteps
