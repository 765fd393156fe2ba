"""The force contract (kernels/forces.py) and the energy kernels against plain numpy, on every
gravity model and code path."""
import math
import sys

import numpy as np
import pytest
from reference import direct_accelerations, direct_potential

from spacephys._jit import PARALLEL_MIN_PAIRS
from spacephys.kernels import diagnostics, forces, gravity, pairs


def _scene(rng, n, frac_pulling):
    pos = rng.normal(size=(n, 3))
    mass = rng.uniform(0.1, 2.0, n)
    pulls = rng.random(n) < frac_pulling
    mass[rng.random(n) < 0.2] = 0.0        # some test particles among the passive ones
    pulls &= mass > 0
    return pos, mass, pulls


def _model(model, ns, G=1.7, eps2=0.0, field=np.zeros(3), field_mass=0.0):
    """The gravity table of `model` (a name) for ns sources, as spacephys/forces.py builds it."""
    if model == "direct":
        return gravity.Direct(G, eps2, np.empty((4, ns)),
                              np.empty((3, ns)) if ns >= pairs.PAIRS_FROM else None)
    if model == "central":
        return gravity.Central(G, eps2, field, field_mass, np.empty((4, 1)))
    if model == "uniform":
        return gravity.Uniform(field)
    return None


def _run(pos, mass, pulls, model, G=1.7, eps2=0.0, field=np.zeros(3), field_mass=0.0,
         still=np.zeros(0, np.int64), threads=None):
    src = np.flatnonzero(pulls).astype(np.int64)
    passive = np.flatnonzero(~pulls).astype(np.int64)
    n = len(mass)
    out = np.full((n, 3), np.nan)
    table = _model(model, src.size, G, eps2, field, field_mass)
    f = forces.make(mass, np.arange(n, dtype=np.int64), gravity=table, src=src,
                    passive=passive, still=still, threads=threads)
    forces.accelerations_of(f, 0.0, pos, np.zeros_like(pos), out, np.arange(n, dtype=np.int64),
                            False)
    energy = gravity.potential(table, pos, mass, src, passive)
    return out, energy


# n = 40 stays on the serial path, n = 400 crosses PARALLEL_MIN_PAIRS onto threads, n = 900
# has several chunks of pairs.CHUNK targets on each thread and ~430 sources, whose pairs are
# taken once (pairs.PAIRS_FROM: rounds of tiles on threads)
@pytest.mark.parametrize("n", [40, 400, 900])
@pytest.mark.parametrize("eps", [0.0, 0.05])
def test_direct_matches_numpy(rng, n, eps):
    assert (40 * 40 < PARALLEL_MIN_PAIRS) and (400 * 200 > PARALLEL_MIN_PAIRS)
    pos, mass, pulls = _scene(rng, n, 0.6)
    threads = np.array([PARALLEL_MIN_PAIRS], np.int64) if n > 40 else None
    acc, energy = _run(pos, mass, pulls, "direct", eps2=eps * eps, threads=threads)
    ref = direct_accelerations(pos, mass, pulls, 1.7, eps * eps)
    assert np.max(np.abs(acc - ref)) <= 1e-12 * np.max(np.abs(ref))
    ref_energy = direct_potential(pos, mass, pulls, 1.7, eps * eps)
    assert abs(energy - ref_energy) <= 1e-12 * abs(ref_energy)


@pytest.mark.parametrize("dtype", [np.float64, np.float32])
@pytest.mark.parametrize("nt, ns", [(1, 1), (1, 77), (3, 200), (64, 17), (100, 257)])
def test_each_points_sum_runs_in_source_order(rng, dtype, nt, ns):
    """pairs.pull_points: each point's sum is the plain sum over the sources in their order,
    term by term as written, bit for bit (no partial sums by the vector width, no fused
    multiply-add: the same bits on every x86-64 CPU); a coincident source pulls nothing.
    pairs.pull_point, one point's sum (its terms side by side in blocks), the same bits."""
    s = np.zeros((4, ns), dtype)
    s[:3] = rng.normal(size=(3, ns))
    s[3] = rng.uniform(0.1, 2.0, ns)
    pts = rng.normal(size=(3, nt)).astype(dtype)
    pts[:, 0] = s[:3, -1]                                  # a point on a source
    eps2 = dtype(0.0)
    acc = np.zeros((3, nt), dtype)
    pairs.pull_points(pts[0], pts[1], pts[2], nt, s, ns, eps2, acc[0], acc[1], acc[2])
    for t in range(nt):
        want = [dtype(0.0)] * 3
        for j in range(ns):
            d = [s[c, j] - pts[c, t] for c in range(3)]
            r2 = d[0] * d[0] + d[1] * d[1] + d[2] * d[2] + eps2
            d3 = r2 * np.sqrt(r2)
            w = s[3, j] / d3 if d3 > 0 else dtype(0.0)
            want = [want[c] + w * d[c] for c in range(3)]
        want = [dtype(v).tobytes() for v in want]
        assert [a.tobytes() for a in acc[:, t]] == want, t
        one = pairs.pull_point(pts[0, t], pts[1, t], pts[2, t], s, ns, eps2)
        assert [dtype(v).tobytes() for v in one] == want, t


@pytest.mark.parametrize("nt", [2, 4, 5, 6, 7, 13, 64, 70])
def test_a_chunks_points_get_their_own_sums_whatever_their_number(rng, nt):
    """gravity._pull_each: each target's pull is G times its plain sum in source order, bit
    for bit, and no other row is written, however many targets the last chunk holds (a
    last vector of 5-7 is filled up with points that are computed and dropped)."""
    n, ns = nt + 3, 9
    pos = rng.normal(size=(n, 3))
    s = np.zeros((4, ns))
    s[:3] = rng.normal(size=(3, ns))
    s[3] = rng.uniform(0.1, 2.0, ns)
    targets = np.arange(1, nt + 1, dtype=np.int64)      # rows 0, nt + 1.. are not targets
    out = np.full((n, 3), 7.0)
    G, eps2 = 1.3, 0.01
    gravity._pull_each(targets, pos, s, G, eps2, out)
    for k in range(n):
        if k not in targets:
            assert (out[k] == 7.0).all(), k
            continue
        want = [0.0] * 3
        for j in range(ns):
            d = [s[c, j] - pos[k, c] for c in range(3)]
            r2 = d[0] * d[0] + d[1] * d[1] + d[2] * d[2] + eps2
            w = s[3, j] / (r2 * np.sqrt(r2))
            want = [want[c] + w * d[c] for c in range(3)]
        assert out[k].tobytes() == np.array([G * v for v in want]).tobytes(), k


@pytest.mark.parametrize("nb", range(1, 13))
def test_the_rounds_of_block_pairs_take_each_pair_once(nb):
    """pairs.round_pair: every pair of distinct blocks in exactly one round, and no block
    twice in a round (the tiles of a round run on threads side by side)."""
    seen = []
    rounds = nb + nb % 2 - 1
    for r in range(rounds):
        used = []
        for k in range((nb + nb % 2) // 2):
            i, j = pairs.round_pair(r, k, nb)
            if i >= 0:
                assert 0 <= i < j < nb
                used += [i, j]
                seen.append((i, j))
        assert len(used) == len(set(used)), (nb, r, used)
    assert sorted(seen) == [(i, j) for i in range(nb) for j in range(i + 1, nb)]


def _fma(a, b, c):
    """a * b + c rounded once, in Python (math.fma is 3.13's): the exact value as a ratio of
    integers, divided once (Python rounds an integer division correctly)."""
    (na, da), (nb, db), (nc, dc) = (v.as_integer_ratio() for v in (a, b, c))
    num = na * nb * dc + nc * da * db
    return num / (da * db * dc) if num else a * b + c


def _pairs_as_written(s, ns, eps2):
    """pairs.pull_pairs in plain Python floats, operation by operation in the order its
    source fixes: the blocks' own tiles, then the rounds; in a tile, sweep r pairs lane l
    with body (l + r) mod q of the other block (within a block, sweeps r < q / 2 and half of
    sweep q / 2), the lanes in groups and each group's sweeps in strides of pairs.GROUP (see
    kernels/pairs.py)."""
    nb, B = pairs.blocks(ns)
    sums = [[0.0] * ns for _ in range(3)]
    x = [[float(v) for v in s[c, :ns]] for c in range(4)]

    def inverse_cube(d):
        r2 = _fma(d[2], d[2], _fma(d[1], d[1], d[0] * d[0])) + eps2
        d3 = r2 * math.sqrt(r2)
        return 1.0 / d3 if d3 > 0.0 else 0.0

    def both_ways(lane, row, i0, j0, q, l, k):
        j = j0 + k % q
        d = [x[c][j] - x[c][i0 + l] for c in range(3)]
        inv = inverse_cube(d)
        wj, wi = x[3][j] * inv, x[3][i0 + l] * inv
        for c in range(3):
            lane[c][l] = _fma(wj, d[c], lane[c][l])
        for c in range(3):
            row[c][k] = _fma(-wi, d[c], row[c][k])

    def tile(I, J):
        if min(B, ns - I * B) > min(B, ns - J * B):
            I, J = J, I
        i0, j0 = I * B, J * B
        p, q = min(B, ns - i0), min(B, ns - j0)
        lane = [[0.0] * p for _ in range(3)]
        row = [[0.0] * (2 * q) for _ in range(3)]
        def strip(l0, l1, first, last):         # lanes l0..l1-1, as pairs._strip
            for c in range(G):
                for r in range(first + c, last, G):
                    for l in range(l0, l1):
                        both_ways(lane, row, i0, j0, q, l, l + r)

        first, last = (1, (q + 1) // 2) if I == J else (0, q)
        G = pairs.GROUP
        groups = p // G
        for g in range(groups):                   # a group's lanes: the same order
            strip(g * G, (g + 1) * G, first, last)
        strip(groups * G, p, first, last)
        if I == J and q % 2 == 0:
            strip(0, q // 2, q // 2, q // 2 + 1)
        for k in range(q):
            for c in range(3):
                sums[c][j0 + k] += row[c][k] + row[c][k + q]
        for l in range(p):
            for c in range(3):
                sums[c][i0 + l] += lane[c][l]

    for b in range(nb):
        tile(b, b)
    R, T = pairs.rounds(nb)
    for r in range(R):
        for k in range(T):
            i, j = pairs.round_pair(r, k, nb)
            if i >= 0:
                tile(i, j)
    return np.array(sums)


@pytest.mark.parametrize("ns", [2, 3, 6, 130, 300, 517])
def test_the_pairs_once_run_in_the_order_their_source_fixes(rng, ns):
    """pairs.pull_pairs, each pair once in tiles: bit for bit the plain-Python sums in the
    order kernels/pairs.py writes them (no partial sums by the vector width, multiply-adds
    fused exactly where the source fuses them), on one thread or on threads; to rounding
    the one-sided sums; a coincident pair pulls nothing. Blocks of even and odd size, fewer
    bodies than a group of lanes (2, 3, 6), and 300 and 517 bodies in blocks of unequal size
    (a short last one)."""
    s = np.zeros((4, ns))
    s[:3] = rng.normal(size=(3, ns))
    s[3] = rng.uniform(0.1, 2.0, ns)
    if ns > 2:
        s[:3, -1] = s[:3, 0]
    eps2 = 0.0 if ns != 300 else 1e-4
    sums, threaded = np.zeros((3, ns)), np.zeros((3, ns))
    pairs.pull_pairs(s, sums, ns, eps2)
    pairs.pull_pairs_threaded(s, threaded, ns, eps2)
    assert sums.tobytes() == _pairs_as_written(s, ns, eps2).tobytes()
    assert threaded.tobytes() == sums.tobytes()
    ref = np.zeros((3, ns))
    pairs.pull_points(s[0].copy(), s[1].copy(), s[2].copy(), ns, s, ns, eps2, *ref)
    assert np.all(np.isfinite(sums))
    assert np.max(np.abs(sums - ref)) <= 1e-13 * np.max(np.abs(ref))


def test_every_code_path_of_the_forces_gives_the_same_bits(rng):
    """accelerations on threads, on the calling thread in a table that may thread, and in a
    table without threads (its kernels compiled without the threaded loops): one result bit
    for bit; the same for the sources when they alone are the targets, or any of them."""
    pos, mass, pulls = _scene(rng, 1000, 0.6)
    src = np.flatnonzero(pulls).astype(np.int64)
    assert src.size >= pairs.PAIRS_FROM                   # the pairs once, in rounds
    n = len(mass)
    everyone = np.arange(n, dtype=np.int64)
    results = []
    for threads in (np.array([1], np.int64), np.array([2**62], np.int64), None):
        f = forces.make(mass, everyone, gravity=_model("direct", src.size, G=1.3, eps2=1e-4),
                        src=src, passive=np.flatnonzero(~pulls), still=np.zeros(0, np.int64),
                        threads=threads)
        out = np.full((n, 3), np.nan)
        forces.accelerations_of(f, 0.0, pos, pos * 0, out, everyone, False)
        results.append(out)
    assert n > 4 * pairs.CHUNK                            # several chunks of targets
    for out in results[1:]:
        assert np.array_equal(out, results[0])
    # the sources alone as targets (an integrator moving only them): the same bits
    out = np.full((n, 3), np.nan)
    forces.accelerations_of(f, 0.0, pos, pos * 0, out, src, False)     # the table's own array
    assert np.array_equal(out[src], results[0][src])
    # and a subset of the targets (one-sided sums, in source order) agrees to rounding
    out = np.full((n, 3), np.nan)
    some = src[::2]
    forces.accelerations_of(f, 0.0, pos, pos * 0, out, some, False)
    scale = np.abs(results[0][some]).max(axis=1, keepdims=True)
    assert np.all(np.abs(out[some] - results[0][some]) <= 1e-13 * scale)
    assert not np.array_equal(out[some], results[0][some])     # it took the other path


def test_passive_bodies_feel_but_do_not_pull(rng):
    pos, mass, _ = _scene(rng, 50, 1.0)
    pulls = np.zeros(50, bool)
    pulls[:10] = True
    acc, _ = _run(pos, mass, pulls, "direct")
    # the pulling bodies' accelerations are those of a scene without the passive ones
    alone, _ = _run(pos[:10], mass[:10], pulls[:10], "direct")
    assert np.array_equal(acc[:10], alone)
    assert np.all(np.abs(acc[10:]) > 0)


def test_coincident_bodies_exert_no_force_and_stay_finite():
    pos = np.array([[1.0, 2.0, 3.0], [1.0, 2.0, 3.0], [4.0, 2.0, 3.0]])
    mass = np.array([1.0, 2.0, 3.0])
    acc, energy = _run(pos, mass, np.ones(3, bool), "direct", G=1.0)
    # bodies 0 and 1 feel only body 2 (distance 3): G m2 / 9 along +x
    np.testing.assert_allclose(acc[0], [3.0 / 9.0, 0, 0], rtol=1e-15)
    np.testing.assert_allclose(acc[1], [3.0 / 9.0, 0, 0], rtol=1e-15)
    np.testing.assert_allclose(acc[2], [-3.0 / 9.0, 0, 0], rtol=1e-15)
    assert energy == pytest.approx(-(1.0 * 3.0 + 2.0 * 3.0) / 3.0, rel=1e-15)


def test_softening_is_plummer():
    pos = np.array([[0.0, 0.0, 0.0], [0.3, 0.4, 0.0]])     # |d| = 0.5
    mass = np.array([2.0, 0.0])
    acc, _ = _run(pos, mass, mass > 0, "direct", G=1.0, eps2=0.12 ** 2)
    expected = -2.0 * pos[1] / (0.25 + 0.0144) ** 1.5
    np.testing.assert_allclose(acc[1], expected, rtol=1e-14)


@pytest.mark.parametrize("n", [30, 20000])
def test_central_matches_numpy(rng, n):
    pos, mass, pulls = _scene(rng, n, 0.5)
    centre = np.array([0.3, -0.2, 0.1])
    acc, energy = _run(pos, mass, pulls, "central", G=2.0, eps2=1e-4, field=centre, field_mass=5.0)
    # a fixed body: every body feels it the same way, whatever it pulls itself
    both = np.vstack([centre, pos])
    m = np.concatenate([[5.0], np.zeros(n)])
    ref = direct_accelerations(both, m, np.arange(n + 1) == 0, 2.0, 1e-4)[1:]
    assert np.max(np.abs(acc - ref)) <= 1e-12 * np.max(np.abs(ref))
    r = np.sqrt(((pos - centre) ** 2).sum(axis=1) + 1e-4)
    assert energy == pytest.approx(-2.0 * 5.0 * (mass / r).sum(), rel=1e-12)


def test_uniform_and_none(rng):
    pos, mass, pulls = _scene(rng, 20, 0.5)
    g = np.array([0.0, -9.81, 0.5])
    acc, energy = _run(pos, mass, pulls, "uniform", field=g)
    assert np.array_equal(acc, np.broadcast_to(g, acc.shape))
    assert energy == pytest.approx(-(mass * (pos @ g)).sum(), rel=1e-13)
    acc, energy = _run(pos, mass, pulls, None)
    assert np.array_equal(acc, np.zeros_like(acc)) and energy == 0.0


def test_kinetic_energy_is_compensated():
    # 1e6 terms of 1e-16 after one of 1.0: each is below half an ulp of 1.0, so a plain running
    # sum (or one whose compensation fastmath optimised away) returns exactly 1.0
    vel = np.zeros((1_000_001, 3))
    vel[:, 0] = 1.0
    mass = np.full(1_000_001, 2e-16)
    mass[0] = 2.0
    assert diagnostics.kinetic_energy(vel, mass) == 1.0 + 1e-10


def test_potential_energy_is_compensated():
    # one pair at distance 1 (-1) and a million terms of ~5e-18, each below half an ulp of 1:
    # a plain running sum returns exactly -1
    n = 1_000_000
    pos = np.zeros((n + 2, 3))
    pos[1, 0] = 1.0
    pos[2:, 1] = 10.0
    mass = np.full(n + 2, 5e-17)
    mass[:2] = 1.0
    pulls = np.zeros(n + 2, bool)
    pulls[:2] = True
    _, energy = _run(pos, mass, pulls, "direct", G=1.0)
    r = np.sqrt(((pos[2:3] - pos[:2]) ** 2).sum(axis=1))
    exact = math.fsum([-1.0] + [-5e-17 / r[0]] * n + [-5e-17 / r[1]] * n)
    assert energy != -1.0
    assert abs(energy - exact) <= 2.3e-16


def test_immovable_bodies_have_no_acceleration(rng):
    pos, mass, pulls = _scene(rng, 30, 0.7)
    still = np.array([2, 7, 11], dtype=np.int64)
    acc, _ = _run(pos, mass, pulls, "direct", still=still)
    free, _ = _run(pos, mass, pulls, "direct")
    assert np.all(acc[still] == 0)
    others = np.setdiff1d(np.arange(30), still)
    assert np.array_equal(acc[others], free[others])     # they still pull the others


def test_thread_count_changes_nothing_but_time():
    """sp.set_threads: a 700-body scene (2.4e5 pairs in 5 blocks: the threaded rounds) ends
    bit for bit the same on 1 thread as on all of them; a bad count is refused, naming it."""
    import numba
    import spacephys as sp
    from spacephys import scenes
    results = []
    previous = sp.get_threads()
    try:
        for n in (1, numba.config.NUMBA_NUM_THREADS):
            assert sp.set_threads(n) >= 1 and sp.get_threads() == n
            w = scenes.uniform_sphere(700, seed=2, softening=0.01, integrator="leapfrog",
                                      dt=1e-3)
            w.threads = "always"
            w.step(20)
            results.append(w.pos.copy())
    finally:
        sp.set_threads(previous)
    assert np.array_equal(results[0], results[1])
    with pytest.raises(ValueError, match="n = 0"):
        sp.set_threads(0)
    with pytest.raises(ValueError, match="at most"):
        sp.set_threads(numba.config.NUMBA_NUM_THREADS + 1)
    assert sp.get_threads() == previous


class _Clock:
    """A perf_counter that advances by what each call is made to cost."""

    def __init__(self):
        self.now = 0.0

    def __call__(self):
        return self.now


def _call(choice, clock, threaded_cost, serial_cost, work=90_000, steps=1):
    token = choice.begin(work, steps)
    used = choice.min_pairs[0] == PARALLEL_MIN_PAIRS
    clock.now += (threaded_cost if used else serial_cost) * steps
    choice.end(token, steps)
    return used


def test_thread_choice_keeps_what_measures_faster(monkeypatch):
    """"auto": a scene starts on threads (its first two calls, which load kernels and build
    tables, untimed), tries one thread for three calls, keeps the faster; beside busy
    processes (threads 8 ms per step, one thread 0.3 ms) it goes to one thread and tries
    threads again only after 1, 2, 4... s; on an idle machine (threads faster) it keeps them
    and checks one thread after 1, 2... s; three calls in a row 4x slower make it look again
    at once, one slow call does not;
    a trial counts its fastest call, so waking the pool on the first does not decide it."""
    from spacephys import _jit
    clock = _Clock()
    monkeypatch.setattr(_jit.time, "perf_counter", clock)
    monkeypatch.setattr(_jit.numba.config, "NUMBA_NUM_THREADS", 2)   # whatever the machine
    monkeypatch.setattr(_jit, "_crowded", lambda: False)   # no other program running
    busy = _jit.ThreadChoice()
    used = [_call(busy, clock, 8e-3, 3e-4) for _ in range(6)]
    assert used == [True, True, True, False, False, False] and not busy.threaded
    clock.now += 0.5
    assert not _call(busy, clock, 8e-3, 3e-4)             # not yet: 1 s after the switch
    clock.now += 0.6
    used = [_call(busy, clock, 8e-3, 3e-4) for _ in range(3)]
    assert used == [True] * 3 and not busy.threaded                   # tried, lost
    clock.now += 1.0
    assert not _call(busy, clock, 8e-3, 3e-4)             # now 2 s between tries
    clock.now += 1.1
    assert _call(busy, clock, 8e-3, 3e-4) and not busy.threaded
    idle = _jit.ThreadChoice()
    used = [_call(idle, clock, 1e-4, 2e-4) for _ in range(7)]
    assert used == [True, True, True, False, False, False, True] and idle.threaded
    clock.now += 2.1
    used = [_call(idle, clock, 1e-4, 2e-4) for _ in range(3)]
    assert used == [False] * 3 and idle.threaded                      # checked, kept
    assert _call(idle, clock, 5e-3, 2e-4) and _call(idle, clock, 1e-4, 2e-4)  # one hiccup
    assert _call(idle, clock, 1e-4, 2e-4) and idle.trial == 0      # ...is not contention
    used = [_call(idle, clock, 9e-3, 2e-4) for _ in range(6)]       # contention came...
    assert used == [True] * 3 + [False] * 3 and not idle.threaded  # ...looked at once
    # the load went away; the first threaded call after a run on one thread wakes the pool
    clock.now += 1.1
    used, last = [], False
    for _ in range(3):
        last = _call(idle, clock, 1e-4 if last else 1e-3, 2e-4)
        used.append(last)
    assert used == [True] * 3 and idle.threaded
    # a long run in one call is never the trial: 1000 steps of 0.1 ms is 0.1 s
    batch = _jit.ThreadChoice()
    used = [_call(batch, clock, 1e-4, 2e-4, steps=1000) for _ in range(5)]
    assert used == [True] * 5
    # measured slower on threads, a long run stays on one thread
    used = [_call(busy, clock, 8e-3, 3e-4, steps=1000) for _ in range(2)]
    assert used == [False] * 2
    small = _jit.ThreadChoice()
    assert small.begin(PARALLEL_MIN_PAIRS - 1, 1) is None         # never worth it
    for mode, want in (("always", PARALLEL_MIN_PAIRS), ("never", _jit.NEVER)):
        small.set(mode)
        assert small.begin(90_000, 1) is None and small.min_pairs[0] == want
    with pytest.raises(ValueError, match="threads='sometimes'"):
        small.set("sometimes")


def test_beside_busy_programs_a_long_call_and_the_first_frames_take_one_thread(monkeypatch):
    """Other work holds the cores (_crowded): a long call, which no trial can split, and a
    scene's first calls run on one thread, and a trial of threads waits until the cores are
    free again; then the choice is measured as on an idle machine."""
    from spacephys import _jit
    clock = _Clock()
    monkeypatch.setattr(_jit.time, "perf_counter", clock)
    monkeypatch.setattr(_jit.numba.config, "NUMBA_NUM_THREADS", 2)
    crowded = [True]
    monkeypatch.setattr(_jit, "_crowded", lambda: crowded[0])
    batch = _jit.ThreadChoice()
    assert [_call(batch, clock, 1e-4, 2e-4, steps=1000) for _ in range(3)] == [False] * 3
    frames = _jit.ThreadChoice()
    used = [_call(frames, clock, 8e-3, 3e-4) for _ in range(4)]
    assert used == [False] * 4 and not frames.threaded
    clock.now += 1.1
    assert not _call(frames, clock, 8e-3, 3e-4)          # a trial is due, the cores are not
    crowded[0] = False
    clock.now += 1.1
    used = [_call(frames, clock, 1e-4, 3e-4) for _ in range(4)]
    assert used == [True] * 4 and frames.threaded      # tried once the cores were free: kept
    assert _call(batch, clock, 1e-4, 2e-4, steps=1000)   # a long call on an idle machine


def test_the_cores_other_programs_hold_are_counted():
    """_cores_taken reads the machine's runnable threads: two spinning processes count."""
    import subprocess
    import time
    from spacephys import _jit
    spinners = [subprocess.Popen([sys.executable, "-c", "while True: pass"]) for _ in range(2)]
    try:
        time.sleep(0.5)
        seen = max(_jit._cores_taken() for _ in range(20))
    finally:
        for p in spinners:
            p.kill()
            p.wait()
    assert seen >= 2


def test_a_few_pulling_bodies_compile_no_pairs_code(tmp_path):
    """Below pairs.PAIRS_FROM the Direct table's sums are None, a type of its own, so the
    step kernel of a star system (6 pulling bodies) compiles none of pull_pairs (it cost the
    default scene's cold first step 3.6 s while the sums were an empty array); a cluster of
    PAIRS_FROM does. In a fresh process with an empty cache."""
    import subprocess
    code = ("import numpy as np, spacephys as sp\n"
            "from spacephys.kernels import pairs\n"
            "import sys; n = int(sys.argv[1])\n"
            "w = sp.World(3, dt=1e-3)\n"
            "w.threads = 'never'\n"
            "w.add_bodies(1.0, np.random.default_rng(1).normal(size=(n, 3)))\n"
            "w.step(1)\n"
            "print(len(pairs.pull_pairs.signatures) + len(pairs.tile.signatures))\n")
    env = dict(__import__("os").environ, NUMBA_CACHE_DIR=str(tmp_path))
    few, many = (int(subprocess.run([sys.executable, "-c", code, str(n)], env=env, check=True,
                                    capture_output=True, text=True).stdout.split()[-1])
                 for n in (6, pairs.PAIRS_FROM))
    assert few == 0 and many > 0
