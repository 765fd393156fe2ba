"""Stability at the extremes (docs/extremes.md lists each case, what happens and why).

Each case is either accurate within a stated bound, measured against a closed form or
REBOUND, or the World raises InstabilityError naming the bodies; never silent garbage.
"""
import math
import warnings

import hypothesis.strategies as st
import numpy as np
import pytest
from hypothesis import given, settings

import spacephys as sp
from spacephys import scenes
from spacephys.kernels import diagnostics
from spacephys.study import rebound as peer

P = 2 * math.pi          # the period of an a = 1 orbit about mu = 1


# ---------------------------------------------------------------- mass ratios 1e-12 ... 1e12
def _hierarchy(**kw):
    """A star (1), a planet (1e-6) at 1 and its moon (1e-12) at 0.002 from it, all pulling:
    mass ratios from 1e-12 to 1e12 in one scene."""
    w = sp.World(dim=3, **kw)
    w.add_body(1.0, (0, 0, 0), kind="star")
    w.add_body(1e-6, (1, 0, 0), (0, 1, 0), kind="planet")
    w.add_body(1e-12, (1.002, 0, 0), (0, 1 + math.sqrt(1e-6 / 0.002), 0), kind="moon")
    w.move_to_center_of_mass()
    return w


def _rebound_ias15(w, t):
    sim = peer.simulation(w, "ias15", dt=1e-3)          # REBOUND's own first step
    sim.integrate(t, exact_finish_time=1)
    return peer.positions(sim)


@pytest.mark.parametrize("integrator, dt, moon_bound", [("gauss_radau", P / 10, 1e-9),
                                                        ("yoshida6", P / 1250, 2e-6)])
def test_mass_ratios_1e12_in_one_scene(integrator, dt, moon_bound):
    """The moon's orbit about the planet (its mass 1e-12 of the star's) is not lost in the
    round-off of the big bodies: after one planetary orbit it agrees with IAS15 to moon_bound
    of its orbit's size (measured 1.2e-11 Gauss-Radau, 1.8e-7 Yoshida 6, 2.9e-3 leapfrog at
    dt 1e-3), the planet to 1e-12, momentum to 1e-19 (the star's is 1e-6), energy to 1e-13."""
    w = _hierarchy(integrator=integrator, dt=dt)
    ref = _rebound_ias15(w, P)
    p0, E0 = w.momentum(), w.energy()
    w.step(round(P / dt))
    assert abs(w.t - P) < 1e-12
    moon_error = np.linalg.norm((w.pos[2] - w.pos[1]) - (ref[2] - ref[1])) / 0.002
    assert moon_error < moon_bound
    assert np.linalg.norm(w.pos[1] - ref[1]) < 1e-12
    assert np.abs(w.momentum() - p0).max() < 1e-19
    assert abs(w.energy() / E0 - 1) < 1e-13


# ---------------------------------------------------------------- eccentricities
@pytest.mark.parametrize("e, bound", [(0.999, 1e-11), (0.9999, 1e-10)])
@pytest.mark.parametrize("integrator, dt", [("gauss_radau", P / 2),
                                            ("wisdom_holman", P / 2 / 7.3)])
def test_eccentricity_0999_and_09999(e, bound, integrator, dt):
    """A comet of e = 0.999 / 0.9999 (pericentre 1e-3 / 1e-4, speed there 45 / 141) after
    10.5 orbits, at apocentre: Gauss-Radau (adaptive) and Wisdom-Holman (exact Kepler drift)
    stay within `bound` of the closed form in position and energy (measured 4e-13 and 3e-12
    Gauss-Radau, 5e-13 and 1.3e-12 Wisdom-Holman)."""
    w = scenes.kepler(e, integrator=integrator, dt=dt)
    w.step(round(10.5 * P / dt))
    p, _ = sp.kepler_state(1.0, 1.0, e, w.t)
    assert np.abs(w.pos[1, :2] - p[:2]).max() < bound
    energy = 0.5 * (w.vel[1] ** 2).sum() - 1.0 / np.linalg.norm(w.pos[1])
    assert abs(energy / -0.5 - 1) < bound


def test_unresolved_pericentre_is_reported_naming_the_bodies():
    """Leapfrog at P/1000 cannot resolve a pericentre of 1e-4 (its dynamical time is 1e-6):
    the energy goes wrong by orders of magnitude, and a watched World says so and names the
    pair instead of returning the garbage."""
    w = scenes.kepler(0.9999, planet_mass=1e-3, integrator="leapfrog", dt=P / 1000)
    w.watch_energy(1e-3)
    with pytest.raises(sp.InstabilityError, match=r"energy error .* passed its limit 0\.001"
                       r".*body [01] \((star|planet)\), body [01]") as err:
        w.step(2000)
    assert sorted(err.value.ids) == [0, 1]
    assert err.value.t == w.t


# ---------------------------------------------------------------- close encounters
@pytest.mark.parametrize("q, bound", [(1e-6, 1e-9), (1e-8, 1e-7)])
def test_close_encounter_down_to_1e8_of_the_orbit(q, bound):
    """A body of a = 1 through a pericentre q (1e-6, 1e-8 of the orbit; speed there 1.4e3,
    1.4e4) and out to apocentre: Gauss-Radau within `bound` of the closed form in position
    and energy (measured 2.6e-10 and 1.7e-8); Wisdom-Holman too (5e-10, 6.5e-9). Equal
    masses through the same encounter keep energy to the bound, angular momentum to 1e-14."""
    e = 1 - q
    for integrator, dt in (("gauss_radau", P / 2), ("wisdom_holman", P / 2 / 7.3)):
        w = scenes.kepler(e, integrator=integrator, dt=dt)
        w.step(round(1.5 * P / dt))
        p, _ = sp.kepler_state(1.0, 1.0, e, w.t)
        assert np.abs(w.pos[1, :2] - p[:2]).max() < bound, integrator
        energy = 0.5 * (w.vel[1] ** 2).sum() - 1.0 / np.linalg.norm(w.pos[1])
        assert abs(energy / -0.5 - 1) < bound, integrator
    w = scenes.kepler(e, planet_mass=1.0, integrator="gauss_radau", dt=P / 2 / math.sqrt(2))
    E0, L0 = w.energy(), w.angular_momentum()
    w.step(3)
    assert abs(w.energy() / E0 - 1) < bound
    assert abs(w.angular_momentum() / L0 - 1) < 1e-14


def _twins(integrator, dv, softening=0.0):
    w = sp.World(dim=2, integrator=integrator, dt=1e-3, softening=softening)
    w.add_body(1.0, (0, 0), kind="star")
    w.add_body(1e-3, (1, 0), (0, 1), kind="planet")
    w.add_body(1e-3, (1, 0), (dv, 1), kind="planet")
    return w


@pytest.mark.parametrize("integrator", ["leapfrog", "gauss_radau"])
def test_coincident_bodies_moving_together_stay_together(integrator):
    """Two bodies at exactly the same point with the same velocity exert no force on each
    other (the direction is undefined): they orbit as one, exactly, with no NaN."""
    w = _twins(integrator, 0.0)
    E0 = w.energy()
    w.step(1000)
    assert np.array_equal(w.pos[1], w.pos[2]) and np.array_equal(w.vel[1], w.vel[2])
    assert abs(w.energy() / E0 - 1) < 1e-9


def test_coincident_bodies_flying_apart_are_reported():
    """The same bodies separating at 0.1 start from an infinite pair energy: leapfrog's
    first kicks are wild (energy off by 1e5), and a watched World names the pair;
    Gauss-Radau cannot find a step, and says so naming the pair, state kept at t = 0.
    Softened (1e-3), both integrate it: energy kept to 1e-3 / 1e-12."""
    w = _twins("leapfrog", 0.1)
    w.watch_energy(1e-3)
    with pytest.raises(sp.InstabilityError, match="body [12] \\(planet\\), body [12]") as err:
        w.step(1000)
    assert sorted(err.value.ids[:2]) == [1, 2]
    w = _twins("gauss_radau", 0.1)
    with pytest.raises(sp.InstabilityError, match="closest pulling bodies are body 1 "
                       r"\(planet\), body 2 \(planet\)") as err:
        w.step(1000)
    assert sorted(err.value.ids) == [1, 2] and w.t == 0.0
    assert np.array_equal(w.pos[1], w.pos[2])
    for integrator, bound in (("leapfrog", 1e-3), ("gauss_radau", 1e-12)):
        w = _twins(integrator, 0.1, softening=1e-3)
        E0 = w.energy()
        w.step(1000)
        assert abs(w.energy() / E0 - 1) < bound, integrator


# ---------------------------------------------------------------- far from the origin
def _far_kepler(offset):
    w = sp.World(dim=2, integrator="leapfrog", dt=1e-3)
    w.add_body(1.0, (offset, 0.0), kind="star")
    w.add_body(0.0, (offset + 1.0, 0.0), (0.0, 1.0), kind="planet")
    return w


@pytest.mark.filterwarnings("ignore::spacephys.PrecisionWarning")  # its subject
def test_far_from_the_origin_precision_is_lost_and_a_shifted_origin_keeps_it():
    """At 1e15 from the origin a double resolves only 0.125: a unit orbit there is garbage
    (measured position error of order 1). Shifting the origin to the star gives the same
    motion as the scene built at 0, bit for bit, and the absolute positions stay
    origin + pos."""
    near = _far_kepler(0.0)
    far = _far_kepler(1e15)
    shifted = _far_kepler(1e15)
    shifted.shift_origin((1e15, 0.0))
    for w in (near, far, shifted):
        w.step(6283)
    far_error = np.abs((far.pos[1] - far.pos[0]) - (near.pos[1] - near.pos[0])).max()
    assert far_error > 0.1                  # the precision loss, shown
    assert np.array_equal(shifted.pos, near.pos) and np.array_equal(shifted.vel, near.vel)
    assert np.array_equal(shifted.origin, [1e15, 0.0])
    p, _ = sp.kepler_state(1.0, 1.0, 0.0, near.t)
    assert np.abs(near.pos[1] - p[:2]).max() < 1e-5      # and near 0 it is a good orbit


@settings(max_examples=60, deadline=None)
@given(st.integers(0, 40), st.integers(1, 3), st.integers(0, 2**32 - 1), st.booleans())
def test_the_precision_checks_extent_is_numpys(n, d, seed, nans):
    """diagnostics.extent (the widest span along an axis, the largest |coordinate|, NaNs
    passed over) is numpy's nanmin/nanmax answer, on strided (n, d) views as World hands it."""
    rng = np.random.default_rng(seed)
    pos = (rng.normal(size=(n, 3)) * 10.0 ** rng.integers(-3, 9, (n, 3)))[:, :d]
    if nans and n:
        pos[rng.integers(0, n, max(1, n // 4)), rng.integers(0, d)] = np.nan
    span, far = diagnostics.extent(pos)
    with np.errstate(all="ignore"), warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)      # an all-NaN column
        lo, hi = np.nanmin(pos, axis=0, initial=np.inf), np.nanmax(pos, axis=0, initial=-np.inf)
    want_span = max([0.0] + [h - l for l, h in zip(lo, hi) if l <= h]) if n else 0.0
    want_far = max([0.0] + list(np.abs(lo)) + list(np.abs(hi))) if n else 0.0
    assert span == want_span and far == want_far


def test_shift_origin_moves_everything_that_has_a_position():
    """The central body, walls and the boundary box move with the bodies; velocities and
    energy do not change; a bad delta changes nothing."""
    w = sp.World(dim=2, gravity="central", central_mass=1.0, central_pos=(5.0, 5.0),
                 integrator="leapfrog", dt=1e-2)
    w.add_body(1.0, (6.0, 5.0), (0.0, 1.0), radius=0.1)
    w.add_segment((0.0, 0.0), (10.0, 0.0))
    w.add_plane((0.0, 20.0), (0.0, -1.0))
    w.set_boundary("reflect", (-100.0, -100.0), (100.0, 100.0))
    E0 = w.energy()
    with pytest.raises(ValueError, match="delta"):
        w.shift_origin((1.0, np.nan))
    assert np.array_equal(w.origin, [0.0, 0.0])
    twin = w.copy()
    w.shift_origin((5.0, 5.0))
    assert np.array_equal(w.pos, [[1.0, 0.0]]) and np.array_equal(w.vel, twin.vel)
    assert w.energy() == E0
    assert np.array_equal(w.walls[:, 1:7], [[-5, -5, 0, 5, -5, 0], [-5, 15, 0, 0, -1, 0]])
    assert np.array_equal(w.boundary[1], [-105.0, -105.0])
    w.step(100)
    twin.step(100)
    assert np.allclose(w.pos + w.origin, twin.pos, rtol=0, atol=1e-13)


# ---------------------------------------------------------------- step sizes
def test_tiny_steps_1e9_accumulate_little_round_off():
    """10^6 leapfrog steps of 1e-9 (each moving a body by 1e-9 on an orbit of size 1): the
    round-off of adding tiny increments stays below 1e-12 (measured 2e-16)."""
    w = scenes.kepler(0.5, integrator="leapfrog", dt=1e-9)
    w.step(10 ** 6)
    p, v = sp.kepler_state(1.0, 1.0, 0.5, w.t)
    assert abs(w.t - 1e-3) < 1e-18
    assert np.abs(w.pos[1, :2] - p[:2]).max() < 1e-12
    assert np.abs(w.vel[1, :2] - v[:2]).max() < 1e-11


@pytest.mark.parametrize("integrator, bound", [("gauss_radau", 1e-13),
                                               ("wisdom_holman", 1e-12),
                                               ("wisdom_holman_corrected", 1e-12)])
def test_steps_longer_than_the_period_where_the_method_allows(integrator, bound):
    """dt = 1.3 orbital periods: Gauss-Radau substeps inside its output interval, and
    Wisdom-Holman's Kepler drift is exact for any step, so both stay accurate (measured
    energy errors 9e-16, 1.3e-14, 1.3e-15 over ten such steps)."""
    w = scenes.kepler(0.5, planet_mass=1e-3, integrator=integrator, dt=1.3 * P)
    E0 = w.energy()
    w.watch_energy(bound)
    w.step(10)
    assert abs(w.energy() / E0 - 1) < bound


@pytest.mark.parametrize("integrator", ["leapfrog", "yoshida8", "rk4"])
def test_steps_longer_than_the_period_are_reported_for_fixed_step_methods(integrator):
    """The fixed-step methods sample the force once or a few times per 1.3 orbits: the
    result is meaningless (energy off by 3 to 20 times), and a watched World reports it."""
    w = scenes.kepler(0.5, planet_mass=1e-3, integrator=integrator, dt=1.3 * P)
    w.watch_energy(1e-6)
    with pytest.raises(sp.InstabilityError, match="energy error"):
        w.step(10)


# ---------------------------------------------------------------- many steps
def test_ten_million_leapfrog_steps_keep_the_energy_error_bounded():
    """10^7 leapfrog steps (50 000 orbits of e = 0.5 at P/200): the energy error oscillates
    with the phase but does not grow (measured at most 6.3e-4 in every stretch); the last
    half's worst is no larger than the first half's. RK4, not symplectic, drifts: 4.7e-3 per
    10^6 steps, past this bound in 10^6 steps and 10x that by the end (checked below)."""
    errors = {}
    for integrator, stretches in (("leapfrog", 100), ("rk4", 10)):
        w = scenes.kepler(0.5, planet_mass=1e-3, integrator=integrator, dt=P / 200)
        E0 = w.energy()
        errs = []
        for _ in range(stretches):
            w.step(10 ** 5)
            errs.append(abs(w.energy() / E0 - 1))
        errors[integrator] = np.array(errs)
    lf = errors["leapfrog"]
    assert lf.max() < 1e-3
    assert lf[50:].max() <= 1.05 * lf[:50].max()
    rk = errors["rk4"]                       # 10^6 steps of RK4
    assert np.all(np.diff(rk) > 0) and rk[-1] > 1e-3


# ---------------------------------------------------------------- masses
def test_zero_masses_move_freely_and_exactly():
    """Only test particles: no force anywhere, straight lines to rounding, energy 0 (and
    nothing to watch: a relative energy error has no scale). Measured 1.5e-13 of the
    positions' size after 1 000 Yoshida-4 steps."""
    w = sp.World(dim=3, integrator="yoshida4", dt=0.01)
    rng = np.random.default_rng(1)
    x0, v0 = rng.normal(size=(50, 3)), rng.normal(size=(50, 3))
    w.add_bodies(0.0, x0, v0)
    w.step(1000)
    assert np.abs(w.pos - (x0 + v0 * w.t)).max() < 1e-12 * np.abs(w.pos).max()
    assert np.array_equal(w.vel, v0)
    assert w.energy() == 0.0
    with pytest.raises(ValueError, match="energy is 0"):
        w.watch_energy(1e-6)
    with pytest.raises(ValueError, match="total mass is 0"):
        w.center_of_mass()


@pytest.mark.parametrize("integrator", ["leapfrog", "gauss_radau"])
def test_near_zero_masses_keep_their_scale_invariant_orbit(integrator):
    """A star of mass 1e-300 with a planet at 1e-100: the same orbit as mass 1 at 1, scaled
    (period 2 pi), since r^3 = 1e-300 is still a normal double. The planet's state matches
    the unit orbit's, scaled, to 1e-9 relative; a 5e-324 (subnormal) body beside it pulls
    nothing measurable and makes no NaN."""
    def build(scale):
        w = sp.World(dim=2, integrator=integrator, dt=P / 1000)
        w.add_body(scale ** 3, (0, 0), kind="star")
        w.add_body(0.0, (scale, 0), (0, 1.0 * scale), kind="planet")
        return w
    unit, tiny = build(1.0), build(1e-100)
    tiny.add_body(5e-324, (0, 0.5e-100), (-math.sqrt(2) * 1e-100, 0), kind="moon")
    unit.step(1000)
    tiny.step(1000)
    assert np.abs(tiny.pos[1] / 1e-100 - unit.pos[1]).max() < 1e-9
    assert np.abs(tiny.vel[1] / 1e-100 - unit.vel[1]).max() < 1e-9
    assert np.isfinite(tiny.pos).all()


# ---------------------------------------------------------------- speeds
@pytest.mark.parametrize("v", [1e6, 1e100])
@pytest.mark.parametrize("integrator, steps", [("gauss_radau", 1), ("yoshida6", 2000)])
def test_huge_velocities_fly_by_with_the_right_deflection(v, integrator, steps):
    """A test particle at speed v passes a unit mass at impact parameter 1, from x = -10 to
    10. Its sideways speed is then -(2/v)(10/sqrt(101)) (the straight-line integral; the
    next term is 1e-12 of it at v = 1e6): matched to 1e-9 relative, and x = -10 + v t."""
    w = sp.World(dim=2, integrator=integrator, dt=20 / v / steps)
    w.add_body(1.0, (0, 0), kind="star")
    w.add_body(0.0, (-10.0, 1.0), (v, 0), kind="asteroid")
    w.step(steps)
    exact = -2 / v * 10 / math.sqrt(101)
    assert abs(w.vel[1, 1] / exact - 1) < 1e-9
    assert abs(w.pos[1, 0] - 10.0) < 1e-9


def test_speed_past_the_range_of_doubles_is_reported_naming_the_body():
    """Moving at 1e300 with steps of 1e10, a position overflows to inf: InstabilityError names
    the body (and again on the next step: the state is not silently used)."""
    w = sp.World(dim=2, integrator="leapfrog", dt=1e10)
    w.add_body(1.0, (0, 0), kind="star")
    rock = w.add_body(0.0, (1, 0), (1e300, 0), kind="asteroid")
    with pytest.raises(sp.InstabilityError, match=r"NaN or infinite .* body 1 \(asteroid\)"
                       ) as err:
        w.step(10)
    assert list(err.value.ids) == [rock]
    with pytest.raises(sp.InstabilityError):
        w.step(1)
    w.remove(rock)
    w.step(1)                                  # the rest goes on


def test_a_speed_past_the_range_of_doubles_among_debris_that_follow_ships_is_reported():
    """The same overflow where the collision grid enters debris only in the cells ships
    cover (followers): the ship's infinite box has no cells, the broad phase passes it by,
    and the step reports the body as above (it once failed inside the grid, building a
    map of the ships' cells with a negative size)."""
    rng = np.random.default_rng(1)
    w = sp.World(dim=2, gravity="none", integrator="leapfrog", dt=1e10)
    w.set_collision("ship", "ship", "elastic")
    w.set_collision("ship", "debris", "destroy_both")
    w.add_bodies(1.0, rng.uniform(0.0, 40.0, (6, 2)), radius=0.15, kind="ship")
    w.add_bodies(0.01, rng.uniform(0.0, 40.0, (400, 2)), radius=0.1, kind="debris")
    rock = w.add_body(1.0, (50.0, 50.0), (1e300, 0.0), radius=0.15, kind="ship")
    with pytest.raises(sp.InstabilityError, match=r"NaN or infinite .* \(ship\)") as err:
        w.step(1)
    assert list(err.value.ids) == [rock]


@pytest.mark.filterwarnings("ignore::spacephys.PrecisionWarning")  # its subject
def test_a_floating_origin_is_recorded_and_replays(tmp_path):
    """shift_origin and watch_energy are journaled like every other change: a run that
    follows its planet with the origin replays bit for bit, and a checkpoint keeps the
    origin."""
    path = tmp_path / "far.h5"
    w = _far_kepler(1e15)
    w.watch_energy(None)
    with w.record(path, every=100):
        for _ in range(5):
            w.step(200)
            w.shift_origin(w.pos[1])            # keep the planet at the origin
        w.save(tmp_path / "far_state.h5")
    result = sp.replay(path)
    assert result.ok, result.message
    assert np.array_equal(result.world.origin, w.origin)
    loaded = sp.World.load(tmp_path / "far_state.h5")
    assert np.array_equal(loaded.origin, w.origin) and np.array_equal(loaded.pos, w.pos)


def test_watch_energy_starts_again_after_changes_between_steps():
    """Adding, removing or moving bodies, shifting the origin under a uniform field and moving
    to the centre of mass change the energy on purpose: the watch starts again from the new
    value instead of raising. A real breakdown after such a change is still caught."""
    w = scenes.kepler(0.5, planet_mass=1e-3, integrator="leapfrog", dt=1e-3)
    w.watch_energy(1e-6)
    extra = w.add_body(1e-3, (3.0, 0.0), (0.0, 0.58), kind="planet")
    w.step(10)
    w.set_body(extra, pos=(2.5, 0.0))
    w.step(10)
    w.remove(extra)
    w.step(10)
    w.move_to_center_of_mass()
    w.step(10)
    w.dt = 1.3 * P                                  # then an unresolved step: caught
    with pytest.raises(sp.InstabilityError, match="energy error"):
        w.step(5)
    fall = sp.World(dim=2, gravity="uniform", g=(0.0, -9.81), integrator="leapfrog", dt=0.01)
    fall.add_body(1.0, (0.0, 10.0), (1.0, 0.0))
    fall.watch_energy(1e-9)
    fall.shift_origin((0.0, 100.0))
    fall.step(100)                                   # leapfrog is exact in a uniform field
    assert fall.pos[0, 1] == pytest.approx(10.0 - 100.0 - 0.5 * 9.81 * 1.0, abs=1e-9)


def test_advance_books_the_frame_when_its_steps_went_bad():
    """advance() whose steps were all taken but ended non-finite raises, with the frame time
    booked (the accumulator is not left holding time already stepped)."""
    w = sp.World(dim=2, integrator="leapfrog", dt=1e10)
    w.add_body(1.0, (0, 0), kind="star")
    w.add_body(0.0, (1, 0), (1e300, 0), kind="asteroid")
    with pytest.raises(sp.InstabilityError):
        w.advance(3e10)
    assert w.t == 3e10 and w.state()["world"]["accumulator"] < w.dt


def test_a_launch_before_a_shift_is_reported_where_the_missile_is():
    """A missile launched, then the origin shifted before the next step: the launch event
    gives the missile's position in the new coordinates."""
    w = sp.World(dim=2, dt=0.01)
    ship = w.add_ship(sp.ShipSpec(dry_mass=10.0), (1000.0, 0.0), (0.0, 0.0))
    missile = w.launch(ship, sp.MissileSpec(mass=1.0, launch_speed=1.0))
    launched_at = w.get(missile).pos.copy()
    w.shift_origin((1000.0, 0.0))
    w.step(1)
    launch = [k for k, name in sp.EVENT_KINDS.items() if name == "launch"][0]
    ev = w.events[w.events["kind"] == launch][0]
    assert ev["a"] == missile
    assert (ev["x"], ev["y"]) == (launched_at[0] - 1000.0, launched_at[1])
