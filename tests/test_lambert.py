"""lambert (Lambert's problem, after Izzo 2015): the answer flown by the library's own
Gauss-Radau integrator arrives at r2, for random geometries, both directions, short
(hyperbolic) and long (elliptic) flights, 1 and 2 revolutions on both branches, 2D, transfer
angles near 0 and 180 degrees; the flight time read back from Kepler's equation
(orbits.py); the sign of h_z; the minimum time of a multi-revolution transfer; bad input."""
import math
import re
import time

import numpy as np
import pytest

import spacephys as sp
import spacephys.lambert_problem as lam_module
from spacephys.lambert_problem import lambert

# Gauss-Radau at tolerance 1e-12 flies these to within 2e-13 (the exact flight of the same
# velocities, in 50-digit arithmetic, arrives as close); each test's comment gives its
# measured worst. The issue asks for 1e-9; ARRIVAL is what a correct solver reaches with
# room for the integrator, and what a wrong coefficient in T(x) breaks (by 1e-6 and more).
ARRIVAL = 1e-12


def _fly(r1, v1, tof, mu):
    """Position and velocity after tof from (r1, v1) about a fixed mass with G M = mu."""
    w = sp.World(dim=len(r1), G=1.0, gravity="central", central_mass=mu,
                 integrator="gauss_radau", dt=tof, tolerance=1e-12)
    w.add_body(0.0, r1, v1)
    w.step(1)
    return np.array(w.pos[0]), np.array(w.vel[0])


def _arrival(r1, r2, tof, mu, **kw):
    """(relative position miss, relative velocity miss, v1, v2) of lambert's answer."""
    v1, v2 = lambert(r1, r2, tof, mu, **kw)
    assert v1.shape == v2.shape == np.shape(r1) and v1.dtype == np.float64
    p, v = _fly(r1, v1, tof, mu)
    return (np.linalg.norm(p - r2) / np.linalg.norm(r2),
            np.linalg.norm(v - v2) / np.linalg.norm(v2), v1, v2)


def _natural_time(r1, r2, mu):
    """sqrt(s^3 / 2 mu), Izzo's unit of time: a flight of ~1 of it is near the parabola."""
    s = 0.5 * (np.linalg.norm(r1) + np.linalg.norm(r2) + np.linalg.norm(np.subtract(r2, r1)))
    return math.sqrt(s ** 3 / (2.0 * mu))


def _h_z(r, v):
    return r[0] * v[1] - r[1] * v[0]


# ----------------------------------------------------------------------------- arrival

def test_random_transfers_arrive_under_gauss_radau():
    """24 random 3D geometries, each direction, flights from 0.05 to 6 natural times:
    hyperbolic through elliptic. Measured worst: 6.0e-14 (position or velocity)."""
    rng = np.random.default_rng(1969)
    worst, energies = 0.0, []
    for i in range(24):
        r1 = rng.normal(size=3) * rng.uniform(0.5, 2.0)
        r2 = rng.normal(size=3) * rng.uniform(0.5, 2.0)
        mu = 10.0 ** rng.uniform(-1, 1)
        tof = _natural_time(r1, r2, mu) * [0.05, 0.3, 1.0, 3.0][i % 4] * rng.uniform(1, 2)
        for prograde in (True, False):
            dr, dv, v1, _ = _arrival(r1, r2, tof, mu, prograde=prograde)
            worst = max(worst, dr, dv)
            energies.append(0.5 * v1 @ v1 - mu / np.linalg.norm(r1))
            assert (_h_z(r1, v1) > 0) == prograde
    assert worst < ARRIVAL, worst
    assert min(energies) < 0 < max(energies)          # ellipses and hyperbolas both flown


@pytest.mark.parametrize("revolutions", [1, 2])
def test_revolutions_arrive_on_both_branches(revolutions):
    """N full turns: both branches arrive; each orbit's period P has N P < tof < (N + 1) P;
    the left branch is the one of smaller semi-major axis. Measured worst: 1 turn 1.1e-13,
    2 turns 1.5e-13."""
    rng = np.random.default_rng(100 + revolutions)
    worst = 0.0
    for _ in range(4):
        r1, r2 = rng.normal(size=3), rng.normal(size=3)
        mu = 10.0 ** rng.uniform(-1, 1)
        tof = _natural_time(r1, r2, mu) * (4.0 + 8.0 * revolutions) * rng.uniform(1, 1.5)
        prograde = bool(rng.integers(2))
        axes = {}
        for branch in ("left", "right"):
            dr, dv, v1, _ = _arrival(r1, r2, tof, mu, prograde=prograde,
                                     revolutions=revolutions, branch=branch)
            worst = max(worst, dr, dv)
            orbit = sp.state_to_elements(mu, r1, v1)
            assert revolutions * orbit.period < tof < (revolutions + 1) * orbit.period
            assert (_h_z(r1, v1) > 0) == prograde
            axes[branch] = orbit.a
        assert axes["left"] < axes["right"]
    assert worst < ARRIVAL, worst


def test_2d_positions_give_2d_velocities_and_arrive():
    """2D in, 2D out, in a 2D World; exactly 180 degrees apart is fine in 2D (the plane is
    known), both ways round. Measured worst: 1.4e-13."""
    worst = 0.0
    cases = [((1.0, 0.0), (0.2, 1.7), 1.5), ((1.0, 0.5), (-3.0, 0.4), 0.8),
             ((1.0, 0.0), (-2.0, 0.0), 3.0), ((0.0, 2.0), (0.0, -0.5), 12.0)]
    for r1, r2, tof in cases:
        r1, r2 = np.array(r1), np.array(r2)
        for prograde in (True, False):
            dr, dv, v1, v2 = _arrival(r1, r2, tof, 2.0, prograde=prograde)
            assert v1.shape == v2.shape == (2,)
            assert (_h_z(r1, v1) > 0) == prograde
            worst = max(worst, dr, dv)
        dr, dv, _, _ = _arrival(r1, r2, 40.0, 2.0, revolutions=1, branch="right")
        worst = max(worst, dr, dv)
    assert worst < ARRIVAL, worst


@pytest.mark.parametrize("dim", [2, 3])
def test_transfer_angles_near_0_and_near_180_degrees(dim):
    """0.01 degrees between equal radii: a short hop (prograde), or nearly a full turn, 359.99
    degrees (retrograde), in 0.7 and 1.5 times the circular orbit's time for that angle;
    179.9 degrees (and the other way, 180.1) in 0.1, 2 and 6 natural times. Between unequal
    radii a transfer near 0 or 360 degrees is all but radial, through or next to the centre,
    where the integrator cannot follow: not flown here. Measured worst: 2D 2.2e-14, 3D
    1.4e-14."""
    worst = 0.0
    th, r, mu = math.radians(0.01), 1.2, 1.0
    r1 = np.array([r, 0.0, 0.0])[:dim]
    r2 = np.array([math.cos(th), math.sin(th), 0.3 * math.sin(th)])
    r2 = (r * r2 / np.linalg.norm(r2))[:dim]
    angle = math.acos(r1 @ r2 / r ** 2) if dim == 3 else th
    for prograde, sweep in ((True, angle), (False, 2.0 * math.pi - angle)):
        for factor in (0.7, 1.5):
            tof = factor * sweep * math.sqrt(r ** 3 / mu)
            dr, dv, v1, _ = _arrival(r1, r2, tof, mu, prograde=prograde)
            assert (_h_z(r1, v1) > 0) == prograde
            worst = max(worst, dr, dv)
    th = math.radians(179.9)
    r1 = np.array([1.2, 0.0, 0.0])[:dim]
    r2 = 0.9 * np.array([math.cos(th), math.sin(th), 0.3 * math.sin(th)])[:dim]
    for scale in (0.1, 2.0, 6.0):
        tof = scale * _natural_time(r1, r2, mu)
        for prograde in (True, False):
            dr, dv, v1, _ = _arrival(r1, r2, tof, mu, prograde=prograde)
            assert (_h_z(r1, v1) > 0) == prograde
            worst = max(worst, dr, dv)
    assert worst < ARRIVAL, worst


# ----------------------------------------------------------------------------- Kepler

def _kepler_flight_time(mu, r1, v1, r2, v2, revolutions):
    """The time from (r1, v1) to (r2, v2) on one conic, from the mean anomalies."""
    a, b = sp.state_to_elements(mu, r1, v1), sp.state_to_elements(mu, r2, v2)
    if a.e < 1.0:
        n = 2.0 * math.pi / a.period
        return ((b.M - a.M) % (2.0 * math.pi) + 2.0 * math.pi * revolutions) / n
    return (b.M - a.M) / math.sqrt(mu / (-a.a) ** 3)


def test_flight_time_read_back_from_keplers_equation():
    """orbits.py's mean anomalies at both ends give back tof, with no integrator in between:
    the time-of-flight residual. Measured worst: ellipses 2.2e-14 relative; hyperbolas
    9e-11, which is orbits.py's M = e sinh F - F losing digits near e = 1 (the exact
    flight of the same answer, in 50-digit arithmetic, arrives within 3e-14). And both ends
    lie on one orbit: the same a and e from (r1, v1) and from (r2, v2)."""
    rng = np.random.default_rng(7)
    worst = {True: 0.0, False: 0.0}
    for i in range(60):
        r1, r2 = rng.normal(size=3), rng.normal(size=3)
        mu = 10.0 ** rng.uniform(-2, 2)
        n = i % 3
        # T(x = 0) = T00 + n pi < (n + 1) pi natural times: above the minimum for n turns
        least = (n + 1) * math.pi * 1.001 if n else 10.0 ** -1.5
        tof = _natural_time(r1, r2, mu) * least * 10.0 ** rng.uniform(0, 1.5)
        kw = dict(prograde=bool(rng.integers(2)), revolutions=n,
                  branch=("left", "right")[i % 2])
        v1, v2 = lambert(r1, r2, tof, mu, **kw)
        a, b = sp.state_to_elements(mu, r1, v1), sp.state_to_elements(mu, r2, v2)
        assert a.a == pytest.approx(b.a, rel=1e-12) and a.e == pytest.approx(b.e, abs=1e-12)
        residual = abs(_kepler_flight_time(mu, r1, v1, r2, v2, n) / tof - 1)
        worst[a.e < 1] = max(worst[a.e < 1], residual)
    assert worst[True] < 1e-12 and worst[False] < 1e-9, worst
    assert worst[True] > 0.0 and worst[False] > 0.0               # both kinds were met


# ----------------------------------------------------------------------------- minimum time

@pytest.mark.parametrize("revolutions", [1, 2, 5])
def test_below_the_minimum_time_for_n_revolutions_raises_naming_tof(revolutions):
    r1, r2, mu = np.array([1.0, 0.1, 0.0]), np.array([-0.4, 1.3, 0.2]), 1.3
    short = 0.5 * _natural_time(r1, r2, mu)
    with pytest.raises(ValueError, match=rf"tof = .*too short for {revolutions} revolution"):
        lambert(r1, r2, short, mu, revolutions=revolutions)
    with pytest.raises(ValueError) as info:
        lambert(r1, r2, short, mu, revolutions=revolutions)
    tmin = float(re.search(r"the minimum is (\S+)$", str(info.value)).group(1))
    # the minimum it names is the minimum: just below it raises, just above it flies, and
    # there the two branches meet (they part as sqrt(tof - tmin))
    with pytest.raises(ValueError, match="tof"):
        lambert(r1, r2, tmin * (1 - 1e-9), mu, revolutions=revolutions)
    left = lambert(r1, r2, tmin * (1 + 1e-12), mu, revolutions=revolutions, branch="left")[0]
    right = lambert(r1, r2, tmin * (1 + 1e-12), mu, revolutions=revolutions, branch="right")[0]
    assert np.linalg.norm(left - right) < 1e-4 * np.linalg.norm(left)
    wide = [lambert(r1, r2, tmin * 1.01, mu, revolutions=revolutions, branch=b)[0]
            for b in ("left", "right")]
    assert np.linalg.norm(wide[0] - wide[1]) > 1e-2 * np.linalg.norm(wide[0])
    dr, dv, _, _ = _arrival(r1, r2, tmin * (1 + 1e-12), mu, revolutions=revolutions)
    assert max(dr, dv) < ARRIVAL                      # measured 7e-15 to 5e-14


# ----------------------------------------------------------------------------- geometry

def test_prograde_picks_the_way_round_and_keeps_the_plane():
    """Flipping prograde keeps the plane of r1 and r2 and reverses h; for r1 x r2 pointing
    up the prograde transfer is the short way (under 180 degrees), else the long way."""
    r1, r2 = np.array([1.0, 0.0, 0.2]), np.array([0.1, 1.0, -0.3])
    normal = np.cross(r1, r2)
    for prograde in (True, False):
        v1, _ = lambert(r1, r2, 1.0, 1.0, prograde=prograde)
        h = np.cross(r1, v1)
        sin_tilt = np.linalg.norm(np.cross(h, normal)) / np.linalg.norm(h) / np.linalg.norm(normal)
        assert sin_tilt < 1e-14
        assert (h @ normal > 0) == (prograde == (normal[2] > 0))


def test_collinear_positions_raise():
    with pytest.raises(ValueError, match="180 degrees apart.*plane"):
        lambert([1.0, 2.0, 3.0], [-2.0, -4.0, -6.0], 1.0, 1.0)
    for r2 in ([2.0, 4.0, 6.0], [1.0, 2.0, 3.0]):
        with pytest.raises(ValueError, match="point the same way"):
            lambert([1.0, 2.0, 3.0], r2, 1.0, 1.0)
    with pytest.raises(ValueError, match="point the same way"):
        lambert([1.0, 0.0], [3.0, 0.0], 1.0, 1.0)


def test_flights_beyond_double_precision_are_refused():
    with pytest.raises(ValueError, match="tof = .*double precision"):
        lambert([1.0, 0.0], [0.0, 1.0], 1e30, 1.0)
    with pytest.raises(ValueError, match="tof = .*double precision"):
        lambert([1.0, 0.0], [0.0, 1.0], 1e-40, 1.0)


# ----------------------------------------------------------------------------- bad input

R1, R2 = [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]


@pytest.mark.parametrize("kwargs, match", [
    (dict(mu=0.0), r"mu = 0.0: must be > 0"),
    (dict(mu=-1.0), r"mu = -1.0"),
    (dict(mu=float("nan")), r"mu = nan"),
    (dict(mu="1"), r"mu = '1'"),
    (dict(tof=0.0), r"tof = 0.0: must be > 0"),
    (dict(tof=-2.0), r"tof = -2.0"),
    (dict(tof=float("nan")), r"tof = nan"),
    (dict(tof=float("inf")), r"tof = inf"),
    (dict(r1=[0.0, 0.0, 0.0]), r"r1 = \[0.0, 0.0, 0.0\]: must not be zero"),
    (dict(r2=[0.0, 0.0]), r"r2 = \[0.0, 0.0\]: must not be zero"),
    (dict(r1=[1.0, float("nan"), 0.0]), r"r1\[1\] = nan"),
    (dict(r2=[1.0, 2.0, float("inf")]), r"r2\[2\] = inf"),
    (dict(r1=[1.0, 2.0, 3.0, 4.0]), r"r1 has shape \(4,\)"),
    (dict(r1=[[1.0, 2.0, 3.0]]), r"r1 has shape \(1, 3\)"),
    (dict(r1=5.0), r"r1 has shape \(\)"),
    (dict(r2=[1.0, 2.0]), r"r2 has shape \(2,\), expected \(3,\)"),
    (dict(r1=["a", "b", "c"]), r"r1 = "),
    (dict(revolutions=-1), r"revolutions = -1: must be >= 0"),
    (dict(revolutions=1.5), r"revolutions = 1.5: expected an integer"),
    (dict(revolutions=True), r"revolutions = True"),
    (dict(branch="middle"), r"branch = 'middle'"),
    (dict(branch=None), r"branch = None"),
    (dict(prograde="yes"), r"prograde = 'yes'"),
    (dict(prograde=1), r"prograde = 1"),
])
def test_bad_input_names_the_field_and_the_value(kwargs, match):
    args = dict(r1=R1, r2=R2, tof=1.0, mu=1.0)
    args.update(kwargs)
    r1, r2, tof, mu = args.pop("r1"), args.pop("r2"), args.pop("tof"), args.pop("mu")
    with pytest.raises(ValueError, match=match):
        lambert(r1, r2, tof, mu, **args)


def test_numpy_scalars_and_integer_input_are_accepted():
    v1, v2 = lambert(np.array([1, 0, 0]), (0, 2, 0), np.float64(1.5), np.int64(3),
                     revolutions=np.int64(0))
    w1, w2 = lambert([1.0, 0.0, 0.0], [0.0, 2.0, 0.0], 1.5, 3.0)
    assert np.array_equal(v1, w1) and np.array_equal(v2, w2)


# ----------------------------------------------------------------------------- cost

def test_householder_converges_in_a_few_evaluations(monkeypatch):
    """Izzo's initial guesses and Householder steps: at most 5 evaluations of T(x) for no
    revolution (measured: mean 3.08, at most 5, over these 200); the minimum-time search
    and one branch at most 10 (measured 8 each). A wrong derivative still converges (the
    bracket catches it) but slowly, and shows here."""
    counts, original = [0], lam_module._tof

    def counted(*args):
        counts[0] += 1
        return original(*args)

    monkeypatch.setattr(lam_module, "_tof", counted)
    rng = np.random.default_rng(3)
    single, multi = [], []
    for i in range(200):
        r1, r2 = rng.normal(size=3), rng.normal(size=3)
        t = _natural_time(r1, r2, 1.0)
        counts[0] = 0
        lambert(r1, r2, t * 10.0 ** rng.uniform(-2, 1.5), 1.0, prograde=bool(i % 2))
        single.append(counts[0])
        if i % 10 == 0:
            counts[0] = 0
            lambert(r1, r2, 40 * t, 1.0, revolutions=2, branch=("left", "right")[i % 20 // 10])
            multi.append(counts[0])
    assert max(single) <= 5 and np.mean(single) <= 3.3, (max(single), np.mean(single))
    assert max(multi) <= 10, multi


def test_a_call_takes_well_under_a_millisecond():
    r1, r2 = np.array([1.0, 0.2, 0.1]), np.array([-0.3, 1.4, -0.2])
    lambert(r1, r2, 3.0, 1.0)
    start = time.perf_counter()
    for _ in range(200):
        lambert(r1, r2, 3.0, 1.0)
        lambert(r1, r2, 25.0, 1.0, revolutions=2, branch="right")
    per_call = (time.perf_counter() - start) / 400
    assert per_call < 1e-3, per_call            # measured ~0.1 ms
