"""Run logs (spacephys/runlog.py): World.record, open_run, save/load, resume, replay.

Every frame, event and input is checked against what the World itself showed while it ran;
restarts and replays are checked bit for bit; the crash and full-disk cases run in a child
process (killed with SIGKILL, or limited with RLIMIT_FSIZE)."""
import dataclasses
import json
import math
import os
import re
import shutil
import signal
import subprocess
import sys
from fractions import Fraction
from pathlib import Path

import h5py
import numba
import numpy as np
import pytest

import spacephys as sp
from spacephys import checksums
from spacephys import events as ev

ENGINE = dict(dry_mass=1.0, fuel_mass=1.0, max_thrust=2.0, exhaust_speed=3.0)
ROWS = ("ids", "pos", "vel", "mass", "radius", "kind")


# ----------------------------------------------------------------------------- helpers

def _state(w):
    """The frame fields of the World now: (t, ids, pos, vel, mass, radius, kind), copied."""
    return (w.t,) + tuple(np.array(getattr(w, name)) for name in ROWS)


def _json(value):
    """A call argument as the log's JSON should hold it (tuples as lists, specs tagged)."""
    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        return {"__spec__": type(value).__name__,
                "fields": {f.name: _json(getattr(value, f.name))
                           for f in dataclasses.fields(value)}}
    if isinstance(value, (list, tuple)):
        return [_json(v) for v in value]
    if isinstance(value, dict):
        return {k: _json(v) for k, v in value.items()}
    if isinstance(value, np.generic):
        return value.item()
    return value


class Script:
    """Makes calls on a World and notes what its run log must hold: every call (name, args,
    kwargs, log step and time when made, the exception it raised), the events each step
    call reported (with the log step after it) and, with `every`, the frames due."""

    def __init__(self, w, every=None):
        self.w, self.every = w, every
        self.calls, self.events, self.frames = [], [], []
        self.steps = 0
        if every:
            self.frames.append((0,) + _state(w))

    def __call__(self, name, *args, raises=None, **kwargs):
        w = self.w
        self.calls.append((name, args, kwargs, self.steps, w.t,
                           raises.__name__ if raises else None))
        if raises:
            with pytest.raises(raises):
                getattr(w, name)(*args, **kwargs)
            return None
        result = getattr(w, name)(*args, **kwargs)
        if name == "step":
            self.steps += args[0]
            self.events.append((self.steps, w.events))
            if self.every and self.steps % self.every == 0:
                self.frames.append((self.steps,) + _state(w))
        return result

    def expected_events(self):
        rows = [np.zeros(len(e), sp.runlog.LOG_EVENT_DTYPE) for _, e in self.events]
        for (step, events), r in zip(self.events, rows):
            for name in sp.EVENT_DTYPE.names:
                r[name] = events[name]
            r["step"] = step
        return np.concatenate(rows)


def _assert_events_equal(got, want):
    assert got.dtype.names == ("step",) + sp.EVENT_DTYPE.names
    assert len(got) == len(want)
    for name in got.dtype.names:
        assert np.array_equal(got[name], want[name]), name


def _assert_same_world(a, b):
    """Bitwise the same bodies, ship state, time and integrator counters."""
    assert a.t == b.t and a.n == b.n
    for name in ROWS + ("active",):
        assert np.array_equal(getattr(a, name), getattr(b, name)), name
    assert a.integrator_stats == b.integrator_stats
    assert np.array_equal(a.interpolate(0.5), b.interpolate(0.5))    # prev too
    for body in a.ids:
        if body in a.actor_ids:
            assert a.fuel(body) == b.fuel(body)
            assert np.array_equal(a.orientation(body), b.orientation(body))
            assert np.array_equal(np.asarray(a.heading(body)), np.asarray(b.heading(body)))
            assert np.array_equal(np.asarray(a.angular_velocity(body)),
                                  np.asarray(b.angular_velocity(body)))


def _run_child(code, *args, timeout=120):
    return subprocess.run([sys.executable, "-c", code, *map(str, args)], capture_output=True,
                          text=True, timeout=timeout)


# ----------------------------------------------------------------------------- 1. round trip

def _battle(s, dim):
    """Two planets, a burning and turning ship that explodes, a guided missile, a target,
    a failed call; steps in pieces of 3 and a last piece of 2. Returns (ship, missile)."""
    z = (0.0,) * (dim - 2)
    s("set_collision", "debris", "planet", "destroy_a")
    s("add_body", 1e3, (0.0, 0.0) + z, radius=5.0, kind="planet")
    s("add_body", 10.0, (60.0, 0.0) + z, (0.0, math.sqrt(1e3 / 60.0)) + z, radius=1.0,
      kind="planet")
    boom = sp.ExplosionSpec(count=12, speed=2.0, lifetime=0.15, lifetime_spread=0.2)
    ship = s("add_ship", sp.ShipSpec(**ENGINE, turn_rate=1.0, radius=1.0, explosion=boom),
             (30.0, 0.0) + z, (0.0, 5.0) + z)
    target = s("add_body", 1.0, (40.0, 2.0) + z, (0.0, 5.0) + z, radius=0.5, kind="ship")
    s("control", ship, throttle=0.5, turn=0.3 if dim == 2 else (0.0, 0.1, 0.3))
    for _ in range(10):
        s("step", 3)
    missile = s("launch", ship, sp.MissileSpec(fuel_mass=1.0, thrust=3.0, exhaust_speed=20.0,
                                               guidance="pn", launch_speed=20.0,
                                               fuse_radius=0.5), target=target)
    s("launch", ship, sp.MissileSpec(guidance="pn"), raises=ValueError)   # no target
    for _ in range(10):
        s("step", 3)
    s("explode", ship)
    for _ in range(10):
        s("step", 3)
    s("step", 2)
    return ship, missile


def test_only_a_recorded_world_journals_its_calls(tmp_path):
    """An unrecorded World calls its plain methods (no per-call wrapper); while recorded,
    every changing call, nested or not, reaches the log once; a copy is not recorded; after
    close() the calls are plain again and go unrecorded."""
    w = sp.World(2, dt=0.01)
    plain = {name: getattr(w, name).__func__ for name in ("step", "control", "add_body")}
    assert all(f is getattr(sp.World, n) for n, f in plain.items())
    log = w.record(tmp_path / "r.h5")
    a = w.add_body(1.0, (0.0, 0.0))
    w.advance(0.025)                                   # advance() calling step(): one input
    c = w.copy()
    c.step(3)
    c.add_body(0.0, (1.0, 0.0))
    assert c.recording is None and all(
        getattr(c, n).__func__ is f for n, f in plain.items())
    log.close()
    w.step(1)
    w.set_body(a, vel=(1.0, 0.0))
    assert all(getattr(w, n).__func__ is f for n, f in plain.items())
    with sp.open_run(tmp_path / "r.h5") as run:
        assert [e["call"] for e in run.inputs()] == ["add_body", "advance"]


@pytest.mark.parametrize("dim", [2, 3])
def test_round_trip_of_every_field(tmp_path, dim):
    path = tmp_path / "battle.h5"
    w = sp.World(dim, dt=0.01, seed=3)
    log = w.record(path, every=3, scenario="battle: round trip")
    assert w.recording is log and isinstance(log, sp.RunLog)
    s = Script(w, every=3)
    ship, missile = _battle(s, dim)
    end = _state(w)
    log.close()
    assert w.recording is None

    with sp.open_run(path) as run:
        # the schedule: frame 0 at record, one every 3 steps, close()'s at step 92
        want_steps = list(range(0, 91, 3)) + [92]
        assert len(run) == len(want_steps) == 32
        assert run.steps.tolist() == want_steps
        frames = s.frames + [(92,) + end]
        assert [f[0] for f in frames] == want_steps
        assert np.array_equal(run.times, [f[1] for f in frames])
        for k, want in enumerate(frames):
            fr = run.frame(k)
            assert fr.index == k and fr.step == want[0] and fr.t == want[1]
            for name, value in zip(ROWS, want[2:]):
                got = getattr(fr, name)
                assert got.shape == value.shape and np.array_equal(got, value), (k, name)
        assert run.frame(-1).step == 92
        with pytest.raises(IndexError):
            run.frame(len(run))
        # bodies were added and removed along the way
        counts = [len(f[2]) for f in frames]
        assert counts[0] == 0 and max(counts) > counts[-1] > 0

        # frame_at: the last frame at or before t
        times = run.times
        for k in (0, 1, 17, len(run) - 1):
            assert run.frame_at(times[k]).index == k
            assert run.frame_at(times[k] + 0.005).index == k
        assert run.frame_at(times[5] - 0.005).index == 4
        with pytest.raises(IndexError):
            run.frame_at(-1.0)

        # the ship: alive until it explodes at step 60, NaN after
        tr = run.trajectory(ship)
        alive = np.array([ship in f[2] for f in frames])
        assert not alive[0] and alive[1] and not alive[-1]       # frame 0: no bodies yet
        assert alive[1:].tolist() == sorted(alive[1:], reverse=True)
        assert np.array_equal(tr.alive, alive) and np.array_equal(tr.t, times)
        for k, f in enumerate(frames):
            if alive[k]:
                row = f[2].tolist().index(ship)
                assert np.array_equal(tr.pos[k], f[3][row]) and np.array_equal(tr.vel[k],
                                                                               f[4][row])
        assert np.all(np.isnan(tr.pos[~alive])) and np.all(np.isnan(tr.vel[~alive]))
        assert np.array_equal(run.steps[alive], [st for st in want_steps if 0 < st <= 60])

        # events: every step's, as w.events showed them
        want_events = s.expected_events()
        assert {"launch", "expiry"} <= {ev.kind_name(k) for k in want_events["kind"]}
        _assert_events_equal(run.events(), want_events)
        launches = run.events(kind="launch")
        _assert_events_equal(launches, want_events[want_events["kind"] == ev.LAUNCH])
        assert len(launches) == 1 and launches[0]["a"] == missile and launches[0]["b"] == ship
        assert launches[0]["step"] == 33
        _assert_events_equal(run.events(kind=ev.EXPIRY),
                             want_events[want_events["kind"] == ev.EXPIRY])
        mine = (want_events["a"] == missile) | (want_events["b"] == missile)
        _assert_events_equal(run.events(id=missile), want_events[mine])
        assert len(run.events(kind="launch", id=ship)) == 1
        assert len(run.events(kind="merge")) == 0
        with pytest.raises(ValueError, match="kind"):
            run.events(kind="boom")

        # inputs: every call, in order, with its arguments
        inputs = run.inputs()
        assert [e["call"] for e in inputs] == [c[0] for c in s.calls]
        for entry, (name, args, kwargs, step, t, raised) in zip(inputs, s.calls):
            assert entry["args"] == _json(list(args)), name
            assert entry["kwargs"] == _json(kwargs), name
            assert entry["step"] == step and entry["t"] == t, name
            assert entry.get("raised") == raised, name
        assert inputs[3]["args"][0]["__spec__"] == "ShipSpec"
        assert inputs[3]["args"][0]["fields"]["explosion"]["fields"]["count"] == 12

        # metadata
        meta = run.meta
        want_meta = {"format": "spacephys-run", "format_version": 3,
                     "spacephys_version": sp.__version__, "numpy_version": np.__version__,
                     "numba_version": numba.__version__, "h5py_version": h5py.__version__,
                     "integrator": "leapfrog", "dt": 0.01, "G": w.G, "units": "game",
                     "dim": dim, "seed": 3, "scenario": "battle: round trip", "every": 3,
                     "closed": True}
        assert {k: meta.get(k) for k in want_meta} == want_meta
        assert run.checkpoints[0] == (0, 0.0) and run.checkpoints[-1] == (92, end[0])


# ----------------------------------------------------------------------------- 2. every_time

def _two_body(dt, **kw):
    w = sp.World(2, dt=dt, **kw)
    w.add_body(1.0, (0.0, 0.0), kind="star")
    w.add_body(1e-3, (1.0, 0.0), (0.0, 1.0), kind="planet")
    return w


@pytest.mark.parametrize("start", [0, 2], ids=["from_t0", "from_t0.06"])
def test_every_time_frames_at_the_first_step_past_each_multiple(tmp_path, start):
    dt, every_time = 0.03, 0.1
    ref = _two_body(dt)                                  # unrecorded, one step at a time
    states = []
    for _ in range(60):
        states.append(_state(ref))
        ref.step(1)
    states.append(_state(ref))

    w = _two_body(dt)
    w.step(start)
    path = tmp_path / "time.h5"
    log = w.record(path, every_time=every_time)
    for n in (5, 1, 13):
        w.step(n)
    w.advance(0.1)                                      # 3 steps and a bit
    w.step(19)
    end = start + 5 + 1 + 13 + 3 + 19
    assert w.t == states[end][0]
    log.close()

    # world steps k > start where k dt first reaches a multiple m of every_time (exactly)
    due = [start]
    m = 1
    while True:
        k = math.ceil(Fraction(m, 10) / Fraction(3, 100))
        m += 1
        if k <= start:
            continue
        if k > end:
            break
        due.append(k)
    if due[-1] != end:
        due.append(end)                                  # close()'s frame
    with sp.open_run(path) as run:
        assert run.meta["every_time"] == every_time and run.meta["every"] == 0
        assert run.steps.tolist() == [k - start for k in due]
        assert np.array_equal(run.times, [states[k][0] for k in due])
        for i, k in enumerate(due):
            fr = run.frame(i)
            for name, value in zip(ROWS, states[k][1:]):
                assert np.array_equal(getattr(fr, name), value), (i, name)


# ----------------------------------------------------------------------------- 3. restarts

def _orbit_scene(name):
    """A star, a planet and a passive ship burning and turning around the star (suits
    Wisdom-Holman too: one dominant mass, passive ships)."""
    w = sp.World(2, integrator=name, dt=0.01, seed=1)
    w.add_body(1.0, (0.0, 0.0), kind="star")
    w.add_body(1e-3, (2.0, 0.0), (0.0, math.sqrt(1.0 / 2.0)), kind="planet")
    ship = w.add_ship(sp.ShipSpec(dry_mass=1.0, fuel_mass=1.0, max_thrust=0.2,
                                  exhaust_speed=1.0, turn_rate=1.0), (1.0, 0.0), (0.0, 1.0),
                      heading=0.7)
    w.control(ship, throttle=1.0, turn=0.2)
    w.add_body(0.0, (0.0, 1.5), (-0.8, 0.0), kind="asteroid")         # a test particle
    return w


@pytest.mark.parametrize("name", list(sp.INTEGRATORS))
def test_save_and_load_continue_bit_for_bit(tmp_path, name):
    half = 20
    a = _orbit_scene(name)
    a.step(half)
    b = _orbit_scene(name)
    b.step(half)
    _assert_same_world(a, b)
    b.save(tmp_path / "world.h5")
    c = sp.World.load(tmp_path / "world.h5")
    assert c is not b and c.recording is None and c.integrator == name
    _assert_same_world(b, c)
    a.step(half)
    c.step(half)
    _assert_same_world(a, c)
    if name == "gauss_radau":
        assert a.integrator_stats["steps"] > 0


@pytest.mark.parametrize("name", list(sp.INTEGRATORS))
def test_a_run_log_checkpoint_continues_bit_for_bit(tmp_path, name):
    plain = _orbit_scene(name)                      # the same calls, never recorded
    w = _orbit_scene(name)
    path = tmp_path / "run.h5"
    log = w.record(path, every=3, checkpoint_every=2)
    for n in (7, 1, 13):
        w.step(n)
        plain.step(n)
    _assert_same_world(w, plain)                    # recording changes nothing
    log.close()
    copy = w.copy()
    loaded = sp.World.load(path)                    # the last checkpoint: close()'s
    assert loaded.recording is None
    _assert_same_world(copy, loaded)
    for x in (copy, loaded, plain):
        x.step(25)
    _assert_same_world(copy, loaded)
    _assert_same_world(plain, loaded)


# ----------------------------------------------------------------------------- 4. replay

def _skirmish(path, every=None, every_time=None):
    """Merging asteroids, a planet eating debris, a guided missile hitting a ship
    (destroy_both: the ship explodes), an explicit explosion, advance() with uneven frame
    times, w.dt changed mid-run, a call that fails."""
    w = sp.World(2, dt=0.01, seed=11)
    w.set_collision("asteroid", "asteroid", "merge")
    w.set_collision("missile", "ship", "destroy_both")
    w.set_collision("debris", "planet", "destroy_a")
    w.add_body(1e3, (0.0, 0.0), radius=5.0, kind="planet")
    w.add_body(1.0, (-3.0, 30.0), (6.0, 0.0), radius=1.0, kind="asteroid")
    w.add_body(2.0, (3.0, 30.5), (-6.0, 0.0), radius=1.0, kind="asteroid")
    kw = {"every": every} if every else {"every_time": every_time}
    log = w.record(path, checkpoint_every=4, flush_seconds=0.0, **kw)
    boom = sp.ExplosionSpec(count=10, speed=3.0, lifetime=0.3, lifetime_spread=0.3)
    ship = w.add_ship(sp.ShipSpec(**ENGINE, turn_rate=1.0, radius=1.0, explosion=boom),
                      (20.0, 0.0), (0.0, 7.0))
    target = w.add_ship(sp.ShipSpec(radius=1.0, explosion=boom), (28.0, 1.0), (0.0, 6.0),
                        heading=math.pi)
    w.control(ship, throttle=0.7, turn=0.2)
    w.step(5)
    w.launch(ship, sp.MissileSpec(fuel_mass=0.5, thrust=4.0, exhaust_speed=20.0,
                                  guidance="pn", launch_speed=10.0, radius=0.3), target=target)
    with pytest.raises(ValueError):
        w.launch(ship, sp.MissileSpec(guidance="pn"))
    for frame_time in (0.016, 0.033, 0.007, 0.05, 0.021):
        w.advance(frame_time)
    w.dt = 0.005
    w.step(7)
    for frame_time in (0.011, 0.04, 0.0025):
        w.advance(frame_time)
    w.step(30)
    w.explode(ship)
    w.step(25)
    if target in w:
        w.control(target, turn=-0.5)
    w.step(61)
    log.close()
    return w


@pytest.fixture(scope="module")
def skirmish_log(tmp_path_factory):
    path = tmp_path_factory.mktemp("replay") / "skirmish.h5"
    w = _skirmish(path, every=2)
    return path, w


def test_replay_reproduces_a_skirmish(skirmish_log):
    path, w = skirmish_log
    with sp.open_run(path) as run:
        kinds = {ev.kind_name(k) for k in run.events()["kind"]}
        assert {"merge", "destroy", "launch", "expiry"} <= kinds
        calls = [e["call"] for e in run.inputs()]
        assert {"advance", "launch", "explode", "setattr"} <= set(calls)
        assert {"call": "setattr", "args": ["dt", 0.005], "kwargs": {}} in \
            [{k: e[k] for k in ("call", "args", "kwargs")} for e in run.inputs()]
        assert [e.get("raised") for e in run.inputs() if e["call"] == "launch"] == \
            [None, "ValueError"]
        frames = len(run)
        assert len(run.checkpoints) > 5
    result = sp.replay(path)
    assert result.ok, result.message
    assert result.frames == frames and result.diverged_at is None
    _assert_same_world(result.world, w)


def test_replay_with_every_time(tmp_path):
    path = tmp_path / "skirmish_t.h5"
    w = _skirmish(path, every_time=0.02)
    result = sp.replay(path)
    assert result.ok, result.message
    with sp.open_run(path) as run:
        assert result.frames == len(run) > 20
    _assert_same_world(result.world, w)


def _reseal(path):
    """Rewrite a log's per-flush CRC-32s (spacephys/checksums.py) to match its rows."""
    with h5py.File(path, "r+") as f:
        crcs = f["flushes/crc"][:]
        for k, j, name, a, b in checksums.blocks(f["flushes/lengths"][:]):
            crcs[k, j] = checksums.crc(f[name][a:b])
        f["flushes/crc"][:] = crcs


@pytest.mark.parametrize("where", ["first", "middle", "last"])
def test_replay_finds_the_first_frame_that_differs(tmp_path, skirmish_log, where):
    path = tmp_path / "tampered.h5"
    shutil.copy(skirmish_log[0], path)
    with h5py.File(path, "r+") as f:
        n = f["frames/step"].shape[0]
        k = {"first": 0, "middle": n // 2, "last": n - 1}[where]
        row = int(f["frames/first"][k]) + int(f["frames/count"][k]) - 1
        assert f["frames/count"][k] > 0
        f["frames/pos"][row, 1] += 1.0
    with pytest.raises(sp.RunLogError, match="frames/pos rows"):
        sp.replay(path)                          # the rows' CRC-32 sees it first
    _reseal(path)                                # a forgery replay's comparison must see
    result = sp.replay(path)
    assert not result.ok
    assert result.diverged_at == k
    assert result.max_difference == pytest.approx(1.0, rel=1e-9)
    assert str(k) in result.message


# ----------------------------------------------------------------------------- 5. crash

CRASH_CHILD = r"""
import math, sys, time
import spacephys as sp
path = sys.argv[1]
w = sp.World(2, dt=0.01, seed=2)
log = w.record(path, every=1, flush_seconds=0.05, checkpoint_every=30)
w.add_body(1e3, (0.0, 0.0), radius=5.0, kind="planet")
ship = w.add_ship(sp.ShipSpec(dry_mass=1.0, fuel_mass=1e6, max_thrust=0.5,
                              exhaust_speed=1e3, turn_rate=0.5),
                  (30.0, 0.0), (0.0, math.sqrt(1e3 / 30.0)))
w.control(ship, throttle=1.0, turn=0.2)
w.add_body(1.0, (-40.0, 0.0), (0.0, -5.0), kind="asteroid")
frames = 1                                   # frame 0, taken by record()
while True:
    w.step(1)
    frames += 1
    if frames % 25 == 0:
        log.flush()
        print(frames, flush=True)
    time.sleep(0.002)                        # a game's frame
"""


def test_a_killed_recording_leaves_a_readable_log_that_resumes(tmp_path):
    path = tmp_path / "crash.h5"
    proc = subprocess.Popen([sys.executable, "-c", CRASH_CHILD, str(path)],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    reported = []
    try:
        while len(reported) < 4:
            line = proc.stdout.readline()
            if not line:
                break
            reported.append(int(line))
        os.kill(proc.pid, signal.SIGKILL)
    finally:
        proc.kill()
        _, err = proc.communicate(timeout=60)
    assert len(reported) == 4, err
    assert proc.returncode == -signal.SIGKILL

    with sp.open_run(path) as run:
        assert not run.meta["closed"]
        F = len(run)
        assert F >= reported[-1] == 100
        assert run.steps.tolist() == list(range(F))
        for k in range(F):
            fr = run.frame(k)
            assert fr.step == k and fr.ids.shape == (3 if k else 0,)
            assert np.all(np.isfinite(fr.pos)) and fr.pos.shape == (len(fr.ids), 2)
        calls = [e["call"] for e in run.inputs()]
        assert calls[:4] == ["add_body", "add_ship", "control", "add_body"]
        # a frame flushed in the middle of its step call can precede that call's input
        assert calls[4:] == ["step"] * (len(calls) - 4) and F - 2 <= len(calls) - 4 <= F - 1
        last_checkpoint = run.checkpoints[-1]
        assert last_checkpoint[0] >= 90
        saved = run.world()

    w = sp.resume(path)
    assert isinstance(w, sp.World) and isinstance(w.recording, sp.RunLog)
    assert w.t == last_checkpoint[1]
    _assert_same_world(w, saved)
    w.step(10)
    w.recording.close()
    assert w.recording is None
    with sp.open_run(path) as run:
        assert run.meta["closed"]
        assert run.steps.tolist() == list(range(last_checkpoint[0] + 11))
    result = sp.replay(path)
    assert result.ok, result.message
    _assert_same_world(result.world, w)


# ----------------------------------------------------------------------------- 6. resume

@pytest.mark.parametrize("first", [9, 10], ids=["closed_on_a_frame", "closed_between"])
def test_resume_appends_to_a_closed_log(tmp_path, first):
    path = tmp_path / "resume.h5"
    ref = _orbit_scene("leapfrog")
    states = [_state(ref)]
    for _ in range(first + 8):
        ref.step(1)
        states.append(_state(ref))

    w = _orbit_scene("leapfrog")
    log = w.record(path, every=3)
    w.step(first)
    log.close()
    w2 = sp.resume(path)
    assert isinstance(w2.recording, sp.RunLog) and w2.recording.path == str(path)
    _assert_same_world(w2, w)
    w2.step(8)
    w2.recording.close()
    _assert_same_world(w2, ref)

    end = first + 8
    # close()'s off-schedule frame of the first part is dropped on resume (the run goes on
    # from there); the final close() adds one for the end
    want = sorted(set(range(0, end + 1, 3)) | {end})
    with sp.open_run(path) as run:
        assert run.steps.tolist() == want
        assert np.all(np.diff(run.times) > 0)
        for i, k in enumerate(want):
            fr = run.frame(i)
            assert fr.t == states[k][0]
            for name, value in zip(ROWS, states[k][1:]):
                assert np.array_equal(getattr(fr, name), value), (i, name)
        assert [e["call"] for e in run.inputs()] == ["step", "step"]
        assert run.meta["closed"]
    result = sp.replay(path)
    assert result.ok, result.message


# ----------------------------------------------------------------------------- 7. refused

def test_an_unwritable_path_is_refused_before_anything_changes(tmp_path):
    w = _two_body(0.01)
    w.step(3)
    before = _state(w)
    bad = "/nonexistent_dir/x.h5"
    with pytest.raises(sp.RunLogError) as info:
        w.record(bad)
    assert bad in str(info.value)
    assert w.recording is None and not os.path.exists("/nonexistent_dir")
    after = _state(w)
    assert after[0] == before[0] and all(np.array_equal(a, b)
                                         for a, b in zip(after[1:], before[1:]))
    log = w.record(tmp_path / "ok.h5")                  # still free to record elsewhere
    w.step(2)
    log.close()
    with sp.open_run(tmp_path / "ok.h5") as run:
        assert len(run) == 3


DISK_CHILD = r"""
import json, os, resource, signal, sys
import numpy as np
import spacephys as sp
path, when = sys.argv[1], sys.argv[2]

def limit(size):
    signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
    resource.setrlimit(resource.RLIMIT_FSIZE, (size, size))

def outcome(call):
    try:
        call()
        return None
    except Exception as e:
        return [type(e).__name__, str(e)]

rng = np.random.default_rng(5)
w = sp.World(2, dt=0.01, gravity="none")
w.add_bodies(np.ones(2000), rng.uniform(-100.0, 100.0, (2000, 2)), rng.normal(size=(2000, 2)))
report = {}
if when == "record":
    limit(300_000)
try:
    log = w.record(path, every=1, flush_seconds=0.0)
    if when == "step":
        limit(os.path.getsize(path) + 300_000)
    for k in range(1000):
        w.step(1)
    report["error"] = None
except Exception as e:
    report["error"] = [type(e).__name__, str(e)]
    report["recording"] = w.recording is not None
    if w.recording is not None:
        report["again"] = outcome(lambda: w.step(1))
        report["close"] = outcome(w.recording.close)
print(json.dumps(report), flush=True)
os._exit(0)           # (HDF5 can crash at exit on a file it failed to write)
"""


@pytest.mark.parametrize("when", ["record", "step"])
def test_a_full_disk_raises_run_log_error(tmp_path, when):
    path = tmp_path / "full.h5"
    child = _run_child(DISK_CHILD, path, when)
    assert child.returncode == 0, child.stderr
    report = json.loads(child.stdout.strip().splitlines()[-1])
    assert report["error"] is not None, "a full disk went unnoticed"
    kind, message = report["error"]
    assert kind == "RunLogError", message
    assert str(path) in message and re.search(r"fail|cannot write", message), message
    if when == "record":
        assert report["recording"] is False
    else:
        assert report["recording"] is True
        # the log stays broken: the next call says so again, and close() gives up quietly
        assert report["again"] is not None and report["again"][0] == "RunLogError"
        assert report["close"] is None or report["close"][0] == "RunLogError", \
            report["close"]


# ----------------------------------------------------------------------------- 8. bad files

@pytest.fixture(scope="module")
def small_log(tmp_path_factory):
    path = tmp_path_factory.mktemp("small") / "small.h5"
    w = _orbit_scene("leapfrog")
    with w.record(path, every=2):
        w.step(30)
    return path


def _not_hdf5(path, small):
    path.write_text("frame 0: nothing here\n" * 50)


def _no_format(path, small):
    with h5py.File(path, "w") as f:
        f.create_dataset("frames", data=np.arange(10))
        f.attrs["format_version"] = 1


def _newer(path, small):
    shutil.copy(small, path)
    with h5py.File(path, "r+") as f:
        f.attrs["format_version"] = 99


def _truncated(path, small):
    data = small.read_bytes()
    path.write_bytes(data[:len(data) // 2])


READERS = {"open_run": sp.open_run, "load": sp.World.load, "resume": sp.resume,
           "replay": sp.replay}


@pytest.mark.parametrize("reader", list(READERS))
@pytest.mark.parametrize("make, why", [(_not_hdf5, "not an HDF5 file"),
                                       (_no_format, "not a spacephys run log"),
                                       (_newer, "newer"),
                                       (_truncated, "")],
                         ids=["text", "no_format", "version_99", "truncated"])
def test_bad_files_are_refused_by_name(tmp_path, small_log, make, why, reader):
    path = tmp_path / "bad.h5"
    make(path, small_log)
    before = path.read_bytes()
    with pytest.raises(sp.RunLogError) as info:
        READERS[reader](path)
    message = str(info.value)
    assert str(path) in message and why in message, message
    assert path.read_bytes() == before                  # refused without touching it


def test_a_missing_file_is_refused_by_name(tmp_path):
    path = tmp_path / "missing.h5"
    with pytest.raises(sp.RunLogError, match="no such file") as info:
        sp.open_run(path)
    assert str(path) in str(info.value)


# ----------------------------------------------------------------------------- 9. arguments

@pytest.mark.parametrize("kwargs, field", [
    ({"every": 0}, "every"),
    ({"every_time": -1}, "every_time"),
    ({"every": 5, "every_time": 0.1}, "every = 5 and every_time"),
    ({"compression": "zip"}, "compression"),
    ({"checkpoint_every": 0}, "checkpoint_every"),
    ({"flush_seconds": -1.0}, "flush_seconds"),
    ({"scenario": 42}, "scenario"),
])
def test_bad_record_arguments_name_the_field(tmp_path, kwargs, field):
    w = _two_body(0.01)
    path = tmp_path / "never.h5"
    with pytest.raises(ValueError, match=re.escape(field)):
        w.record(path, **kwargs)
    assert w.recording is None and not path.exists()


def test_recording_twice_is_refused(tmp_path):
    w = _two_body(0.01)
    log = w.record(tmp_path / "a.h5")
    with pytest.raises(ValueError, match="already recorded"):
        w.record(tmp_path / "b.h5")
    assert w.recording is log and not (tmp_path / "b.h5").exists()
    w.step(1)
    log.close()
    with sp.open_run(tmp_path / "a.h5") as run:
        assert len(run) == 2


# ----------------------------------------------------------------------------- 10. copies

def test_a_copy_of_a_recording_world_is_not_recording(tmp_path):
    w = _two_body(0.01)
    path = tmp_path / "orig.h5"
    log = w.record(path, every=1)
    w.step(4)
    c = w.copy()
    assert c.recording is None and w.recording is log
    c.step(50)
    c.add_body(1.0, (5.0, 5.0))
    c.dt = 0.02
    w.step(1)
    log.close()
    with sp.open_run(path) as run:
        assert len(run) == 6
        assert [e["call"] for e in run.inputs()] == ["step", "step"]
    assert c.t == pytest.approx(0.54) and c.n == 3


def test_version_1_files_read_their_frames_and_refuse_their_checkpoints(tmp_path):
    """A log of format 1 (checkpoints of World's old attribute tree): frames, events and
    inputs still read; a checkpoint is refused naming the file and the version."""
    path = tmp_path / "old.h5"          # version 1's tables are version 2's (a fixture)
    shutil.copy(Path(__file__).parent / "data" / "version2.h5", path)
    w = sp.World.load(path)
    with h5py.File(path, "r+") as f:
        f.attrs["format_version"] = 1
    with sp.open_run(path) as run:
        assert len(run) == 6 and run.frame(-1).step == 10
        assert [e["call"] for e in run.inputs()] == ["step"]
        with pytest.raises(sp.RunLogError, match="old.h5.*format version 1"):
            run.world(0)
    for load in (lambda: sp.World.load(path), lambda: sp.resume(path),
                 lambda: sp.replay(path)):
        with pytest.raises(sp.RunLogError, match="old.h5.*format version 1"):
            load()
    saved = tmp_path / "world.h5"
    w.save(saved)
    with h5py.File(saved, "r+") as f:
        f.attrs["format_version"] = 1
    with pytest.raises(sp.RunLogError, match="world.h5.*format version 1"):
        sp.World.load(saved)
