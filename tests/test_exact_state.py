"""Exactness of replay and of saved states, down to one unit in the last place.

test_runlog.py checks that replay and save/load reproduce small scenes and that replay finds
a frame moved by 1.0; it does not check that a difference of one ulp is found, that worlds
of thousands of bodies (arrays big enough to be compressed, or to tempt a writer into a
smaller type) come back bit for bit, that extreme doubles (subnormals, 1e300, -0.0, values a
float32 cannot hold) survive, nor that a replay reproduces the events table. Every float is
compared by its bits (uint64 views), so -0.0 differs from 0.0 and no tolerance hides a
rounding.
"""
import dataclasses
import math

import h5py
import numpy as np
import pytest

import spacephys as sp
from spacephys import runlog

ROWS = ("ids", "pos", "vel", "mass", "radius", "kind")


# ----------------------------------------------------------------------------- helpers

def _bits(a):
    """An array as raw integers of its bits (floats: uint64, so -0.0 != 0.0)."""
    a = np.ascontiguousarray(a)
    return a.view(np.uint64) if a.dtype == np.float64 else a


def _assert_same_state(a, b, where="state"):
    """Two World.state() dicts (or parts of them) equal bit for bit: the same keys, types,
    dtypes, shapes and bytes; floats by their bits."""
    if isinstance(a, dict):
        assert isinstance(b, dict) and sorted(a) == sorted(b), where
        for key in a:
            _assert_same_state(a[key], b[key], f"{where}/{key}")
    elif isinstance(a, (list, tuple)):
        assert isinstance(b, (list, tuple)) and len(a) == len(b), where
        for k, (x, y) in enumerate(zip(a, b)):
            _assert_same_state(x, y, f"{where}/{k}")
    elif isinstance(a, np.ndarray):
        assert isinstance(b, np.ndarray), where
        assert a.dtype == b.dtype and a.shape == b.shape, (where, a.dtype, b.dtype)
        if a.tobytes() != b.tobytes():
            if a.dtype.names:
                bad = [name for name in a.dtype.names
                       if not np.array_equal(_bits(a[name]), _bits(b[name]))]
            else:
                bad = np.argwhere(_bits(a) != _bits(b))[:3].tolist()
            pytest.fail(f"{where} differs in its bits at {bad}")
    elif dataclasses.is_dataclass(a):
        assert type(a) is type(b), where
        _assert_same_state(dataclasses.asdict(a), dataclasses.asdict(b), where)
    elif isinstance(a, float):
        assert isinstance(b, float) and a.hex() == b.hex(), (where, a, b)
    else:
        assert type(a) is type(b) and a == b, (where, a, b)


def _assert_same_world(a, b):
    """The same state bit for bit, and the same views (what a game reads)."""
    _assert_same_state(a.state(), b.state())
    assert a.t.hex() == b.t.hex()
    for name in ROWS:
        assert np.array_equal(_bits(getattr(a, name)), _bits(getattr(b, name))), name


def _event_differences(a, b):
    """(row, field) pairs where two event tables differ in their bits."""
    assert a.dtype == b.dtype and a.shape == b.shape, (a.dtype, b.dtype, a.shape, b.shape)
    return [(int(row), name) for name in a.dtype.names
            for row in np.flatnonzero(_bits(a[name]) != _bits(b[name]))]


def _nudge(value):
    """value moved up by one ulp."""
    return np.nextafter(value, np.inf)


# ----------------------------------------------------------------------------- scenes

def _melee(path):
    """A 3D recorded run with every kind of contact it can get cheaply: asteroids merging,
    one bouncing off the planet, a wall, a guided missile that burns out and destroys its
    target (destroy_both), a ship that runs out of fuel and is exploded, debris expiring and
    hitting the planet; advance() with uneven frame times and a change of dt."""
    w = sp.World(3, dt=0.01, seed=5)
    w.set_collision("asteroid", "asteroid", "merge")
    w.set_collision("asteroid", "planet", "bounce", 0.6)
    w.set_collision("missile", "ship", "destroy_both")
    w.set_collision("debris", "planet", "destroy_a")
    w.add_plane((0.0, 0.0, -4.0), (0.0, 0.0, 1.0), restitution=0.9)
    log = w.record(path, every=2, checkpoint_every=3, flush_seconds=0.0)
    w.add_body(1e3, (0.0, 0.0, 0.0), radius=5.0, kind="planet")
    w.add_bodies([1.0, 2.0], [(-3.0, 30.0, 0.1), (3.0, 30.5, -0.1)],
                 [(6.0, 0.0, 0.0), (-6.0, 0.0, 0.0)], radius=1.0, kind="asteroid")
    w.add_body(0.5, (0.0, 9.0, 0.0), (0.0, -3.0, 0.0), radius=0.5, kind="asteroid")
    w.add_body(0.1, (10.0, 0.0, -2.0), (0.0, 0.0, -4.0), radius=0.5, kind="body")
    boom = sp.ExplosionSpec(count=16, speed=4.0, lifetime=0.3, lifetime_spread=0.4, radius=0.1)
    ship = w.add_ship(sp.ShipSpec(dry_mass=1.0, fuel_mass=0.05, max_thrust=2.0,
                                  exhaust_speed=3.0, turn_rate=1.0, radius=1.0,
                                  explosion=boom), (20.0, 0.0, 0.0), (0.0, 7.0, 0.0))
    target = w.add_ship(sp.ShipSpec(radius=1.0, explosion=boom), (28.0, 1.0, 0.0),
                        (0.0, 6.0, 0.0))
    w.control(ship, throttle=1.0, turn=(0.0, 0.1, 0.2))
    w.step(5)
    w.launch(ship, sp.MissileSpec(fuel_mass=0.5, thrust=4.0, exhaust_speed=20.0, burn_time=0.3,
                                  guidance="pn", launch_speed=10.0, radius=0.3), target=target)
    for frame_time in (0.016, 0.033, 0.007, 0.05):
        w.advance(frame_time)
    w.dt = 0.005
    w.step(40)
    w.explode(ship)
    w.step(30)
    w.step(61)
    log.close()
    return w


@pytest.fixture(scope="module")
def melee_log(tmp_path_factory):
    path = tmp_path_factory.mktemp("exact") / "melee.h5"
    w = _melee(path)
    with sp.open_run(path) as run:
        kinds = {sp.events.kind_name(k) for k in run.events()["kind"]}
    assert {"merge", "bounce", "wall", "destroy", "launch", "burnout", "fuel_empty",
            "expiry"} <= kinds, kinds
    result = sp.replay(path)                          # untouched, it replays bit for bit
    assert result.ok, result.message
    return path, w


def _crowd(n=5000, seed=7):
    """n asteroids (passive, so gravity costs n, not n^2) around a planet, merging when they
    touch and bouncing off it; four burning, turning ships (one fires a guided missile, one is
    exploded into debris)."""
    rng = np.random.default_rng(seed)
    w = sp.World(2, dt=0.01, seed=seed)
    w.set_collision("asteroid", "asteroid", "merge")
    w.set_collision("asteroid", "planet", "bounce", 0.5)
    w.set_collision("debris", "planet", "destroy_a")
    w.set_collision("missile", "ship", "destroy_both")
    w.add_body(1e4, (0.0, 0.0), radius=10.0, kind="planet")
    r = rng.uniform(15.0, 600.0, n)
    th = rng.uniform(0.0, 2 * np.pi, n)
    v = np.sqrt(1e4 / r) * rng.uniform(0.8, 1.2, n)
    w.add_bodies(rng.uniform(1e-3, 1e-2, n), np.c_[r * np.cos(th), r * np.sin(th)],
                 np.c_[-v * np.sin(th), v * np.cos(th)] + rng.normal(0.0, 0.5, (n, 2)),
                 radius=rng.uniform(0.3, 1.5, n), kind="asteroid", active=False)
    boom = sp.ExplosionSpec(count=20, speed=3.0, lifetime=0.05, lifetime_spread=0.5)
    spec = sp.ShipSpec(dry_mass=1.0, fuel_mass=1.0, max_thrust=2.0, exhaust_speed=3.0,
                       turn_rate=1.0, radius=1.0, explosion=boom)
    ships = [w.add_ship(spec, (50.0 + 5 * k, 0.0), (0.0, math.sqrt(1e4 / (50 + 5 * k))))
             for k in range(4)]
    for s in ships:
        w.control(s, throttle=0.5, turn=0.2)
    return w, ships


def _crowd_battle(w, ships):
    """Steps, a launch and an explosion: the state then holds missiles, debris with
    lifetimes, queued launches consumed, and a step's events."""
    w.step(3)
    w.launch(ships[0], sp.MissileSpec(fuel_mass=0.5, thrust=4.0, exhaust_speed=20.0,
                                      guidance="pn", launch_speed=10.0, radius=0.3),
             target=ships[1])
    w.explode(ships[3])
    w.step(4)


# ----------------------------------------------------------------------------- 1. replay, one ulp
# A log that differs from what its inputs reproduce is made by the writer itself (so every
# checksum of the file holds): a change made while the log is detached is not journaled.

def _unrecorded(w, change):
    """change(w) made behind the log's back: the log records its effects, not the call."""
    log = w.recording
    w.recording = None
    try:
        change(w)
    finally:
        w.recording = log


def _orbits(path, when=None, change=None):
    """A recorded 2D scene (a star, a planet, a test particle, a burning ship), a frame every
    2 steps; change(w) is made unrecorded after step 7 ("mid": the next frame is at step 8),
    after step 13 ("close": close() takes an off-schedule frame of it) or after step 14 ("end":
    a frame was just taken, so only the final checkpoint holds it)."""
    w = sp.World(2, dt=0.01, seed=1)
    log = w.record(path, every=2, checkpoint_every=2, flush_seconds=0.0)
    w.add_body(1.0, (0.0, 0.0), kind="star")
    w.add_body(1e-3, (2.0, 0.0), (0.0, math.sqrt(0.5)), radius=0.1, kind="planet")
    w.add_body(0.0, (0.0, 1.5), (-0.8, 0.0), kind="asteroid")
    ship = w.add_ship(sp.ShipSpec(dry_mass=1.0, fuel_mass=1.0, max_thrust=0.2,
                                  exhaust_speed=1.0, turn_rate=1.0), (1.0, 0.0), (0.0, 1.0))
    w.control(ship, throttle=1.0, turn=0.2)
    for steps, stage in ((7, "mid"), (6, "close"), (1, "end")):
        if stage == "end" and when != "end":
            break
        w.step(steps)
        if stage == when:
            _unrecorded(w, change)
    log.close()
    return w


def _nudged(field, body=None, ulps=None):
    """A change of one number of one body (default: the first planet) by one ulp: the
    largest coordinate of its position or velocity (a normal number, which no absolute
    tolerance would cover), or its mass or radius; the ulp is appended to `ulps`."""
    def change(w):
        who = int(w.ids[w.kind == w.kind_code("planet")][0]) if body is None else body
        value = np.array(getattr(w, field)[w.index_of(who)])
        k = int(np.argmax(np.abs(value))) if value.ndim else ()
        old = value[k]
        value[k] = _nudge(old)
        assert abs(old) >= 1e-3
        if ulps is not None:
            ulps.append(float(value[k] - old))
        w.set_body(who, **{field: value})
    return change


@pytest.fixture(scope="module")
def orbits(tmp_path_factory):
    """The scene of _orbits recorded to step 14 without a change: it replays bit for
    bit."""
    path = tmp_path_factory.mktemp("orbits") / "clean.h5"
    w = _orbits(path, "end", lambda w: None)
    result = sp.replay(path)
    assert result.ok and result.frames == 8, result.message
    return w


@pytest.mark.parametrize("when", ["mid", "close"])
@pytest.mark.parametrize("field", ["pos", "vel", "mass", "radius"])
def test_replay_finds_one_ulp_in_one_number_of_one_body(tmp_path, orbits, field, when):
    """One ulp (np.nextafter) on one number of one body, unrecorded, mid-run or just before
    close(): the replay must report the first frame taken after it (a comparison with any
    relative tolerance would pass it). Just before close() the frame differs by exactly that
    ulp, and replay's largest difference says so."""
    path = tmp_path / "nudged.h5"
    ulps = []
    _orbits(path, when, _nudged(field, ulps=ulps))
    with sp.open_run(path) as run:
        steps = run.steps
        want = int(np.flatnonzero(steps > (7 if when == "mid" else 12))[0])
        assert steps[want] == (8 if when == "mid" else 13)
    result = sp.replay(path)
    assert not result.ok, result.message
    assert result.diverged_at == want, result.message
    if when == "close" and field in ("pos", "vel"):
        assert result.max_difference == ulps[0] > 0
    elif field in ("pos", "vel"):
        assert 0 < result.max_difference < 1e-12


def test_replay_finds_one_ulp_in_the_time_of_a_frame(tmp_path):
    """A frame holding no bodies is still compared, by its time: dt made one ulp longer
    unrecorded puts the next frame at t = dt + ulp, and replay reports that frame."""
    path = tmp_path / "time.h5"
    w = sp.World(2, dt=0.01)
    log = w.record(path, every=1, flush_seconds=0.0)
    _unrecorded(w, lambda w: setattr(w, "dt", float(_nudge(0.01))))
    w.step(2)
    log.close()
    with sp.open_run(path) as run:
        assert run.times[1] == _nudge(0.01) and run.frame(1).ids.size == 0
    result = sp.replay(path)
    assert not result.ok and result.diverged_at == 1, result.message


def test_replay_finds_one_ulp_in_the_final_state(tmp_path, orbits):
    """One velocity component of a body one ulp off, unrecorded, right after a frame was
    taken, then close(): every frame matches, so only replay's bit-for-bit comparison of
    the final state (the last checkpoint) can tell."""
    path = tmp_path / "final.h5"
    _orbits(path, "end", _nudged("vel"))
    with sp.open_run(path) as run:
        assert run.steps[-1] == 14 and run.checkpoints[-1][0] == 14
        final = run.world()
    assert np.count_nonzero(final.vel != orbits.vel) == 1
    result = sp.replay(path)
    assert not result.ok
    assert result.diverged_at is None, result.message
    assert result.message == "the final state differs in bodies/columns/vel"


def test_replay_compares_the_whole_final_state(tmp_path):
    """What frames do not hold (a ship's heading, here set by an unrecorded call just before
    close()) is compared too: the final state is World.state(), not the frame columns."""
    w = sp.World(2, dt=0.01)
    w.add_body(100.0, (0.0, 0.0), radius=1.0)
    log = w.record(tmp_path / "heading.h5")
    ship = w.add_ship(sp.ShipSpec(fuel_mass=1.0, max_thrust=1.0, exhaust_speed=5.0),
                      (5.0, 0.0), (0.0, 4.0))
    w.step(10)
    w.recording = None
    w.set_heading(ship, 1.0)
    w.recording = log
    log.close()
    result = sp.replay(tmp_path / "heading.h5")
    assert not result.ok and result.message == "the final state differs in bodies/columns/quat"


# ----------------------------------------------------------------------------- 2. events by replay

def _change_event(field):
    """Changes one field of an event row: one ulp more of a float, another kind (a bounce),
    another id (b's as a)."""
    def change(row):
        if field == "kind":
            row[field] = sp.events.BOUNCE
        elif field == "a":
            row[field] = row["b"]
        else:
            row[field] = _nudge(row[field])
    return change


def _plant_event(monkeypatch, kind, change):
    """While a log is written (until monkeypatch.undo()), the first event of `kind` the run
    reports is changed by change(row) on its way into the file, the World's own events left
    as they are: a log whose events table differs from the run in one event, written by the
    writer itself (every checksum of the file holds). Returns a list that is [True] once
    the event was changed."""
    record = runlog.RunLog.record_events
    planted = []

    def plant(self, events):
        events = np.array(events)
        hits = np.flatnonzero(events["kind"] == kind)
        if not planted and hits.size:
            row = events[hits[0]].copy()
            change(row)
            events[hits[0]] = row
            planted.append(True)
        return record(self, events)

    monkeypatch.setattr(runlog.RunLog, "record_events", plant)
    return planted


def test_a_replay_reproduces_every_event_field_bit_for_bit(tmp_path, melee_log, monkeypatch):
    """sp.replay compares the events the replayed World reports, step by step, with the
    recorded table: every field of every row (kinds, ids, times, contact points, normals,
    speeds, energies, distances, the step). A log written with one ulp more in one bounce's
    energy_lost differs from its replay there, and replay names the row and the field."""
    path, _ = melee_log
    result = sp.replay(path)
    assert result.ok and "the events" in result.message, result.message
    with sp.open_run(path) as run:
        assert len(run.events()) > 100

    planted = _plant_event(monkeypatch, sp.events.BOUNCE, _change_event("energy_lost"))
    _melee(tmp_path / "event.h5")
    monkeypatch.undo()
    assert planted == [True]
    with sp.open_run(tmp_path / "event.h5") as run:
        written = run.events()
    first_bounce = int(np.flatnonzero(written["kind"] == sp.events.BOUNCE)[0])
    result = sp.replay(tmp_path / "event.h5")
    assert not result.ok
    assert result.message.endswith(f"events[{first_bounce}].energy_lost"), result.message


def _merger(path):
    """Two asteroids that merge, recorded: one merge event with energy lost."""
    w = sp.World(2, dt=0.01)
    w.set_collision("asteroid", "asteroid", "merge")
    with w.record(path, flush_seconds=0.0):
        w.add_body(1.0, (-2.0, 0.0), (10.0, 0.0), radius=1.0, kind="asteroid")
        w.add_body(2.0, (2.0, 0.1), (-10.0, 0.0), radius=1.0, kind="asteroid")
        w.step(30)


@pytest.mark.parametrize("field", ["energy_lost", "kind", "a"])
def test_replay_reports_an_event_that_differs(tmp_path, monkeypatch, field):
    """A log whose events table differs from the run in one field of one event (one ulp of
    a float, another kind, another id) must not replay as equal."""
    path = tmp_path / "event.h5"
    planted = _plant_event(monkeypatch, sp.events.MERGE, _change_event(field))
    _merger(path)
    monkeypatch.undo()
    assert planted == [True]
    result = sp.replay(path)
    assert not result.ok and f"events[0].{field}" in result.message, result.message


# ----------------------------------------------------------------------------- 3. thousands of bodies

@pytest.fixture(scope="module")
def crowd():
    w, ships = _crowd()
    _crowd_battle(w, ships)
    assert w.n > 4000 and len(w.events) > 0 and len(w.actor_ids) >= 3
    return w


def test_a_world_of_5000_bodies_saves_loads_and_continues_bit_for_bit(tmp_path, crowd):
    """Save/load and from_state(state()) of ~5 000 bodies with ships, a missile, debris and
    merges: the state comes back bit for bit (every column, the last step's events), stored
    as float64 in the file, and stepping on gives the same bits as the original stepped."""
    w = crowd.copy()
    path = tmp_path / "crowd.h5"
    w.save(path)
    with h5py.File(path, "r") as f:
        for name in ("pos", "vel", "prev", "mass", "radius", "fuel"):
            assert f["world/bodies/columns/" + name].dtype == np.float64, name
    loaded = sp.World.load(path)
    rebuilt = sp.World.from_state(w.state())
    _assert_same_world(w, loaded)
    _assert_same_world(w, rebuilt)
    for x in (w, loaded, rebuilt):
        x.step(6)
    assert len(w.events) > 0
    _assert_same_world(w, loaded)
    _assert_same_world(w, rebuilt)


@pytest.mark.parametrize("nudge", [False, True], ids=["exact", "one_ulp"])
def test_a_recorded_world_of_5000_bodies_replays_bit_for_bit(tmp_path, nudge):
    """A log of ~5 000 bodies (big frames, big checkpoint images): its last checkpoint loads
    as the World that closed it, bit for bit, and the replay matches; with one ulp on one
    coordinate of the last body before close(), the last frame is reported."""
    w, ships = _crowd()
    path = tmp_path / "crowd_run.h5"
    log = w.record(path, every=3, flush_seconds=0.0)
    _crowd_battle(w, ships)
    w.step(1)
    if nudge:
        _unrecorded(w, _nudged("pos", int(w.ids[-1])))
    log.close()
    _assert_same_world(w, sp.World.load(path))
    result = sp.replay(path)
    if not nudge:
        assert result.ok, result.message
        _assert_same_world(w, result.world)
    else:
        with sp.open_run(path) as run:
            assert run.frame(-1).ids.size > 4000
            assert not result.ok and result.diverged_at == len(run) - 1, result.message


# ----------------------------------------------------------------------------- 4. extreme values

EXTREMES = np.array([5e-324, -5e-324, 2.2250738585072014e-308 / 3, 1e300, -1e300, -0.0, 0.1,
                     1 / 3, float(np.nextafter(1.0, 2.0)), -2.0 ** -1074 * 12345,
                     1.7976931348623157e308 / 4, 16777217.0, 0.0])


def _extreme_world(n):
    """n bodies (no gravity, so nothing overflows when stepped) whose positions, velocities,
    masses and radii, plus dt, the origin and a ship's fuel, are extreme doubles or doubles a
    float32 cannot hold, set after two steps (so that stepping has not rounded them away);
    the last body's velocity needs all 17 significant digits."""
    rng = np.random.default_rng(11)
    w = sp.World(3, dt=float(np.nextafter(0.01, 1.0)), gravity="none", seed=3)
    w.shift_origin((0.1, -1 / 3, 1e-310))
    ids = w.add_bodies(np.abs(rng.choice(EXTREMES, n)), rng.choice(EXTREMES, (n, 3)),
                       rng.choice(EXTREMES, (n, 3)) * 1e-3,
                       radius=np.abs(rng.choice(EXTREMES, n)) * 1e-10)
    ship = w.add_ship(sp.ShipSpec(dry_mass=1e-300, fuel_mass=1.0, max_thrust=0.0,
                                  exhaust_speed=3.0), (1e300, -0.0, 5e-324), (-0.0, 0.1, 1e-320))
    last = w.add_body(5e-324, (-0.0, 0.1, 2.0 ** -1060))
    w.step(2)
    for k, x in enumerate(EXTREMES):
        y = EXTREMES[-1 - k]
        w.set_body(int(ids[k]), pos=(x, -0.0, y), vel=(y, x, -0.0), mass=abs(x),
                   radius=abs(y) * 1e-10)
    w.set_fuel(ship, 1 / 3)
    w.set_body(last, vel=(float(np.nextafter(0.1, 1.0)), 1 / 3, 0.30000000000000004))
    return w


@pytest.mark.parametrize("n", [20, 5000], ids=["small", "big"])
def test_extreme_values_survive_save_load_and_from_state_bit_for_bit(tmp_path, n):
    """Subnormals, +-1e300, -0.0, 0.1, 1/3, 1 + ulp, 2^24 + 1: saved and loaded, or passed
    through from_state(state()), every bit (sign of zero included) comes back, in small
    arrays and in arrays big enough to be compressed; stepped on, the bits stay the same."""
    w = _extreme_world(n)
    for values in (w.pos, w.vel):                   # what is saved holds every case
        assert np.any(np.signbit(values) & (values == 0.0))
        assert np.any((values != 0.0) & (np.abs(values) < 2.2250738585072014e-308))
        assert np.any(np.abs(values) >= 1e300)
        with np.errstate(over="ignore"):
            assert np.any(values.astype(np.float32).astype(np.float64) != values)
    w.save(tmp_path / "extreme.h5")
    loaded = sp.World.load(tmp_path / "extreme.h5")
    rebuilt = sp.World.from_state(w.state())
    for x in (loaded, rebuilt):
        _assert_same_world(w, x)
        assert x.dt.hex() == w.dt.hex() and x.fuel(x.actor_ids[0]) == w.fuel(w.actor_ids[0])
        assert np.array_equal(_bits(x.origin), _bits(w.origin))
    last = loaded.vel[-1]
    assert last.tolist() == [float(np.nextafter(0.1, 1.0)), 1 / 3, 0.30000000000000004]
    for x in (w, loaded, rebuilt):
        x.step(3)
    _assert_same_world(w, loaded)
    _assert_same_world(w, rebuilt)
