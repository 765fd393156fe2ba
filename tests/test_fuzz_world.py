"""Stateful fuzzing of the World API (hypothesis RuleBasedStateMachine): long random
sequences of legal calls, with the invariants checked after every one.

Profiles (SPACEPHYS_FUZZ): "ci" (the default, in the suite) runs FUZZ_PROFILES["ci"]
examples; "long" for local runs: SPACEPHYS_FUZZ=long python -m pytest tests/test_fuzz_world.py
"""
import os
import tempfile
from pathlib import Path

import hypothesis.strategies as st
import numpy as np
import pytest
from hypothesis import HealthCheck, settings
from hypothesis.stateful import (RuleBasedStateMachine, initialize, invariant, precondition,
                                 rule)

import spacephys as sp

# ci: the same examples on every run (a failure in CI is one that reproduces); long: new
# ones each time
FUZZ_PROFILES = {"ci": dict(max_examples=2000, stateful_step_count=12, derandomize=True),
                 "long": dict(max_examples=20_000, stateful_step_count=40)}
PROFILE = os.environ.get("SPACEPHYS_FUZZ", "ci")

# "closed" scenes: gravity among free bodies and contacts that keep momentum, nothing else
CLOSED_RESPONSES = ("ignore", "elastic", "merge", "sensor")
OPEN_RESPONSES = ("ignore", "elastic", "bounce", "merge", "sensor", "destroy_a", "destroy_b",
                  "destroy_both", "break_a", "break_b")
KINDS = ("body", "asteroid")
INTEGRATORS = tuple(sp.INTEGRATORS)

coord = st.floats(-10.0, 10.0, allow_nan=False)
speed = st.floats(-1.0, 1.0, allow_nan=False)
unit = st.floats(0.0, 1.0, allow_nan=False)


def _same(a, b, where="state"):
    """Two World.state() trees equal bit for bit (NaN equal to NaN)."""
    assert type(a) is type(b) or (np.isscalar(a) and np.isscalar(b)), where
    if isinstance(a, dict):
        assert a.keys() == b.keys(), where
        for k in a:
            _same(a[k], b[k], f"{where}/{k}")
    elif isinstance(a, (list, tuple)):
        assert len(a) == len(b), where
        for k, (x, y) in enumerate(zip(a, b)):
            _same(x, y, f"{where}/{k}")
    elif isinstance(a, np.ndarray):
        assert a.dtype == b.dtype and a.shape == b.shape, where
        assert a.tobytes() == b.tobytes(), where
    else:
        assert a == b or (a != a and b != b), (where, a, b)


class WorldMachine(RuleBasedStateMachine):
    """One World driven by random legal calls; self.model keeps what must hold."""

    def __init__(self):
        super().__init__()
        self._tmp = None
        self.w = None
        self.log = None
        self.broken = False          # an InstabilityError was raised: the World is done
        self.seen, self.dead = set(), set()
        self.saved = False
        self.snap = None             # (snapshot, copy, digest, seen, dead) when one is taken

    @property
    def tmp(self):
        """A folder for this example's files, made when first needed."""
        if self._tmp is None:
            self._tmp = Path(tempfile.mkdtemp(prefix="spacephys-fuzz-"))
        return self._tmp

    # ------------------------------------------------------------------ the scene
    @initialize(dim=st.sampled_from([2, 3]), integrator=st.sampled_from(INTEGRATORS),
                closed=st.booleans(), n=st.integers(1, 6), seed=st.integers(0, 2**16),
                dt=st.sampled_from([0.001, 0.01, 0.05]),
                files=st.sampled_from([False, False, False, True]))
    def scene(self, dim, integrator, closed, n, seed, dt, files):
        self.closed = closed
        # files cost some 40 ms each (h5py writes and reads ~50 objects a state): a quarter
        # of the examples save, load, record and replay
        self.files = files
        w = sp.World(dim, dt=dt, seed=seed, softening=0.05)
        rng = np.random.default_rng(seed)
        w.add_body(10.0, np.zeros(dim), radius=0.5, kind="body")
        if n > 1:
            w.add_bodies(rng.uniform(0.0, 1.0, n - 1), rng.uniform(-8, 8, (n - 1, dim)),
                         rng.uniform(-1, 1, (n - 1, dim)), radius=0.1, kind="asteroid")
        try:
            w.integrator = integrator
        except ValueError:
            w.integrator = "leapfrog"            # a family that refuses this scene
        self.w = w
        self._book()

    def _book(self):
        live = set(self.w.ids.tolist())
        assert not live & self.dead, "a dead id came back"
        self.dead |= self.seen - live
        self.seen |= live

    def _pick(self, data, ids=None):
        ids = self.w.ids if ids is None else ids
        return int(ids[data.draw(st.integers(0, len(ids) - 1))])

    def _call(self, name, *args, **kwargs):
        """A call of the World; a refusal (ValueError) must leave it as it was."""
        before = self.w.state()
        try:
            return getattr(self.w, name)(*args, **kwargs)
        except ValueError as e:
            assert str(e), name
            _same(before, self.w.state(), f"{name} refused, yet the state changed")
            return None
        finally:
            self._book()

    def _vec(self, data, elements=coord):
        return np.array(data.draw(st.lists(elements, min_size=self.w.dim,
                                           max_size=self.w.dim)))

    # ------------------------------------------------------------------ bodies
    @precondition(lambda m: not m.broken)
    @rule(data=st.data(), mass=st.floats(0.0, 5.0), radius=st.floats(0.0, 0.5),
          kind=st.sampled_from(KINDS))
    def add_body(self, data, mass, radius, kind):
        i = self._call("add_body", mass, self._vec(data), self._vec(data, speed),
                       radius=radius, kind=kind)
        assert i is not None and i in self.w and i not in self.dead

    @precondition(lambda m: not m.broken and m.w.n > 0)
    @rule(data=st.data())
    def remove(self, data):
        i = self._pick(data)
        self._call("remove", i)
        assert i not in self.w and i in self.dead

    @precondition(lambda m: not m.broken and m.w.n > 0)
    @rule(data=st.data(), what=st.sampled_from(["pos", "vel", "mass"]))
    def set_body(self, data, what):
        i = self._pick(data)
        value = data.draw(st.floats(0.0, 5.0)) if what == "mass" else \
            self._vec(data, coord if what == "pos" else speed)
        self._call("set_body", i, **{what: value})

    @precondition(lambda m: not m.broken and m.dead)
    @rule(data=st.data())
    def stale_ids_are_refused(self, data):
        dead = sorted(self.dead)
        i = dead[data.draw(st.integers(0, len(dead) - 1))]
        before = self.w.state()
        for call in (lambda: self.w.set_body(i, pos=np.zeros(self.w.dim)),
                     lambda: self.w.remove(i), lambda: self.w.index_of(i),
                     lambda: self.w.explode(i)):
            try:
                call()
            except ValueError as e:
                assert str(i) in str(e)
            else:
                raise AssertionError(f"the dead id {i} was accepted")
        assert i not in self.w
        _same(before, self.w.state())

    # ------------------------------------------------------------------ actors (open scenes)
    @precondition(lambda m: not m.broken and not m.closed)
    @rule(data=st.data())
    def add_ship(self, data):
        spec = sp.ShipSpec(dry_mass=1.0, fuel_mass=5.0, max_thrust=1.0, exhaust_speed=10.0,
                           radius=0.2, explosion=sp.ExplosionSpec(count=4, lifetime=0.2))
        self._call("add_ship", spec, self._vec(data), self._vec(data, speed))

    @precondition(lambda m: not m.broken and len(m.w.actor_ids))
    @rule(data=st.data(), throttle=unit, turn=st.floats(-1.0, 1.0))
    def control(self, data, throttle, turn):
        i = self._pick(data, self.w.actor_ids)
        turn = turn if self.w.dim == 2 else (0.0, turn, -turn)
        self._call("control", i, throttle=throttle, turn=turn)

    @precondition(lambda m: not m.broken and not m.closed and m.w.n > 0)
    @rule(data=st.data(), guided=st.booleans(), recoil=st.booleans())
    def launch(self, data, guided, recoil):
        parent = self._pick(data)
        target = self._pick(data) if guided else None
        spec = sp.MissileSpec(mass=0.1, fuel_mass=0.1, thrust=0.5, exhaust_speed=20.0,
                              lifetime=0.5, launch_speed=1.0, recoil=recoil, radius=0.05,
                              guidance="pn" if guided else "none", fuse_radius=0.1)
        heading = self._vec(data, speed) + 1e-3
        m = self._call("launch", parent, spec, target=target, heading=heading)
        assert m is None or m in self.w

    @precondition(lambda m: not m.broken and not m.closed and m.w.n > 0)
    @rule(data=st.data(), count=st.integers(1, 6))
    def explode(self, data, count):
        i = self._pick(data)
        debris = self._call("explode", i, sp.ExplosionSpec(count=count, lifetime=0.1,
                                                           radius=0.02))
        assert i not in self.w
        assert debris is None or all(d in self.w for d in debris.tolist())

    # ------------------------------------------------------------------ settings
    @precondition(lambda m: not m.broken)
    @rule(data=st.data(), a=st.sampled_from(KINDS), b=st.sampled_from(KINDS + ("*",)))
    def set_collision(self, data, a, b):
        response = data.draw(st.sampled_from(CLOSED_RESPONSES if self.closed
                                             else OPEN_RESPONSES))
        restitution = data.draw(unit) if response == "bounce" else None
        self._call("set_collision", a, b, response, restitution)

    @precondition(lambda m: not m.broken)
    @rule(data=st.data())
    def shift_origin(self, data):
        self._call("shift_origin", self._vec(data))

    # ------------------------------------------------------------------ time
    def _advance(self, name, arg):
        p0 = self.w.momentum()
        scale = float(np.sum(np.abs(self.w.mass[:, None] * self.w.vel)))
        try:
            self._call(name, arg)
        except FloatingPointError as e:
            # InstabilityError (NaN, inf, the energy watch), or a family that cannot go on
            # (a Kepler drift that does not converge): said, and the World kept finite or
            # marked so; it is not driven further
            assert str(e) and (isinstance(e, sp.InstabilityError) or (
                np.all(np.isfinite(self.w.pos)) and np.all(np.isfinite(self.w.vel))))
            self.broken = True
            return
        assert np.all(np.isfinite(self.w.pos)) and np.all(np.isfinite(self.w.vel)), \
            "non-finite state without InstabilityError"
        if self.closed:
            scale = max(scale, float(np.sum(np.abs(self.w.mass[:, None] * self.w.vel))), 1.0)
            # mass is conserved too (merges keep it), so its change is no excuse
            assert np.max(np.abs(self.w.momentum() - p0)) <= 1e-9 * scale, \
                (self.w.momentum(), p0)

    @precondition(lambda m: not m.broken)
    @rule(n=st.integers(1, 8))
    def step(self, n):
        self._advance("step", n)

    @precondition(lambda m: not m.broken)
    @rule(frame=st.floats(0.0, 0.1))
    def advance(self, frame):
        self._advance("advance", frame)

    # ------------------------------------------------------------------ files
    def _continue_alike(self, other, k, what, ref=None):
        """`ref` (default: an unrecorded copy of the World; recording splits a Wisdom-Holman
        run at frames, which changes its rounding) and `other` step k alike, digests too;
        returns the error both raised, or None."""
        ref = self.w.copy() if ref is None else ref
        _same(ref.state(), other.state(), what)
        errors = []
        for world in (ref, other):
            try:
                world.step(k)
                errors.append(None)
            except FloatingPointError as e:
                errors.append(str(e))
        assert errors[0] == errors[1]
        _same(ref.state(), other.state(), f"{what}, then stepped")
        assert ref.digest() == other.digest()
        return errors[0]

    @precondition(lambda m: not m.broken)
    @rule(k=st.integers(1, 5))
    def state_round_trip(self, k):
        loaded = sp.World.from_state(self.w.state())
        assert loaded.digest() == self.w.digest()
        self._continue_alike(loaded, k, "from_state(state())")

    @precondition(lambda m: not m.broken and m.log is None)
    @rule()
    def snapshot(self):
        """A snapshot, with a copy of the World and the model as they were."""
        self.snap = (self.w.snapshot(), self.w.copy(), self.w.digest(), set(self.seen),
                     set(self.dead))

    @precondition(lambda m: not m.broken and m.log is None and m.snap is not None)
    @rule(k=st.integers(1, 5))
    def restore(self, k):
        """restore -> the World as it was, bit for bit, digest and all; then it steps as the
        copy taken at the snapshot does."""
        snap, ref, digest, seen, dead = self.snap
        self.w.restore(snap)
        self.seen, self.dead = set(seen), set(dead)
        assert self.w.digest() == digest
        self.broken = self._continue_alike(self.w, k, "restored", ref=ref.copy()) is not None

    @precondition(lambda m: not m.broken and m.files and not m.saved)
    @rule(k=st.integers(1, 5))
    def save_load_step(self, k):
        """save -> load -> step equals step."""
        self.saved = True
        path = self.tmp / "saved.h5"
        self.w.save(path)
        self._continue_alike(sp.World.load(path), k, "saved and loaded")
        path.unlink()

    @precondition(lambda m: not m.broken and m.files and m.log is None)
    @rule(every=st.sampled_from([1, 3]))
    def record(self, every):
        self.log = self._call("record", self.tmp / "run.h5", every=every)
        assert self.log is not None and self.w.recording is self.log

    @precondition(lambda m: m.broken)
    @rule()
    def broken_worlds_are_left_alone(self):
        """After a breakdown nothing more is asked of the World (a rule must be possible)."""

    # ------------------------------------------------------------------ invariants
    @invariant()
    def ids_match_rows(self):
        if self.w is None:
            return
        ids = self.w.ids
        assert len(set(ids.tolist())) == ids.size == self.w.n
        if ids.size:
            np.testing.assert_array_equal(self.w.index_of(ids), np.arange(ids.size))
        assert all(i in self.w for i in ids.tolist())

    def teardown(self):
        try:
            if self.log is not None:
                self.log.close()
                result = sp.replay(self.tmp / "run.h5")
                assert result.ok, result.message
                _same(result.world.state(), self.w.state(), "replayed")
        finally:
            if self._tmp is not None:
                for f in self._tmp.iterdir():
                    f.unlink()
                self._tmp.rmdir()


# numpy's RuntimeWarnings from legal calls are errors; the World's own warning that Gauss-Radau
# held substeps at min_step (a scene it cannot resolve, found by the long profile: a body of
# mass 5e-79 born on a missile) is what the World should say there
pytestmark = pytest.mark.filterwarnings("error::RuntimeWarning",
                                        "ignore:.*substeps were held at min_step:RuntimeWarning")

WorldMachine.TestCase.settings = settings(
    deadline=None, suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large],
    **FUZZ_PROFILES[PROFILE])
TestWorldAPI = WorldMachine.TestCase
