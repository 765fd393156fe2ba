"""Reading run logs (sp.open_run), resume and replay: what needs both the log format
(runlog.py) and World.
"""
import functools
import json
import os
from collections import namedtuple

import h5py
import numpy as np
from numpy.lib.recfunctions import repack_fields

from . import checksums
from .events import EVENT_KINDS
from .journal import decode
from .runlog import (COUNTS, DAMAGE, FORMAT, LAYOUT, LOG_EVENT_DTYPE, RunLog, RunLogError,
                     _Schedule, checkpoint_state, checkpoint_table, committed, event_rows,
                     open_file)
from .world import World

Frame = namedtuple("Frame", "index step t ids pos vel mass radius kind")
Frame.__doc__ = ("One frame: its index, step and time, and (k,) ids, (k, dim) pos and vel, "
                 "(k,) mass, radius and kind codes of the bodies alive then.")
Trajectory = namedtuple("Trajectory", "t pos vel alive")
Trajectory.__doc__ = ("One body through the frames: (F,) times, (F, dim) pos and vel (NaN "
                      "where it was not alive), (F,) alive.")
ReplayResult = namedtuple("ReplayResult", "ok frames diverged_at max_difference world message")
ReplayResult.__doc__ = ("ok: every frame, every event and the final state equal, bit for "
                        "bit; frames: frames compared; diverged_at: the first frame that "
                        "differs (None); max_difference: its largest |difference|; world: the "
                        "replayed World; message: what differs, where.")


def _same(a, b):
    """Bit-for-bit equal arrays; NaN equals NaN (a replayed breakdown is still the same)."""
    return np.array_equal(a, b, equal_nan=a.dtype.kind == "f")


def _world(f, path, index=-1):
    """(World, attributes) of a checkpoint."""
    state, attrs = checkpoint_state(f, path, index)
    try:
        return World.from_state(state), attrs
    except DAMAGE as e:
        raise RunLogError(f"{path!r}: checkpoint {index} is corrupt ({e})") from None


def _reading(method):
    """A damaged log found while reading (a checksum that fails, a table that does not
    decode) is a RunLogError naming the file, whatever h5py or json said."""
    @functools.wraps(method)
    def read(self, *args, **kwargs):
        try:
            return method(self, *args, **kwargs)
        except RunLogError:
            raise
        except DAMAGE as e:
            raise RunLogError(f"{self.path!r}: corrupt ({type(e).__name__}: {e})") from None
    return read


class Run:
    """A run log opened for reading (sp.open_run): lazy, nothing is loaded until asked for.

    meta: the root attributes (and "closed": whether close() finished the log); times,
    steps: (F,) of the frames; frame(i), frame_at(t), trajectory(id), events(kind=, id=),
    inputs(), checkpoints, world(k). It reads what the writer had committed when the log was
    opened; refresh() reads what it committed since (a log being written opens too)."""

    def __init__(self, path):
        self.path = os.fspath(path)
        self._f = open_file(self.path)
        try:
            self._read_header()
        except Exception:
            self._f.close()
            raise

    @_reading
    def _read_header(self):
        self.meta = {k: (v.item() if isinstance(v, np.generic) else v)
                     for k, v in self._f.attrs.items()}
        self.kinds = tuple(json.loads(self._f["frames"].attrs["kinds"]))
        self._n = None
        self.refresh()

    @_reading
    def refresh(self):
        """Read what the writer committed since (when it is still writing)."""
        if self._f.swmr_mode:
            # the commit first, then the tables: they hold at least the rows it counts
            commit = self._f["commit"]
            commit.refresh()
            self._f.visititems(lambda _, node: node.refresh() if isinstance(
                node, h5py.Dataset) and node != commit else None)
        self._n = n = committed(self._f)
        self.meta["closed"] = bool(n["closed"])
        return self

    @_reading
    def _read(self, name, count):
        """The committed rows of a dataset."""
        return self._f[name][:self._n[count]]

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()

    def close(self):
        """Close the file (also on leaving a with block)."""
        self._f.close()

    def __len__(self):
        return self._n["frames"]

    @property
    def times(self):
        """(F,) the time of each recorded frame [time]."""
        return self._read("frames/t", "frames")

    @property
    def steps(self):
        """(F,) the World's step count at each recorded frame."""
        return self._read("frames/step", "frames")

    def frame(self, index):
        """Recorded frame `index` (negative counts from the end) as a Frame: its index,
        step and time, and the ids, positions, velocities, masses, radii and kind codes of
        the bodies alive then; IndexError outside the log."""
        n = len(self)
        if not -n <= index < n:
            raise IndexError(f"frame {index}: the log holds {n} frames")
        return self._frame(index % n)

    @_reading
    def _frame(self, index):
        fr, lay = self._f["frames"], self._f["layouts"]
        first, count = int(fr["first"][index]), int(fr["count"][index])
        k = int(fr["layout"][index])
        lf = int(lay["first"][k])
        who = [lay[name][lf:lf + count] for name in LAYOUT]
        return Frame(index, int(fr["step"][index]), float(fr["t"][index]), who[0],
                     fr["pos"][first:first + count], fr["vel"][first:first + count], *who[1:])

    def frame_at(self, t):
        """The last frame taken at or before time t."""
        times = self.times
        k = int(np.searchsorted(times, t + 1e-12 * max(abs(t), 1.0), side="right")) - 1
        if k < 0:
            raise IndexError(f"t = {t}: before the first frame (t = {times[0]})")
        return self.frame(k)

    @_reading
    def trajectory(self, body_id):
        """Trajectory of one id through every frame (read in blocks: O(rows) time, O(block)
        memory)."""
        fr, lay = self._f["frames"], self._f["layouts"]
        block = 1 << 20
        # where the id sits in each layout (-1: absent)
        lfirst = self._read("layouts/first", "layouts")
        where = np.full(lfirst.size, -1, np.int64)
        ids = lay["ids"]
        for start in range(0, self._n["layout_rows"], block):
            end = min(start + block, self._n["layout_rows"])
            rows = start + np.flatnonzero(ids[start:end] == body_id)
            layout = np.searchsorted(lfirst, rows, side="right") - 1
            where[layout] = rows - lfirst[layout]
        local = where[self._read("frames/layout", "frames")]
        alive = local >= 0
        F, dim = alive.size, int(self.meta["dim"])
        pos, vel = np.full((F, dim), np.nan), np.full((F, dim), np.nan)
        rows = self._read("frames/first", "frames") + local
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
        if kind is not None:
            names = {v: k for k, v in EVENT_KINDS.items()}
            code = names.get(kind, kind)
            if code not in EVENT_KINDS:
                raise ValueError(f"kind = {kind!r}: not an event kind; valid: "
                                 f"{', '.join(EVENT_KINDS.values())}")
        ev = self._read("events", "events")
        if kind is not None:
            ev = ev[ev["kind"] == code]
        if id is not None:
            ev = ev[(ev["a"] == id) | (ev["b"] == id)]
        return ev

    @_reading
    def inputs(self):
        """The recorded calls, in order: dicts with step, t, call, args, kwargs (and raised,
        the exception it raised, if it did)."""
        n = self._n["inputs"]
        g = self._f["inputs"]
        steps, times = g["step"][:n], g["t"][:n]
        if "text" in g:                                  # version 3: bytes end to end
            first, size = g["first"][:n], g["size"][:n]
            end = int(first[-1] + size[-1]) if n else 0
            text = g["text"][:end].tobytes()
            calls = [text[a:a + b].decode() for a, b in zip(first, size)]
        else:
            calls = g["call"].asstr()[:n]
        out = []
        for s, t, text in zip(steps, times, calls):
            entry = json.loads(text)
            entry.update(step=int(s), t=float(t))
            out.append(entry)
        return out

    @property
    @_reading
    def checkpoints(self):
        """(step, t) of each checkpoint."""
        return [(int(row["step"]), float(row["t"])) for row in checkpoint_table(self._f)]

    @_reading
    def verify(self):
        """Check every committed row against the CRC-32s written with it (reads the whole
        log); a mismatch raises RunLogError naming the table and the rows. Returns the
        number of flushes checked (0 for a log written before spacephys kept them)."""
        return checksums.verify(self._f, self.path, self._n, RunLogError)

    @_reading
    def world(self, checkpoint=-1):
        """The World saved at a checkpoint (default: the last)."""
        return _world(self._f, self.path, checkpoint)[0]


def open_run(path):
    """Open a run log for reading (see Run)."""
    return Run(path)


# ----------------------------------------------------------------------------- resume, replay

def resume(path):
    """Reopen a run log (closed, or left by a killed process) at its last checkpoint: the
    World as it was then, recording again into the same file. Frames, events and inputs after
    that checkpoint are dropped (the calls that made them are not known to this process).
    Returns the World (its log: world.recording)."""
    path = os.fspath(path)
    f = open_file(path, "r+")
    try:
        if f.attrs["format"] != FORMAT:
            raise RunLogError(f"{path!r}: a world file, not a run log: nothing to resume")
        if int(f.attrs["format_version"]) < 3:
            raise RunLogError(f"{path!r}: format version {int(f.attrs['format_version'])}: "
                              f"resume appends to version-3 logs only (this one still "
                              f"reads: sp.open_run, World.load)")
        world, attrs = _world(f, path)
        counts = {name: int(attrs[name]) for name in COUNTS[:6]}
        counts["checkpoints"] = committed(f)["checkpoints"]
        if attrs["extra_frame"]:
            # close()'s frame of the end state, off the schedule: the run goes on from here
            counts["frames"] -= 1
            counts["rows"] = int(f["frames/first"][counts["frames"]])
        image_end = int(attrs["first"]) + int(attrs["size"])
    except Exception:
        f.close()
        raise
    meta = f.attrs
    # RunLog commits the checkpoint's lengths at once; rows past them are overwritten as
    # the run goes on
    world.recording = RunLog(world, path, every=int(meta["every"]) or None,
                             every_time=float(meta["every_time"]) or None,
                             checkpoint_every=int(meta["checkpoint_every"]) or None,
                             checkpoint_seconds=float(meta["checkpoint_seconds"]),
                             flush_seconds=float(meta["flush_seconds"]),
                             _resume=(f, int(attrs["step"]), float(attrs["next_time"]), counts,
                                      image_end))
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
        self.events = []                # the replay's own, as the log holds them

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
        if len(events):
            self.events.append(event_rows(events, self.steps))

    @staticmethod
    def frame_buffers(F, n):
        return np.empty((F, n, 3)), np.empty((F, n, 3)), np.empty((F, n))


def replay(path, each=None):
    """Verify a log's checksums, re-run it from its first checkpoint and its recorded calls,
    and compare every frame, every event and the whole final state (the last checkpoint of a
    closed log) bit for bit. Returns a ReplayResult naming the first difference, if any.
    each : called as each(world, call, result) after every recorded call is re-run (call
    its name, "setattr" for an assignment; result what it returned): to watch a replay,
    e.g. draw the World after each advance(); what it raises ends the replay."""
    if each is not None and not callable(each):
        raise ValueError(f"each = {each!r}: must be callable, or None")
    with Run(path) as run:
        run.verify()                     # a damaged log is an error, not a divergence
        world, attrs = _world(run._f, run.path, 0)
        # checkpoint 0 is taken just after frame 0, at the same step
        rep = _Replayer(run, int(attrs["step"]), world.t)
        rep.take_frame(world)
        world.recording = rep
        for entry in run.inputs():
            method = getattr(world, entry["call"]) if entry["call"] != "setattr" else None
            args, kwargs = decode(entry["args"]), decode(entry["kwargs"])
            result = None
            try:
                if method is None:
                    setattr(world, *args)
                else:
                    result = method(*args, **kwargs)
            except Exception as e:
                if type(e).__name__ != entry.get("raised"):
                    raise
            if each is not None:
                each(world, entry["call"], result)
        closed = bool(run.meta.get("closed"))
        if closed and len(run) > rep.frame_index:
            rep.take_frame(world)                          # close()'s last frame
        frames = rep.frame_index
        world.recording = None
        if rep.diverged is not None:
            k, diff = rep.diverged
            return ReplayResult(False, frames, k, diff, world,
                                f"frame {k} (t = {run.times[k]:g}) differs: largest "
                                f"difference {diff:.3g}")
        if frames != len(run):
            return ReplayResult(False, frames, None, None, world,
                                f"the replay made {frames} frames, the log holds {len(run)}")
        made = np.concatenate(rep.events) if rep.events else np.zeros(0, LOG_EVENT_DTYPE)
        logged = run.events()
        if logged.dtype.names != made.dtype.names:     # a log from before a field was added
            made = repack_fields(made[list(logged.dtype.names)])
        where = _difference(logged, made, "events")
        if where is not None:
            return ReplayResult(False, frames, None, None, world,
                                f"the replay's events differ from the log's: {where}")
        if closed:
            where = _difference(run.world(-1).state(), world.state(), "")
            if where is not None:
                return ReplayResult(False, frames, None, None, world,
                                    f"the final state differs in {where}")
        return ReplayResult(True, frames, None, None, world,
                            f"{frames} recorded frames, the events and the final state equal, bit "
                            f"for bit")


def _difference(a, b, path):
    """Where two states (nested dicts of arrays, numbers, text) or tables differ, bit for bit
    (-0.0 is not 0.0; NaN is NaN): a path like "bodies/vel" or "events[3].t"; None if
    nowhere."""
    if isinstance(a, dict) or isinstance(b, dict):
        if not (isinstance(a, dict) and isinstance(b, dict)) or a.keys() != b.keys():
            return path or "/"
        for key in a:
            where = _difference(a[key], b[key], f"{path}/{key}" if path else key)
            if where is not None:
                return where
        return None
    a, b = np.asarray(a), np.asarray(b)
    if a.shape != b.shape:
        return f"{path} (shape {a.shape} and {b.shape})"
    if a.dtype.names or b.dtype.names:
        if a.dtype.names != b.dtype.names:
            return f"{path} (fields)"
        for name in a.dtype.names:
            if _difference(a[name], b[name], "") is not None:
                row = np.flatnonzero(_unequal(a[name], b[name]))
                return f"{path}[{row[0] if row.size else '?'}].{name}"
        return None
    return f"{path}" if _unequal(a, b).any() else None


def _unequal(a, b):
    """Elementwise: not the same bits (floats), not equal (the rest)."""
    if a.dtype.kind == "f" and b.dtype.kind == "f":
        a64, b64 = a.astype(np.float64), b.astype(np.float64)
        return a64.view(np.uint64) != b64.view(np.uint64)
    if a.dtype.kind in "biu" and b.dtype.kind in "biu" or a.dtype == b.dtype:
        return np.asarray(a != b)
    return np.ones(a.shape, bool)
