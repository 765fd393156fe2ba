"""Every integrator of the registry: its table, its order, its energy behaviour, its invariants."""
import numpy as np
import pytest
from numpy.polynomial import legendre

import spacephys as sp
from spacephys.scenes import kepler, uniform_sphere

ALL = list(sp.INTEGRATORS)
SYMPLECTIC = [n for n, s in sp.INTEGRATORS.items() if s.symplectic]
FAMILY = {n: s.family for n, s in sp.INTEGRATORS.items()}


def two_planets(integrator, dt, **kw):
    """A star and two planets on mildly eccentric, inclined orbits (a = 1 and 1.6)."""
    w = sp.World(dim=3, integrator=integrator, dt=dt, **kw)
    w.add_body(1.0, (0, 0, 0), kind="star")
    for a, m, f in ((1.0, 1e-3, 0.0), (1.6, 5e-4, 2.0)):
        p, v = sp.elements_to_state(1.0 + m, a, 0.05, 0.02, f=f)
        w.add_body(m, p, v, kind="planet")
    w.move_to_center_of_mass()
    return w


def test_registry_lists_the_ladder():
    expected = {"euler": 1, "symplectic_euler": 1, "leapfrog": 2, "rk4": 4, "yoshida4": 4,
                "yoshida6": 6, "yoshida8": 8, "gauss_radau": 15, "wisdom_holman": 2,
                "wisdom_holman_corrected": 2}
    assert {n: s.order for n, s in sp.INTEGRATORS.items()} == expected
    assert SYMPLECTIC == ["symplectic_euler", "leapfrog", "yoshida4", "yoshida6", "yoshida8",
                          "wisdom_holman", "wisdom_holman_corrected"]
    assert [n for n, s in sp.INTEGRATORS.items() if s.adaptive] == ["gauss_radau"]


def test_unknown_name_lists_the_valid_ones():
    with pytest.raises(ValueError, match="integrator='verlet' is not known; valid: euler, "
                                         "symplectic_euler, leapfrog, rk4, yoshida4"):
        sp.get_integrator("verlet")


@pytest.mark.parametrize("name", [n for n in ALL if FAMILY[n] in ("splitting", "rk")])
def test_tables_are_consistent(name):
    spec = sp.INTEGRATORS[name]
    if spec.family == "splitting":
        # one step drifts and kicks by exactly dt in total
        assert spec.drift.sum() == pytest.approx(1.0, abs=1e-14)
        assert spec.kick.sum() == pytest.approx(1.0, abs=1e-14)
        assert spec.evaluations == np.count_nonzero(spec.kick)
        if name != "symplectic_euler":       # the others are time-symmetric compositions
            assert np.allclose(spec.drift, spec.drift[::-1], atol=1e-15)
            assert np.allclose(spec.kick[:-1], spec.kick[:-1][::-1], atol=1e-15)
        table = spec.drift
    else:
        assert spec.b.sum() == pytest.approx(1.0, abs=1e-15)
        assert np.all(np.triu(spec.a) == 0)   # explicit
        table = spec.b
    assert not table.flags.writeable          # a registry entry cannot be edited by accident


@pytest.mark.parametrize("name", ["yoshida4", "yoshida6", "yoshida8"])
def test_yoshida_weights_meet_the_order_conditions(name):
    # a symmetric composition of leapfrogs with weights w_i has order 2k only if
    # sum w_i = 1 and sum w_i^3 = sum w_i^5 = ... = sum w_i^(2k-1) = 0 (Yoshida 1990, sec. 4);
    # the kicks of the table are exactly those weights
    w = sp.INTEGRATORS[name].kick[:-1]
    order = sp.INTEGRATORS[name].order
    assert w.sum() == pytest.approx(1.0, abs=1e-14)
    for p in range(3, order, 2):
        assert abs(np.sum(w ** p)) < 1e-11, p


def test_gauss_radau_tables():
    spec = sp.INTEGRATORS["gauss_radau"]
    # the nodes with tau = 0 are those of 8-point Radau quadrature: roots of (P7 + P8)/(1 + x)
    roots = np.sort(legendre.legroots([0] * 7 + [1, 1]))
    np.testing.assert_allclose(spec.nodes, (roots[1:] + 1) / 2, atol=1e-15)
    np.testing.assert_allclose(spec.c_gb @ spec.d_bg, np.eye(7), atol=1e-15)
    # Newton and power forms of one random polynomial agree everywhere
    g = np.random.default_rng(1).normal(size=7)
    b = spec.c_gb.T @ g
    for tau in (0.0, 0.37, 1.0):
        newton = sum(g[j] * tau * np.prod([tau - h for h in spec.nodes[:j]]) for j in range(7))
        assert newton == pytest.approx(sum(b[k] * tau ** (k + 1) for k in range(7)), abs=1e-14)
    np.testing.assert_allclose(spec.d_bg.T @ b, g, atol=1e-13)


# ----------------------------------------------------------------------------- order

# Steps per 2 time units on a Kepler orbit (e = 0.5), chosen so the error sits between round-off
# and the pre-asymptotic regime (measured: slopes within 0.05 of the order there).
_N0 = {1: 1280, 2: 160, 4: 160, 6: 20, 8: 20}


def _kepler_error(name, nsteps, t_end=2.0, e=0.5, **kw):
    w = kepler(e, integrator=name, dt=t_end / nsteps, **kw)
    w.step(nsteps)
    r, v = sp.kepler_state(1.0, 1.0, e, w.t)
    return np.linalg.norm(w.pos[1] - r[:2]) + np.linalg.norm(w.vel[1] - v[:2]), w


def _slope(steps, errors):
    return -np.polyfit(np.log(steps), np.log(errors), 1)[0]


@pytest.mark.parametrize("name", [n for n in ALL if FAMILY[n] in ("splitting", "rk")])
def test_convergence_order_on_kepler_orbit(name):
    spec = sp.INTEGRATORS[name]
    steps = np.round(_N0[spec.order] * 2.0 ** (np.arange(5) / 2)).astype(int)
    errors = [_kepler_error(name, int(n))[0] for n in steps]
    assert abs(_slope(steps, errors) - spec.order) <= 0.3, (name, errors)


def test_gauss_radau_fixed_step_is_fifteenth_order():
    # tolerance 0: fixed steps; 5..8 steps over 2 time units give errors 1e-9..1e-12
    steps = [5, 6, 7, 8]
    runs = [_kepler_error("gauss_radau", n, tolerance=0.0) for n in steps]
    assert all(w.integrator_stats["steps"] == n for (_, w), n in zip(runs, steps))
    assert abs(_slope(steps, [e for e, _ in runs]) - 15) <= 0.3


@pytest.mark.parametrize("name", ["wisdom_holman", "wisdom_holman_corrected"])
def test_wisdom_holman_convergence_order(name):
    ref = two_planets("gauss_radau", 10.0)
    ref.step(1)
    steps = [40, 80, 160, 320]
    errors = []
    for n in steps:
        w = two_planets(name, 10.0 / n)
        w.step(n)
        errors.append(np.max(np.abs(w.pos - ref.pos)))
    assert abs(_slope(steps, errors) - 2) <= 0.3, errors


# ----------------------------------------------------------------------------- energy

def _energy_windows(make, total=100_000, every=7):
    """Max |dE/E| over the first and the last tenth of `total` steps (sampled off-period)."""
    w = make()
    E0 = w.energy()
    errs = np.empty(total // every)
    for k in range(errs.size):
        w.step(every)
        errs[k] = abs(w.energy() / E0 - 1)
    tenth = errs.size // 10
    return errs[:tenth].max(), errs[-tenth:].max()


def _energy_scene(name):
    if FAMILY[name] == "wisdom_holman":     # exact on two bodies: needs a third
        return lambda: two_planets(name, 2 * np.pi / 50)
    return lambda: kepler(0.5, planet_mass=1e-3, integrator=name, dt=2 * np.pi / 100)


@pytest.mark.parametrize("name", SYMPLECTIC)
def test_symplectic_energy_error_stays_bounded(name):
    # 1e5 steps, hundreds to a thousand orbits: the error oscillates, it does not grow
    first, last = _energy_windows(_energy_scene(name))
    assert last <= 1.05 * first, (first, last)
    assert last < 0.2


@pytest.mark.parametrize("name,steps_per_orbit", [("euler", 10_000), ("rk4", 100)])
def test_non_symplectic_energy_error_drifts(name, steps_per_orbit):
    assert not sp.INTEGRATORS[name].symplectic
    first, last = _energy_windows(
        lambda: kepler(0.5, planet_mass=1e-3, integrator=name, dt=2 * np.pi / steps_per_orbit))
    assert last > 3 * first, (first, last)


def test_symplectic_corrector_shrinks_the_energy_error():
    # the corrector removes the epsilon dt^2 term: at 50 steps per orbit measured 116x smaller
    # (1.06e-6 -> 9.1e-9); a corrector of the wrong sign or size gains 2x at best
    plain, _ = _energy_windows(_energy_scene("wisdom_holman"), total=7000)
    corrected, _ = _energy_windows(_energy_scene("wisdom_holman_corrected"), total=7000)
    assert corrected < plain / 50, (plain, corrected)


# ----------------------------------------------------------------------------- invariants

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
    crowd.add_bodies(5.0, rng.normal(size=(50, 3)), kind="ship")
    alone.step(50)
    crowd.step(50)
    assert np.array_equal(crowd.pos[:200], alone.pos)
    assert np.array_equal(crowd.vel[:200], alone.vel)
    ships = crowd.vel[-50:]                  # they started at rest and fell toward the cluster
    assert np.all(np.linalg.norm(ships, axis=1) > 0)


# ----------------------------------------------------------------------------- drag

def _thrown(name, n, k=0.3, T=2.0, **kw):
    """A body thrown in a uniform field into a wind with linear drag: (error at T against
    the closed form x(t) = vt t + (v0 - vt)(1 - exp(-k t)) / k, vt = wind + g / k, World)."""
    g, wind, v0 = np.array([0.0, -10.0]), np.array([4.0, 1.0]), np.array([17.3, 10.0])
    w = sp.World(dim=2, gravity="uniform", g=g, drag=k, wind=wind, integrator=name,
                 dt=T / n, **kw)
    w.add_body(1.0, (0.0, 0.0), v0)
    w.step(n)
    if k == 0:
        return None, w
    vt = wind + g / k
    exact = vt * T + (v0 - vt) * -np.expm1(-k * T) / k
    return np.abs(w.pos[0] - exact).max(), w


@pytest.mark.parametrize("name, n0", [("symplectic_euler", 400), ("leapfrog", 50),
                                      ("yoshida4", 20), ("rk4", 20)])
def test_drag_keeps_each_integrators_order(name, n0):
    errors = [_thrown(name, n0 * 2 ** j)[0] for j in range(3)]
    slopes = np.log2(np.array(errors[:-1]) / errors[1:])
    assert np.all(np.abs(slopes - sp.INTEGRATORS[name].order) < 0.15), (slopes, errors)


def test_drag_leaves_fixed_bodies_at_rest_and_changes_nothing_at_zero():
    w = sp.World(dim=2, gravity="uniform", g=(0.0, -1.0), drag=0.5, wind=(3.0, 0.0), dt=0.01)
    post = w.add_body(1.0, (0.0, 0.0), fixed=True)
    w.step(100)
    assert np.all(w.get(post).vel == 0) and np.all(w.get(post).pos == 0)
    _, with_zero = _thrown("leapfrog", 100, k=0.0)
    plain = sp.World(dim=2, gravity="uniform", g=(0.0, -10.0), integrator="leapfrog", dt=0.02)
    plain.add_body(1.0, (0.0, 0.0), (17.3, 10.0))
    plain.step(100)
    assert np.array_equal(with_zero.pos, plain.pos)


def test_bad_drag_is_refused():
    with pytest.raises(ValueError, match="drag = -1"):
        sp.World(dim=2, drag=-1.0)
    with pytest.raises(ValueError, match=r"wind"):
        sp.World(dim=2, drag=1.0, wind=(1.0, 2.0, 3.0))


def test_gauss_radau_takes_drag_to_machine_precision():
    """Drag is read at each node's velocity (off the velocity polynomial): the thrown body
    lands on the closed form to round-off, in one output interval of 2 time units."""
    error, w = _thrown("gauss_radau", 1)
    assert error < 1e-12 * 30, error            # positions of ~30 length units
    assert w.integrator_stats["steps"] > 1


def _dragged_orbit(name, n, T=2 * np.pi, **kw):
    """A star and a planet (mass 1e-3) in a thin atmosphere drifting along x, 3D."""
    w = sp.World(dim=3, integrator=name, dt=T / n, drag=0.05, wind=(0.1, 0.0, 0.0), **kw)
    w.add_body(1.0, (0.0, 0.0, 0.0), kind="star")
    w.add_body(1e-3, (1.0, 0.0, 0.1), (0.0, 1.0, 0.05), kind="planet")
    w.add_body(0.0, (0.0, 1.5, 0.0), (-0.8, 0.0, 0.0), kind="asteroid")
    w.step(n)
    return w.pos


@pytest.mark.parametrize("name", ["wisdom_holman", "wisdom_holman_corrected"])
def test_wisdom_holman_takes_drag_at_second_order(name):
    """The kick relaxes Jacobi velocities exactly (relative ones toward rest, the centre of
    mass toward the wind): second order against a converged Gauss-Radau run with drag."""
    ref = _dragged_orbit("gauss_radau", 1, tolerance=1e-12)
    steps = np.array([200, 400, 800])
    errors = [np.abs(_dragged_orbit(name, int(n)) - ref).max() for n in steps]
    slopes = np.log2(np.array(errors[:-1]) / errors[1:])
    assert np.all(np.abs(slopes - 2) < 0.3), (slopes, errors)
    assert errors[-1] < 1e-4


def test_wisdom_holman_refuses_a_field_without_a_dominant_mass():
    w = sp.World(dim=2, integrator="wisdom_holman", gravity="uniform", g=(0.0, -1.0), dt=0.1)
    w.add_body(1.0, (0.0, 0.0), (1.0, 0.0))
    with pytest.raises(ValueError, match="gravity='direct'.*Kepler"):
        w.step(1)
    assert w.t == 0.0


def test_bad_drag_assignments_change_nothing():
    w = sp.World(dim=2, drag=0.5, wind=(1.0, 2.0))
    with pytest.raises(ValueError, match="drag = -0.1"):
        w.drag = -0.1
    with pytest.raises(ValueError, match="wind"):
        w.wind = (1.0, float("nan"))
    assert w.drag == 0.5 and np.array_equal(w.wind, [1.0, 2.0])
