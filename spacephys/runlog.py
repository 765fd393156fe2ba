"""HDF5 run logs: frames, events, inputs (every call that changed the World) and
checkpoints; the writer (World.record), the reader (open_run), resume and replay.

Layout (format version 1; docs/runlog.md has every dataset and attribute):

    /                      attrs: format = "spacephys-run", format_version, versions, settings
    /frames/step, t        (F,) int64 / float64: when each frame was taken
    /frames/first, count   (F,) int64: frame f's bodies are rows first[f] : first[f] + count[f]
    /frames/pos, vel       (R, dim) float64: of the live bodies, in the order of its layout
    /frames/layout         (F,) int64: the frame's row in /layouts
    /layouts/first, count  (L,) int64: a layout's rows in...
    /layouts/ids, mass, radius, kind   (Rl,): who the bodies are, written only when they
                           change (bodies added, removed, or a mass or radius changed)
    /events                (E,) compound: "step" and the fields of spacephys.EVENT_DTYPE
    /inputs/step, t, call  (I,): the calls that changed the World, as JSON, in order
    /checkpoints/NNNNNN    the whole World (snapshot.py) and the lengths of the tables then

Writes are buffered in memory and go to the file at each flush (every `flush_seconds` of wall
time, at checkpoints and at close), followed by an HDF5 flush; between flushes the file is not
touched, so a process killed outside a flush leaves a file holding everything flushed.
"""
import dataclasses
import functools
import json
import math
import os
import resource
import time
from collections import namedtuple

import h5py
import numpy as np

from . import snapshot
from .entities import ExplosionSpec, MissileSpec, ShipSpec
from .events import EVENT_DTYPE, EVENT_KINDS

FORMAT = "spacephys-run"
WORLD_FORMAT = "spacephys-world"
FORMAT_VERSION = 1
LOG_EVENT_DTYPE = np.dtype([("step", np.int64)] + EVENT_DTYPE.descr)
_SPECS = {"ShipSpec": ShipSpec, "MissileSpec": MissileSpec, "ExplosionSpec": ExplosionSpec}
_ROWS = ("ids", "pos", "vel", "mass", "radius", "kind")
_LAYOUT = ("ids", "mass", "radius", "kind")
_CHUNK_ROWS = 8192

Frame = namedtuple("Frame", "index step t ids pos vel mass radius kind")
Frame.__doc__ = ("One frame: its index, step and time, and (k,) ids, (k, dim) pos and vel, "
                 "(k,) mass, radius and kind codes of the bodies alive then.")
Trajectory = namedtuple("Trajectory", "t pos vel alive")
Trajectory.__doc__ = ("One body through the frames: (F,) times, (F, dim) pos and vel (NaN "
                      "where it was not alive), (F,) alive.")
ReplayResult = namedtuple("ReplayResult", "ok frames diverged_at max_difference world message")
ReplayResult.__doc__ = ("ok: every frame and the final state equal, bit for bit; frames: "
                        "frames compared; diverged_at: the first frame that differs (None); "
                        "max_difference: its largest |difference|; world: the replayed World.")


def _next_multiple(t, every_time, dt):
    """The first multiple of every_time after t (a hair of dt of slack for rounding)."""
    return (math.floor((t + 1e-9 * dt) / every_time) + 1) * every_time


class RunLogError(ValueError):
    """A run log that cannot be written or read; the message names the file and why."""


# ----------------------------------------------------------------------------- journal

def _encode(value):
    """A call argument as JSON-able data (floats exact: json writes them with repr)."""
    if isinstance(value, np.ndarray):
        return {"__array__": value.tolist(), "dtype": value.dtype.str}
    if isinstance(value, np.generic):
        return value.item()
    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        return {"__spec__": type(value).__name__,
                "fields": {f.name: _encode(getattr(value, f.name))
                           for f in dataclasses.fields(value)}}
    if isinstance(value, (list, tuple)):
        return [_encode(v) for v in value]
    if isinstance(value, dict):
        return {str(k): _encode(v) for k, v in value.items()}
    return value


def _decode(value):
    if isinstance(value, list):
        return [_decode(v) for v in value]
    if isinstance(value, dict):
        if "__array__" in value:
            return np.array(value["__array__"], dtype=np.dtype(value["dtype"]))
        if "__spec__" in value:
            return _SPECS[value["__spec__"]](**{k: _decode(v)
                                               for k, v in value["fields"].items()})
        return {k: _decode(v) for k, v in value.items()}
    return value


def _same(a, b):
    """Bit-for-bit equal arrays; NaN equals NaN (a replayed breakdown is still the same)."""
    return np.array_equal(a, b, equal_nan=a.dtype.kind == "f")


def journaled(method):
    """Wrap a public World method that changes the World: a run log attached to the World
    records the call (the outermost one only: advance() calling step() is one input)."""
    @functools.wraps(method)
    def wrapper(self, *args, **kwargs):
        log = self.__dict__.get("_log")
        if log is None or log.depth:
            return method(self, *args, **kwargs)
        return log.call(self, method.__name__, method, args, kwargs)
    return wrapper


# ----------------------------------------------------------------------------- writing

def _metadata(world, every, every_time, checkpoint_every, checkpoint_seconds, flush_seconds,
              scenario):
    import numba
    from . import __version__
    meta = {"format": FORMAT, "format_version": FORMAT_VERSION, "spacephys_version": __version__,
            "numpy_version": np.__version__, "numba_version": numba.__version__,
            "h5py_version": h5py.__version__, "dim": world.dim, "G": world.G,
            "units": world.units.name, "gravity": world.gravity, "integrator": world.integrator,
            "dt": world.dt, "tolerance": world.tolerance,
            "max_step": world.max_step if world.max_step is not None else math.inf,
            "min_step": world.min_step, "step_control": world.step_control,
            "softening": world.softening, "seed": world._seed,
            "every": every or 0, "every_time": every_time or 0.0,
            "checkpoint_every": checkpoint_every or 0, "checkpoint_seconds": checkpoint_seconds,
            "flush_seconds": flush_seconds,
            "scenario": scenario or "", "created": time.strftime("%Y-%m-%dT%H:%M:%S%z"),
            "closed": False}
    return meta


class _Schedule:
    """When frames fall due (every `every` steps, or at the first step at or past each
    multiple of `every_time`), shared by the writer and the replayer; subclasses take the
    frame in _add_frame(step, t, ids, pos, vel, mass, radius, kind)."""

    def until_frame(self, world):
        """Steps from now to the next frame."""
        if self.every:
            return self.every - self.steps % self.every
        return self._steps_to(world, self._next_time, 1)

    @staticmethod
    def _steps_to(world, when, least):
        """The fewest steps d >= least after which the World's time reaches `when` (with a
        hair of dt of slack), computed as World.t computes the time."""
        base, steps, dt = world._t_base, world._steps, world._dt
        reached = lambda d: base + (steps + d) * dt >= when - 1e-9 * dt
        d = max(least, math.ceil((when - base) / dt - steps - 1e-9))
        while not reached(d):
            d += 1
        while d > least and reached(d - 1):
            d -= 1
        return d

    def frame_offsets(self, world, n, limit):
        """(k,) int64: the step counts in [1, n] from now after which frames fall due, at most
        `limit` of them."""
        if self.every:
            first = self.every - self.steps % self.every
            return np.arange(first, n + 1, self.every, dtype=np.int64)[:limit]
        out, when, d = [], self._next_time, 1
        while len(out) < limit:
            d = self._steps_to(world, when, d)
            if d > n:
                break
            out.append(d)
            t = world._t_base + (world._steps + d) * world._dt
            when = _next_multiple(t, self.every_time, world._dt)
            d += 1
        return np.array(out, dtype=np.int64)

    def stepped(self, world, k):
        """k steps were taken (by a kernel cut at frames): frame when one is due."""
        self.steps += k
        due = self.steps % self.every == 0 if self.every else \
            world.t >= self._next_time - 1e-9 * world.dt
        if due:
            self._world_frame(world)
        self._after_steps()

    def captured(self, world, at, fpos, fvel, fmass, done):
        """A kernel took `done` steps and the frames at the step counts `at` inside it: those
        before the last step are taken here (World has not yet booked the steps or removed
        anyone); the one at the last step, if due, by captured_last once World has."""
        b, dim = world._b, world.dim
        n = b.n
        k = int(np.searchsorted(at, done))              # the frames before the last step
        # rows do not change within a kernel call: who they are is compared once, and the
        # masses (ships burn fuel) frame to frame in one go; the state is where
        # frame_buffers put it
        same = np.ones(k, dtype=bool)
        if k > 1:
            same[1:] = (fmass[1:k] == fmass[:k - 1]).all(axis=1)
        for j in range(k):
            t = world._t_base + (world._steps + int(at[j])) * world._dt
            self._add_frame(self.steps + int(at[j]), t, b.ids[:n], fpos[j, :n, :dim],
                            fvel[j, :n, :dim], fmass[j, :n], b.radius[:n], b.kind[:n],
                            known=j > 0 and same[j], staged=True)
            if self.every_time:
                self._next_time = _next_multiple(t, self.every_time, world.dt)
        self.steps += done

    def captured_last(self, world, at, done):
        """After captured: World has booked the steps and settled removals and debris."""
        if np.any(at == done):
            self._world_frame(world)
        self._after_steps()

    def _world_frame(self, world):
        b, dim = world._b, world.dim
        n = b.n
        self._add_frame(self.steps, world.t, b.ids[:n], b.pos[:n, :dim], b.vel[:n, :dim],
                        b.mass[:n], b.radius[:n], b.kind[:n])
        if self.every_time:
            self._next_time = _next_multiple(world.t, self.every_time, world.dt)

    def _after_steps(self):
        pass


class RunLog(_Schedule):
    """Records a World into an HDF5 file; made by World.record (see there), closed by close()
    or a with-block. Frames every `every` steps or every `every_time` of simulation time,
    the events of every step, every call that changed the World, a checkpoint every
    `checkpoint_seconds` of wall time or `checkpoint_every` frames, whichever comes first (at
    the end of the call in which it fell due)."""

    def __init__(self, world, path, *, every=1, every_time=None, checkpoint_every=None,
                 checkpoint_seconds=10.0, flush_seconds=1.0, compression="gzip",
                 compress_state=False, scenario=None, _resume=None):
        self.path = os.fspath(path)
        self.world = world
        self.depth = 0                   # > 0 inside a journaled call
        self._broken = None
        self._compression = compression
        self._last_flush = time.monotonic()
        self._frames, self._events, self._inputs = [], [], []
        self._layouts, self._layout = [], None      # buffered layouts; the latest one
        # positions and velocities (2, rows, 3), rows used; frame masses for the kernels
        self._stage, self._staged, self._mass = None, 0, None
        self.every, self.every_time = every, every_time
        self.checkpoint_every, self.checkpoint_seconds = checkpoint_every, checkpoint_seconds
        self.flush_seconds = flush_seconds
        self._last_checkpoint = time.monotonic()
        self._since_checkpoint = 0
        self._checkpoint_due = False
        if _resume is not None:
            # an open file truncated to its last checkpoint: (file, steps since the log
            # began, the next every_time frame, the table lengths)
            self._file, self.steps, self._next_time, self._counts = _resume
            return
        self.steps = 0                   # steps since the log began
        self._next_time = world.t        # the first frame: now
        self._counts = {"frames": 0, "rows": 0, "layouts": 0, "layout_rows": 0, "events": 0,
                        "inputs": 0, "checkpoints": 0}
        try:
            self._file = h5py.File(self.path, "w", rdcc_nbytes=0)
        except (OSError, RuntimeError) as e:
            raise RunLogError(f"cannot write the run log {self.path!r}: {e}") from None
        try:
            meta = _metadata(world, every, every_time, checkpoint_every, checkpoint_seconds,
                             flush_seconds, scenario)
            meta.update(compression=compression or "none", compress_state=compress_state)
            self._create(world, meta, compress_state)
            self._world_frame(world)
            self._checkpoint(world)
        except (OSError, RuntimeError, RunLogError) as e:
            self._abandon()
            raise RunLogError(f"cannot write the run log {self.path!r}: {e}") from None

    def _create(self, world, meta, compress_state):
        f = self._file
        f.attrs.update(meta)
        dim = world.dim
        opts = {} if self._compression is None else {"compression": self._compression}
        if self._compression == "gzip":
            opts["compression_opts"] = 1

        def table(group, name, shape, dtype, chunk, compress=True):
            o = opts if compress else {}
            group.create_dataset(name, (0,) + shape, dtype, maxshape=(None,) + shape,
                                 chunks=(chunk,) + shape, shuffle=bool(o), **o)

        frames = f.create_group("frames")
        for name, dtype in (("step", np.int64), ("t", np.float64), ("first", np.int64),
                            ("count", np.int64), ("layout", np.int64)):
            table(frames, name, (), dtype, 4096)
        for name in ("pos", "vel"):
            table(frames, name, (dim,), np.float64, _CHUNK_ROWS, compress_state)
        frames.attrs["kinds"] = json.dumps(list(world.kinds))
        layouts = f.create_group("layouts")
        for name in ("first", "count"):
            table(layouts, name, (), np.int64, 1024)
        for name, dtype in (("ids", np.int64), ("mass", np.float64), ("radius", np.float64),
                            ("kind", np.int16)):
            table(layouts, name, (), dtype, _CHUNK_ROWS)
        table(f, "events", (), LOG_EVENT_DTYPE, 1024)
        f["events"].attrs["kinds"] = json.dumps({str(k): v for k, v in EVENT_KINDS.items()})
        inputs = f.create_group("inputs")
        inputs.create_dataset("step", (0,), np.int64, maxshape=(None,), chunks=(1024,))
        inputs.create_dataset("t", (0,), np.float64, maxshape=(None,), chunks=(1024,))
        inputs.create_dataset("call", (0,), h5py.string_dtype(), maxshape=(None,),
                              chunks=(256,))
        f.create_group("checkpoints")

    # -- what World calls
    def call(self, world, name, method, args, kwargs):
        """Run a journaled call and record it (with the exception it raised, if any)."""
        step, t = self.steps, world.t
        # encoded before the call: an argument may be a view of the state the call changes
        entry = {"call": name, "args": _encode(list(args)), "kwargs": _encode(kwargs)}
        self.depth += 1
        error = None
        try:
            return method(world, *args, **kwargs)
        except Exception as e:
            error = type(e).__name__
            raise
        finally:
            self.depth -= 1
            if error:
                entry["raised"] = error
            self._inputs.append((step, t, json.dumps(entry)))
            due = self._checkpoint_due or \
                time.monotonic() - self._last_checkpoint >= self.checkpoint_seconds
            if due and not error:
                self._checkpoint(world)
            self._maybe_flush()

    def record_events(self, events):
        if len(events):
            rows = np.zeros(len(events), LOG_EVENT_DTYPE)
            for name in EVENT_DTYPE.names:
                rows[name] = events[name]
            rows["step"] = self.steps
            self._events.append(rows)

    # -- frames, checkpoints, flushing
    def frame_buffers(self, F, n):
        """(fpos, fvel (F, n, 3), fmass (F, n)) for a kernel to capture F frames into: the
        state goes straight into the staging rows, in the order the frames will be added."""
        self._reserve(F * n)
        s = self._staged
        if self._mass is None or self._mass.size < F * n:
            self._mass = np.empty(max(F * n, 1 << 14))
        return (self._stage[0, s:s + F * n].reshape(F, n, 3),
                self._stage[1, s:s + F * n].reshape(F, n, 3), self._mass[:F * n].reshape(F, n))

    def _reserve(self, rows):
        """Room for `rows` more staged rows (growing keeps the staged ones)."""
        need = self._staged + rows
        if self._stage is None or need > self._stage.shape[1]:
            # room for what a flush lets pile up (8 MB) and one kernel call's frames more
            grown = np.empty((2, max(2 * need, (8 << 20) // 48 + rows), 3))
            if self._stage is not None:
                grown[:, :self._staged] = self._stage[:, :self._staged]
            self._stage = grown

    def _add_frame(self, step, t, ids, pos, vel, mass, radius, kind, known=False,
                   staged=False):
        """Buffer one frame; known: the bodies are those of the latest layout, masses
        included; staged: pos and vel are already in the staging rows (frame_buffers)."""
        c = self._counts
        last = self._layout
        if not (known or last is not None and last[0].shape == ids.shape and all(
                np.array_equal(a, b) for a, b in zip(last, (ids, mass, radius, kind)))):
            self._layout = tuple(np.array(a) for a in (ids, mass, radius, kind))
            self._layouts.append(self._layout)
            c["layouts"] += 1
        self._frames.append((step, t, c["rows"], ids.size, c["layouts"] - 1))
        # into the staging rows, kept from flush to flush (no allocation per frame)
        n, dim = ids.size, pos.shape[1]
        if not staged:
            self._reserve(n)
            self._stage[0, self._staged:self._staged + n, :dim] = pos
            self._stage[1, self._staged:self._staged + n, :dim] = vel
        self._staged += n
        c["rows"] += n
        self._since_checkpoint += 1
        if self.checkpoint_every and self._since_checkpoint >= self.checkpoint_every:
            self._checkpoint_due = True

    def _after_steps(self):
        self._maybe_flush()

    def _checkpoint(self, world, extra_frame=False):
        """The whole World now, with the table lengths it corresponds to (flushed first);
        extra_frame: the last frame is close()'s, off the schedule (resume drops it)."""
        self.flush()
        self._guarded(self._write_checkpoint, world, extra_frame)
        self._since_checkpoint = 0
        self._checkpoint_due = False
        self._last_checkpoint = time.monotonic()

    def _write_checkpoint(self, world, extra_frame):
        c = self._counts
        b = world._b
        self._room(sum(getattr(b, name).nbytes for name in b.columns))
        group = self._file["checkpoints"].create_group(f"{c['checkpoints']:06d}")
        group.attrs.update({"step": self.steps, "t": world.t, "frames": c["frames"],
                            "rows": c["rows"], "layouts": c["layouts"],
                            "layout_rows": c["layout_rows"], "events": c["events"],
                            "inputs": c["inputs"], "next_time": self._next_time,
                            "extra_frame": extra_frame})
        snapshot.save_world(group.create_group("world"), world)
        c["checkpoints"] += 1
        self._file.flush()

    def _maybe_flush(self):
        # on time, or when the staged state passes 8 MB: a fast run must not pile up, and a
        # small staging area stays warm (first touches of fresh pages cost more here than
        # the copies)
        if time.monotonic() - self._last_flush >= self.flush_seconds or \
                self._staged * 16 * self.world.dim > 8 << 20:
            self.flush()

    def flush(self):
        """Write everything buffered to the file, then flush it to disk."""
        self._guarded(self._write_buffers)
        self._last_flush = time.monotonic()

    def _guarded(self, write, *args):
        if self._broken:
            raise RunLogError(self._broken)
        if self._file is None:
            raise RunLogError(f"the run log {self.path!r} is closed")
        try:
            write(*args)
        except (OSError, RuntimeError) as e:       # h5py reports a failed flush as either
            refused = str(e).startswith("no room")
            self._broken = (f"writing the run log {self.path!r} failed: {e} (is the disk "
                            f"full?). " + (
                                f"The log holds everything up to frame "
                                f"{self._counts['frames'] - 1}" if refused else
                                f"The file may be unreadable past frame "
                                f"{self._counts['frames'] - 1}") +
                            "; nothing more is written to it")
            self._abandon()
            raise RunLogError(self._broken) from None

    def _abandon(self):
        """Close the file after a failed write, ignoring what closing it reports."""
        try:
            self._file.close()
        except Exception:
            pass
        self._file = None

    def _room(self, need):
        """Refuse a write that would not fit on the disk (or under the file size limit)
        before HDF5 starts it: a write that fails half-way can leave the file unreadable."""
        need = 2 * need + (1 << 20)           # chunks are allocated whole; some slack
        folder = os.path.dirname(os.path.abspath(self.path))
        st = os.statvfs(folder)
        free = st.f_bavail * st.f_frsize
        size = os.path.getsize(self.path)
        limit = resource.getrlimit(resource.RLIMIT_FSIZE)[0]
        if limit != resource.RLIM_INFINITY:
            free = min(free, limit - size)
        if need > free:
            raise OSError(f"no room: writing needs about {need} bytes, {max(free, 0)} are "
                          f"free (disk space or the file size limit)")

    def _write_buffers(self):
        f, c = self._file, self._counts
        dim = self.world.dim
        self._room(self._staged * 16 * self.world.dim +
                   sum(a.nbytes for lay in self._layouts for a in lay) +
                   sum(e.nbytes for e in self._events) + sum(len(e[2]) for e in self._inputs))
        if self._layouts:
            first = c["layout_rows"]
            counts = np.array([lay[0].size for lay in self._layouts], np.int64)
            self._append(f["layouts/first"], first + np.cumsum(counts) - counts)
            self._append(f["layouts/count"], counts)
            for k, name in enumerate(_LAYOUT):
                self._append(f["layouts/" + name], np.concatenate([lay[k]
                                                                    for lay in self._layouts]))
            c["layout_rows"] += int(counts.sum())
            self._layouts = []
        if self._frames:
            for k, name in enumerate(("step", "t", "first", "count", "layout")):
                dtype = np.float64 if name == "t" else np.int64
                self._append(f["frames/" + name], np.array([fr[k] for fr in self._frames],
                                                            dtype))
            for k, name in enumerate(("pos", "vel")):
                self._append(f["frames/" + name], self._stage[k, :self._staged, :dim])
            c["frames"] += len(self._frames)
            self._frames, self._staged = [], 0
        if self._events:
            self._append(f["events"], np.concatenate(self._events))
            c["events"] = f["events"].shape[0]
            self._events = []
        if self._inputs:
            self._append(f["inputs/step"], np.array([e[0] for e in self._inputs], np.int64))
            self._append(f["inputs/t"], np.array([e[1] for e in self._inputs]))
            self._append(f["inputs/call"], np.array([e[2] for e in self._inputs], object))
            c["inputs"] += len(self._inputs)
            self._inputs = []
        f.flush()

    @staticmethod
    def _append(dataset, data):
        n = dataset.shape[0]
        dataset.resize(n + len(data), axis=0)
        dataset[n:] = data

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()

    def close(self):
        """Flush, write a last frame (unless one was just taken) and a last checkpoint,
        mark the log closed and stop recording the World."""
        world = self.world
        if self._file is None and not self._broken:
            return
        if world.__dict__.get("_log") is self:
            world._log = None
        if self._file is None:                     # abandoned after a failed write
            return
        try:
            if not self._broken:
                extra = self._frames_at() != self.steps
                if extra:
                    self._world_frame(world)    # the end state, off the frame schedule
                self._checkpoint(world, extra_frame=extra)
                self._file.attrs["closed"] = True
                self._file.flush()
        finally:
            self._file.close()
            self._file = None

    def _frames_at(self):
        """The step of the last frame taken."""
        if self._frames:
            return self._frames[-1][0]
        return int(self._file["frames/step"][-1]) if self._counts["frames"] else -1


# ----------------------------------------------------------------------------- reading

def _open(path, mode="r"):
    path = os.fspath(path)
    if not os.path.exists(path):
        raise RunLogError(f"{path!r}: no such file")
    try:
        f = h5py.File(path, mode)
    except OSError as e:
        text = str(e)
        why = "not an HDF5 file" if "signature" in text else "truncated or corrupt"
        raise RunLogError(f"{path!r}: {why} ({text})") from None
    try:
        kind = f.attrs.get("format")
        if kind not in (FORMAT, WORLD_FORMAT):
            raise RunLogError(f"{path!r}: not a spacephys run log (no format attribute "
                              f"'{FORMAT}'; found {kind!r})")
        version = int(f.attrs.get("format_version", -1))
        if version > FORMAT_VERSION:
            raise RunLogError(f"{path!r}: format version {version} is newer than this "
                              f"spacephys reads ({FORMAT_VERSION}); upgrade spacephys")
        if version < 1:
            raise RunLogError(f"{path!r}: no valid format_version ({version})")
        need = ("world",) if kind == WORLD_FORMAT else \
            ("frames/step", "frames/t", "frames/first", "frames/count", "frames/layout",
             "frames/pos", "frames/vel", "layouts/first", "layouts/count", "layouts/ids",
             "layouts/mass", "layouts/radius", "layouts/kind", "events", "inputs/call",
             "checkpoints")
        for name in need:
            if name not in f:
                raise RunLogError(f"{path!r}: corrupt spacephys log: {name!r} is missing")
    except Exception:
        f.close()
        raise
    return f


def _checkpoint_world(f, path, index=-1):
    names = sorted(f["checkpoints"].keys())
    if not names:
        raise RunLogError(f"{path!r}: the log holds no checkpoint")
    try:
        name = names[index]
    except IndexError:
        raise RunLogError(f"checkpoint {index}: the log {path!r} holds {len(names)}") from None
    group = f["checkpoints"][name]
    try:
        return snapshot.load_world(group["world"]), dict(group.attrs)
    except (KeyError, OSError, ValueError, TypeError) as e:
        raise RunLogError(f"{path!r}: checkpoint {name} is corrupt ({e})") from None


class Run:
    """A run log opened for reading (sp.open_run): lazy, nothing is loaded until asked for.

    meta: the root attributes; times, steps: (F,) of the frames; frame(i), frame_at(t),
    trajectory(id), events(kind=, id=), inputs(), checkpoints, world(k)."""

    def __init__(self, path):
        self.path = os.fspath(path)
        self._f = _open(self.path)
        self.meta = {k: (v.item() if isinstance(v, np.generic) else v)
                     for k, v in self._f.attrs.items()}
        self.kinds = tuple(json.loads(self._f["frames"].attrs["kinds"]))

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()

    def close(self):
        self._f.close()

    def __len__(self):
        return self._f["frames/step"].shape[0]

    @property
    def times(self):
        return self._f["frames/t"][:]

    @property
    def steps(self):
        return self._f["frames/step"][:]

    def frame(self, index):
        n = len(self)
        if not -n <= index < n:
            raise IndexError(f"frame {index}: the log holds {n} frames")
        index %= n
        fr, lay = self._f["frames"], self._f["layouts"]
        first, count = int(fr["first"][index]), int(fr["count"][index])
        k = int(fr["layout"][index])
        lf = int(lay["first"][k])
        who = [lay[name][lf:lf + count] for name in _LAYOUT]
        return Frame(index, int(fr["step"][index]), float(fr["t"][index]), who[0],
                     fr["pos"][first:first + count], fr["vel"][first:first + count], *who[1:])

    def frame_at(self, t):
        """The last frame taken at or before time t."""
        times = self.times
        k = int(np.searchsorted(times, t + 1e-12 * max(abs(t), 1.0), side="right")) - 1
        if k < 0:
            raise IndexError(f"t = {t}: before the first frame (t = {times[0]})")
        return self.frame(k)

    def trajectory(self, body_id):
        """Trajectory of one id through every frame (read in blocks: O(rows) time, O(block)
        memory)."""
        fr, lay = self._f["frames"], self._f["layouts"]
        block = 1 << 20
        # where the id sits in each layout (-1: absent)
        lfirst = lay["first"][:]
        where = np.full(lfirst.size, -1, np.int64)
        ids = lay["ids"]
        for start in range(0, ids.shape[0], block):
            rows = start + np.flatnonzero(ids[start:start + block] == body_id)
            layout = np.searchsorted(lfirst, rows, side="right") - 1
            where[layout] = rows - lfirst[layout]
        local = where[fr["layout"][:]]
        alive = local >= 0
        F, dim = alive.size, int(self.meta["dim"])
        pos, vel = np.full((F, dim), np.nan), np.full((F, dim), np.nan)
        rows = fr["first"][:] + local
        # read the state in blocks of whole rows and pick the id's row in each frame
        frames = np.flatnonzero(alive)
        k = 0
        while k < frames.size:
            lo = rows[frames[k]]
            end = int(np.searchsorted(rows[frames], lo + block, side="left"))
            end = max(end, k + 1)
            hi = rows[frames[end - 1]] + 1
            pick = rows[frames[k:end]] - lo
            pos[frames[k:end]] = fr["pos"][lo:hi][pick]
            vel[frames[k:end]] = fr["vel"][lo:hi][pick]
            k = end
        return Trajectory(self.times, pos, vel, alive)

    def events(self, kind=None, id=None):
        """Events (LOG_EVENT_DTYPE: the step and EVENT_DTYPE's fields), optionally those of
        one kind (name or code) or involving one id (as a or b)."""
        ev = self._f["events"][:]
        if kind is not None:
            names = {v: k for k, v in EVENT_KINDS.items()}
            code = names.get(kind, kind)
            if code not in EVENT_KINDS:
                raise ValueError(f"kind = {kind!r}: not an event kind; valid: "
                                 f"{', '.join(EVENT_KINDS.values())}")
            ev = ev[ev["kind"] == code]
        if id is not None:
            ev = ev[(ev["a"] == id) | (ev["b"] == id)]
        return ev

    def inputs(self):
        """The recorded calls, in order: dicts with step, t, call, args, kwargs (and raised,
        the exception it raised, if it did)."""
        g = self._f["inputs"]
        steps, times = g["step"][:], g["t"][:]
        out = []
        for s, t, text in zip(steps, times, g["call"].asstr()[:]):
            entry = json.loads(text)
            entry.update(step=int(s), t=float(t))
            out.append(entry)
        return out

    @property
    def checkpoints(self):
        """(step, t) of each checkpoint."""
        return [(int(g.attrs["step"]), float(g.attrs["t"]))
                for _, g in sorted(self._f["checkpoints"].items())]

    def world(self, checkpoint=-1):
        """The World saved at a checkpoint (default: the last)."""
        return _checkpoint_world(self._f, self.path, checkpoint)[0]


def open_run(path):
    """Open a run log for reading (see Run)."""
    return Run(path)


# ----------------------------------------------------------------------------- world files

def save_world(world, path):
    """Write the World's whole state to an HDF5 file (World.save)."""
    path = os.fspath(path)
    try:
        with h5py.File(path, "w") as f:
            f.attrs.update({"format": WORLD_FORMAT, "format_version": FORMAT_VERSION})
            snapshot.save_world(f.create_group("world"), world)
    except OSError as e:
        raise RunLogError(f"cannot write {path!r}: {e}") from None


def load_world(path, checkpoint=-1):
    """A World from World.save's file, or from a run log's checkpoint (default: the last)."""
    path = os.fspath(path)
    f = _open(path)
    try:
        if f.attrs["format"] == WORLD_FORMAT:
            try:
                return snapshot.load_world(f["world"])
            except (KeyError, OSError, ValueError, TypeError) as e:
                raise RunLogError(f"{path!r}: corrupt world file ({e})") from None
        return _checkpoint_world(f, path, checkpoint)[0]
    finally:
        f.close()


# ----------------------------------------------------------------------------- resume, replay

def resume(path):
    """Reopen a run log (closed, or left by a killed process) at its last checkpoint: the
    World as it was then, recording again into the same file. Frames, events and inputs after
    that checkpoint are dropped (the calls that made them are not known to this process).
    Returns the World (its log: world.recording)."""
    path = os.fspath(path)
    f = _open(path, "r+")
    try:
        if f.attrs["format"] != FORMAT:
            raise RunLogError(f"{path!r}: a world file, not a run log: nothing to resume")
        world, attrs = _checkpoint_world(f, path)
        names = sorted(f["checkpoints"].keys())
        counts = {"frames": int(attrs["frames"]), "rows": int(attrs["rows"]),
                  "events": int(attrs["events"]), "inputs": int(attrs["inputs"]),
                  "checkpoints": len(names)}
        counts.update(layouts=int(attrs["layouts"]), layout_rows=int(attrs["layout_rows"]))
        if attrs.get("extra_frame"):
            # close()'s frame of the end state, off the schedule: the run goes on from here
            counts["frames"] -= 1
            counts["rows"] = int(f["frames/first"][counts["frames"]])
        for name in ("step", "t", "first", "count", "layout"):
            f["frames/" + name].resize(counts["frames"], axis=0)
        for name in ("pos", "vel"):
            f["frames/" + name].resize(counts["rows"], axis=0)
        for name in ("first", "count"):
            f["layouts/" + name].resize(counts["layouts"], axis=0)
        for name in _LAYOUT:
            f["layouts/" + name].resize(counts["layout_rows"], axis=0)
        f["events"].resize(counts["events"], axis=0)
        for name in ("step", "t", "call"):
            f["inputs/" + name].resize(counts["inputs"], axis=0)
        f.attrs["closed"] = False
        f.flush()
    except Exception:
        f.close()
        raise
    meta = f.attrs
    world._log = RunLog(world, path, every=int(meta["every"]) or None,
                        every_time=float(meta["every_time"]) or None,
                        checkpoint_every=int(meta["checkpoint_every"]) or None,
                        checkpoint_seconds=float(meta["checkpoint_seconds"]),
                        flush_seconds=float(meta["flush_seconds"]),
                        _resume=(f, int(attrs["step"]), float(attrs["next_time"]), counts))
    return world


class _Replayer(_Schedule):
    """Stands in for a RunLog while a log is replayed: the same frame schedule, but each
    frame is compared with the recorded one instead of written."""

    def __init__(self, run, start_steps, next_time):
        meta = run.meta
        self.run = run
        self.every = int(meta["every"]) or None
        self.every_time = float(meta["every_time"]) or None
        self.steps = start_steps
        self._next_time = next_time
        self.frame_index = 0
        self.depth = 0
        self.diverged = None            # (frame, max difference)

    def call(self, world, name, method, args, kwargs):
        self.depth += 1
        try:
            return method(world, *args, **kwargs)
        finally:
            self.depth -= 1

    def _add_frame(self, step, t, ids, pos, vel, mass, radius, kind, known=False,
                   staged=False):
        k = self.frame_index
        self.frame_index += 1
        if self.diverged is not None or k >= len(self.run):
            return
        fr = self.run.frame(k)
        mine = (ids, pos, vel, mass, radius, kind)
        theirs = (fr.ids, fr.pos, fr.vel, fr.mass, fr.radius, fr.kind)
        same = fr.step == step and fr.t == t and all(
            a.shape == r.shape and _same(a, r) for a, r in zip(mine, theirs))
        if not same:
            diff = np.inf
            if pos.shape == fr.pos.shape and np.array_equal(ids, fr.ids):
                diff = float(max(np.max(np.abs(pos - fr.pos), initial=0.0),
                                 np.max(np.abs(vel - fr.vel), initial=0.0)))
            self.diverged = (k, diff)

    def record_events(self, events):
        pass

    @staticmethod
    def frame_buffers(F, n):
        return np.empty((F, n, 3)), np.empty((F, n, 3)), np.empty((F, n))


def replay(path):
    """Re-run a log from its first checkpoint and its recorded calls; compare every frame
    and the final state (the last checkpoint of a closed log) bit for bit. Returns a
    ReplayResult naming the first frame that differs, if one does."""
    with Run(path) as run:
        world, attrs = _checkpoint_world(run._f, run.path, 0)
        # checkpoint 0 is taken just after frame 0, at the same step
        rep = _Replayer(run, int(attrs["step"]), world.t)
        rep._world_frame(world)
        world._log = rep
        for entry in run.inputs():
            method = getattr(type(world), entry["call"]) if entry["call"] != "setattr" else None
            args, kwargs = _decode(entry["args"]), _decode(entry["kwargs"])
            try:
                if method is None:
                    object.__setattr__(world, *args)
                else:
                    method(world, *args, **kwargs)
            except Exception as e:
                if type(e).__name__ != entry.get("raised"):
                    raise
        closed = bool(run.meta.get("closed"))
        if closed and len(run) > rep.frame_index:
            rep._world_frame(world)                          # close()'s last frame
        frames = rep.frame_index
        world._log = None
        if rep.diverged is not None:
            k, diff = rep.diverged
            return ReplayResult(False, frames, k, diff, world,
                                f"frame {k} (t = {run.times[k]:g}) differs: largest "
                                f"difference {diff:.3g}")
        if frames != len(run):
            return ReplayResult(False, frames, None, None, world,
                                f"the replay made {frames} frames, the log holds {len(run)}")
        if closed:
            final = run.world(-1)
            n = final._b.n
            for name in ("ids", "pos", "vel", "mass", "radius", "kind"):
                if not _same(getattr(final._b, name)[:n], getattr(world._b, name)[:world._b.n]) \
                        or final.t != world.t:
                    return ReplayResult(False, frames, None, None, world,
                                        f"the final state differs in {name}")
        return ReplayResult(True, frames, None, None, world,
                            f"{frames} frames and the final state equal, bit for bit")
