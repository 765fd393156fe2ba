"""Sensor and contact begin/end events (kernels/touch.touches): a sensor pair reports
sensor_begin when the two start to overlap and sensor_end when they stop, once each, at their
times within the step; a contact pair (elastic, bounce) that ends a step touching reports
contact_begin, and contact_end when it lifts off. Checked on exact cases, against a brute
force of the overlaps after every step (hypothesis), and across copy, save/load and replay."""
import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import spacephys as sp
from spacephys.events import CONTACT_BEGIN, CONTACT_END, SENSOR_BEGIN, SENSOR_END
from spacephys.kernels.touch import CONTACT_SLOP


def _zone_world(dt=0.1, **kw):
    w = sp.World(dim=2, gravity="none", dt=dt, **kw)
    w.add_kind("zone")
    w.add_kind("ship")
    w.set_collision("zone", "ship", "sensor")
    return w


def _run(w, steps):
    """Every event of `steps` single steps: [(kind, a, b, time)]."""
    out = []
    for _ in range(steps):
        w.step()
        out += [(int(e["kind"]), int(e["a"]), int(e["b"]), float(e["time"]))
                for e in w.events]
    return out


def test_a_sensor_reports_its_overlap_once_when_it_begins_and_once_when_it_ends():
    w = _zone_world()
    z = w.add_body(1.0, (0.0, 0.0), radius=2.0, kind="zone")
    s = w.add_body(1.0, (-5.0, 0.0), vel=(1.0, 0.0), radius=0.5, kind="ship")
    got = _run(w, 120)              # the ship is inside from t = 2.5 to t = 7.5
    assert [g[:3] for g in got] == [(SENSOR_BEGIN, z, s), (SENSOR_END, z, s)]
    assert got[0][3] == pytest.approx(2.5, rel=1e-12)
    assert got[1][3] == pytest.approx(7.5, rel=1e-12)


def test_a_body_passing_through_within_one_step_begins_and_ends_in_it():
    w = _zone_world(dt=1.0)
    w.add_body(1.0, (0.0, 0.0), radius=2.0, kind="zone")
    w.add_body(1.0, (-5.0, 0.0), vel=(10.0, 0.0), radius=0.5, kind="ship")
    w.step()
    ev = w.events
    assert ev["kind"].tolist() == [SENSOR_BEGIN, SENSOR_END]
    np.testing.assert_allclose(ev["t_in_step"], [0.25, 0.75], rtol=1e-12)
    np.testing.assert_allclose(ev["distance"], [2.5, 2.5], rtol=1e-12)
    np.testing.assert_allclose(ev["speed"], [10.0, -10.0], rtol=1e-12)   # closing, opening


def test_born_inside_removed_and_destroyed_bodies_begin_and_end_their_overlaps():
    w = _zone_world()
    w.add_kind("mine")
    w.set_collision("mine", "ship", "destroy_b")
    w.set_collision("mine", "zone", "ignore")
    z = w.add_body(1.0, (0.0, 0.0), radius=2.0, kind="zone")
    still = w.add_body(1.0, (0.0, 0.0), radius=0.5, kind="ship")     # born inside, at rest
    gone = w.add_body(1.0, (1.0, 0.0), radius=0.5, kind="ship")
    hit = w.add_body(1.0, (-1.0, 0.0), vel=(-1.0, 0.0), radius=0.1, kind="ship")
    w.add_body(1.0, (-1.25, 0.0), radius=0.1, kind="mine")            # hit meets it at 0.05
    w.step()
    begins = {(int(e["b"]), float(e["t_in_step"])) for e in w.events
              if e["kind"] == SENSOR_BEGIN}
    assert begins == {(still, 0.0), (gone, 0.0), (hit, 0.0)}          # at the step's start
    end = w.events[w.events["kind"] == SENSOR_END]
    assert end["b"].tolist() == [hit] and end["t_in_step"][0] == pytest.approx(0.05, rel=1e-9)
    w.remove(gone)
    t0 = w.t
    w.step()
    assert w.events["kind"].tolist() == [SENSOR_END]                  # at the next step's start
    assert (int(w.events["a"][0]), int(w.events["b"][0])) == (z, gone)
    assert w.events["time"][0] == t0
    assert _run(w, 5) == []                                           # still inside: quiet


def test_overlaps_across_a_periodic_seam():
    w = _zone_world()
    w.set_boundary("periodic", lo=(-10.0, -10.0), hi=(10.0, 10.0))
    z = w.add_body(1.0, (-9.5, 0.0), radius=1.0, kind="zone")
    s = w.add_body(1.0, (8.0, 0.0), vel=(1.0, 0.0), radius=0.5, kind="ship")
    got = _run(w, 60)               # meets the zone's image at x = 9: t = 1.0, leaves at t = 4
    assert [g[:3] for g in got] == [(SENSOR_BEGIN, z, s), (SENSOR_END, z, s)]
    np.testing.assert_allclose([g[3] for g in got], [1.0, 4.0], rtol=1e-12)


def test_a_resting_contact_begins_once_and_ends_when_it_lifts_off():
    w = sp.World(dim=2, G=1.0, dt=0.01)
    w.add_kind("rock")
    w.set_collision("rock", "body", "bounce", restitution=0.0)
    p = w.add_body(1000.0, (0.0, 0.0), radius=10.0, fixed=True)
    r = w.add_body(1e-6, (0.0, 11.0), radius=0.5, kind="rock")
    got = _run(w, 300)              # falls 0.5 under g = 10: lands at t = sqrt(0.1) ~ 0.316
    touch = [g for g in got if g[0] != sp.events.BOUNCE]
    assert [g[:3] for g in touch] == [(CONTACT_BEGIN, p, r)]
    landing = [g[3] for g in got if g[0] == sp.events.BOUNCE][0]
    assert touch[0][3] == landing                                     # at its first bounce
    w.set_body(r, vel=(0.0, 20.0))
    t0, sunk = w.t, float(w.pos[1, 1])         # resting, the rock has sunk in a little
    got = _run(w, 10)
    assert [g[:3] for g in got] == [(CONTACT_END, p, r)]
    # lifting off at 20, the gap passes CONTACT_SLOP x 10.5
    assert got[0][3] - t0 == pytest.approx((10.5 * (1 + CONTACT_SLOP) - sunk) / 20.0, rel=0.01)


def test_a_clean_bounce_is_a_bounce_only():
    w = sp.World(dim=2, gravity="none", dt=0.1)
    w.set_collision("body", "body", "elastic")
    w.add_body(1.0, (0.0, 0.0), vel=(1.0, 0.0), radius=0.5)
    w.add_body(1.0, (3.05, 0.0), radius=0.5)              # meets at t = 2.05, mid-step
    assert [g[0] for g in _run(w, 40)] == [sp.events.BOUNCE]


def test_the_pairs_in_touch_survive_copy_save_and_load(tmp_path):
    w = _zone_world()
    w.add_body(1.0, (0.0, 0.0), radius=2.0, kind="zone")
    w.add_body(1.0, (-2.0, 0.0), vel=(1.0, 0.0), radius=0.5, kind="ship")
    w.step()                                              # inside: begun
    w.save(tmp_path / "w.h5")
    for other in (w.copy(), sp.World.load(tmp_path / "w.h5")):
        want = _run(w.copy(), 60)
        assert [g[0] for g in want] == [SENSOR_END]       # no second begin
        assert _run(other, 60) == want


# ----------------------------------------------------------------------------- brute force

@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.integers(0, 2 ** 32 - 1), st.booleans(), st.sampled_from([2, 3]))
def test_the_pairs_in_touch_are_the_overlapping_pairs_after_every_step(seed, periodic, dim):
    """Begin/end events kept as a set of pairs are, after every step, exactly the sensor pairs
    overlapping at that moment (brute force over every pair, nearest image); each pair's
    events alternate begin, end."""
    rng = np.random.default_rng(seed)
    w = sp.World(dim=dim, gravity="none", dt=0.05)
    w.add_kind("zone")
    w.add_kind("ship")
    w.set_collision("zone", "ship", "sensor")
    w.set_collision("ship", "ship", "sensor")
    half = 6.0
    if periodic:
        w.set_boundary("periodic", lo=[-half] * dim, hi=[half] * dim)
    n = int(rng.integers(2, 40))
    kinds = rng.choice(["zone", "ship", "body"], n).tolist()
    w.add_bodies(1.0, rng.uniform(-half, half, (n, dim)), rng.normal(0, 3.0, (n, dim)),
                 radius=rng.uniform(0.05, 1.5, n), kind=kinds)
    sensing = {("zone", "ship"), ("ship", "zone"), ("ship", "ship")}
    names = dict(zip(w.ids.tolist(), kinds))
    inside = set()
    last = {}
    for _ in range(40):
        w.step()
        for e in w.events:
            pair = (int(e["a"]), int(e["b"]))
            assert pair[0] < pair[1]
            if e["kind"] == SENSOR_BEGIN:
                assert last.get(pair) != SENSOR_BEGIN
                inside.add(pair)
            else:
                assert e["kind"] == SENSOR_END and last.get(pair) == SENSOR_BEGIN
                inside.discard(pair)
            last[pair] = int(e["kind"])
        d = w.pos[None, :, :] - w.pos[:, None, :]
        if periodic:
            d -= 2 * half * np.round(d / (2 * half))
        dist = np.linalg.norm(d, axis=-1)
        R = w.radius[None, :] + w.radius[:, None]
        ids = w.ids
        want, edge = set(), set()
        for i in range(w.n):
            for j in range(i + 1, w.n):
                if (names[int(ids[i])], names[int(ids[j])]) not in sensing:
                    continue
                pair = (int(min(ids[i], ids[j])), int(max(ids[i], ids[j])))
                if abs(dist[i, j] - R[i, j]) < 1e-9 * R[i, j]:
                    edge.add(pair)                        # within rounding of touching
                elif dist[i, j] < R[i, j]:
                    want.add(pair)
        assert inside - edge == want - edge
