"""HDF5 run logs: the writer (World.record), the file format, and World state files.

Layout (format version 3; docs/runlog.md has every dataset and attribute):

    /                      attrs: format = "spacephys-run", format_version, versions, settings
    /frames/step, t        (F,) int64 / float64: when each frame was taken
    /frames/first, count   (F,) int64: frame f's bodies are rows first[f] : first[f] + count[f]
    /frames/pos, vel       (R, dim) float64: of the live bodies, in the order of its layout
    /frames/layout         (F,) int64: the frame's row in /layouts
    /layouts/first, count  (L,) int64: a layout's rows in...
    /layouts/ids, mass, radius, kind   (Rl,): who the bodies are, written only when they
                           change (bodies added, removed, or a mass or radius changed)
    /events                (E,) compound: "step" and the fields of spacephys.EVENT_DTYPE
    /inputs/step, t, first, size   (I,): the calls that changed the World, in order: their
    /inputs/text           JSON is text[first : first + size] (UTF-8)
    /checkpoints/table     (C,) compound: each checkpoint's step, time, the lengths of the
                           tables then, and where its image lies in
    /checkpoints/image     (B,) uint8: world files (World.save's format) end to end
    /commit                () compound: the lengths of the tables that count, and `closed`
    /writer                (2,) int64: the process writing the file (pid, start time)

Crash-proof by design: the file is made complete (frame 0, checkpoint 0) under a temporary
name and renamed into place, then written in HDF5's SWMR mode, which orders its writes so
that the file is readable whenever the writer stops. Writes are buffered in memory and go to
the file at each flush (every `flush_seconds` of wall time, at checkpoints and at close):
the rows are appended and flushed, then /commit takes the new lengths in one small write and
is flushed. A reader reads only the committed rows, so a kill at any moment leaves a log
holding everything committed before it; rows past the commit are overwritten by resume.
HDF5 refuses a plain open of a file whose SWMR writer died (its superblock says a writer
holds it): open_file sees from /writer that the process is gone and clears that
(h5writer.py).
Reading, resume and replay are in runs.py; this module knows nothing of World but its public
surface (the recorder's side of World.record).
"""
import io
import json
import math
import os
import resource
import time
import zlib

import h5py
import numpy as np

from . import checksums, h5writer, statefile
from .driver import FRAME_BYTES_PER_BODY
from .events import EVENT_DTYPE, EVENT_KINDS
from .journal import encode

FORMAT = "spacephys-run"
WORLD_FORMAT = "spacephys-world"
FORMAT_VERSION = 3
LOG_EVENT_DTYPE = np.dtype([("step", np.int64)] + EVENT_DTYPE.descr)
LAYOUT = ("ids", "mass", "radius", "kind")
# the lengths of the tables that count (/commit), and whether close() finished
COUNTS = ("frames", "rows", "layouts", "layout_rows", "events", "inputs", "checkpoints")
COMMIT_DTYPE = np.dtype([(name, np.int64) for name in COUNTS + ("closed", "crc")])
# a checkpoint: when, the lengths of the tables then, the every_time schedule, whether the
# last frame is close()'s (off the schedule), and its world file's bytes in /checkpoints/image
CHECKPOINT_DTYPE = np.dtype(
    [("step", np.int64), ("t", np.float64)] + [(name, np.int64) for name in COUNTS[:6]] +
    [("next_time", np.float64), ("extra_frame", np.int8), ("first", np.int64),
     ("size", np.int64)])
# SWMR needs HDF5 1.10's file format; no newer one, so HDF5 1.10 and later read the logs
LIBVER = ("v110", "v110")
_CHUNK_ROWS = 8192


def event_rows(events, step):
    """(E,) LOG_EVENT_DTYPE: a step's events (EVENT_DTYPE) with the step they happened in."""
    rows = np.zeros(len(events), LOG_EVENT_DTYPE)
    for name in EVENT_DTYPE.names:
        rows[name] = events[name]
    rows["step"] = step
    return rows


def _next_multiple(t, every_time, dt):
    """The first multiple of every_time after t (a hair of dt of slack for rounding)."""
    return (math.floor((t + 1e-9 * dt) / every_time) + 1) * every_time


class RunLogError(ValueError):
    """A run log that cannot be written or read; the message names the file and why."""


# what h5py, numpy and json raise on a damaged file (a failed checksum, a missing or
# mistyped node, bytes that do not decode): a reader turns them into RunLogError
DAMAGE = (OSError, KeyError, ValueError, TypeError, AttributeError, RuntimeError, IndexError)


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
            "softening": world.softening, "seed": world.seed,
            "every": every or 0, "every_time": every_time or 0.0,
            "checkpoint_every": checkpoint_every or 0, "checkpoint_seconds": checkpoint_seconds,
            "flush_seconds": flush_seconds,
            "scenario": scenario or "", "created": time.strftime("%Y-%m-%dT%H:%M:%S%z")}
    return meta


class _Schedule:
    """When frames fall due (every `every` steps, or at the first step at or past each
    multiple of `every_time`), shared by the writer and the replayer; subclasses take the
    frame in _add_frame(step, t, ids, pos, vel, mass, radius, kind)."""

    @staticmethod
    def frame_room(capacity):
        """Frames one kernel call may capture (World's step driver, driver.py): buffers of at
        most 8 MB, 256 frames."""
        return max(1, min(256, (8 << 20) // (FRAME_BYTES_PER_BODY * capacity)))

    def until_frame(self, world):
        """Steps from now to the next frame."""
        if self.every:
            return self.every - self.steps % self.every
        return self._steps_to(world, self._next_time, 1)

    @staticmethod
    def _steps_to(world, when, least):
        """The fewest steps d >= least after which the World's time reaches `when` (with a
        hair of dt of slack), computed as World.t computes the time."""
        dt = world.dt
        reached = lambda d: world.time_after(d) >= when - 1e-9 * dt
        d = max(least, math.ceil((when - world.t) / dt - 1e-9))
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
            t = world.time_after(d)
            when = _next_multiple(t, self.every_time, world.dt)
            d += 1
        return np.array(out, dtype=np.int64)

    def stepped(self, world, k):
        """k steps were taken (by a kernel cut at frames): frame when one is due."""
        self.steps += k
        due = self.steps % self.every == 0 if self.every else \
            world.t >= self._next_time - 1e-9 * world.dt
        if due:
            self.take_frame(world)
        self._after_steps()

    def captured(self, world, at, fpos, fvel, fmass, done):
        """A kernel took `done` steps and the frames at the step counts `at` inside it: those
        before the last step are taken here (World has not yet booked the steps or removed
        anyone); the one at the last step, if due, by captured_last once World has."""
        ids, radius, kind = world.ids, world.radius, world.kind
        dim = world.dim
        k = int(np.searchsorted(at, done))              # the frames before the last step
        # rows do not change within a kernel call: who they are is compared once, and the
        # masses (ships burn fuel) frame to frame in one go; the state is where
        # frame_buffers put it
        same = np.ones(k, dtype=bool)
        if k > 1:
            same[1:] = (fmass[1:k] == fmass[:k - 1]).all(axis=1)
        for j in range(k):
            t = world.time_after(int(at[j]))
            self._add_frame(self.steps + int(at[j]), t, ids, fpos[j, :, :dim], fvel[j, :, :dim],
                            fmass[j], radius, kind, known=j > 0 and same[j], staged=True)
            if self.every_time:
                self._next_time = _next_multiple(t, self.every_time, world.dt)
        self.steps += done

    def captured_last(self, world, at, done):
        """After captured: World has booked the steps and settled removals and debris."""
        if np.any(at == done):
            self.take_frame(world)
        self._after_steps()

    def take_frame(self, world):
        self._add_frame(self.steps, world.t, world.ids, world.pos, world.vel, world.mass,
                        world.radius, world.kind)
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
                 checkpoint_seconds=10.0, flush_seconds=1.0, compression=None,
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
            # a file opened for writing at its last checkpoint: (file, steps since the log
            # began, the next every_time frame, the table lengths then, where the next
            # checkpoint's image goes)
            self._file, self.steps, self._next_time, self._counts, self._image_end = _resume
            n = self._counts["inputs"]
            self._text_end = int(self._file["inputs/first"][n - 1] +
                                 self._file["inputs/size"][n - 1]) if n else 0
            self._resume_checksums()        # before SWMR mode: it cuts /flushes back
            self._start_writing()
            self._commit()                  # the tables cut back to the checkpoint
            return
        self.steps = 0                   # steps since the log began
        self._next_time = world.t        # the first frame: now
        self._counts = dict.fromkeys(COUNTS, 0)
        self._image_end = self._text_end = 0       # bytes used in checkpoints/image, inputs/text
        # the CRC-32s of the rows appended since the last flush row (checksums.py), the
        # flush rows written and the lengths the last one recorded
        self._crc, self._flush_rows, self._sealed = {}, 0, None
        # made whole under another name, then renamed: a kill leaves no half-made log
        part = _part(self.path)
        try:
            self._file = h5py.File(part, "w", libver=LIBVER, rdcc_nbytes=0)
        except (OSError, RuntimeError) as e:
            raise RunLogError(f"cannot write the run log {self.path!r}: {e}") from None
        try:
            meta = _metadata(world, every, every_time, checkpoint_every, checkpoint_seconds,
                             flush_seconds, scenario)
            meta.update(compression=compression or "none", compress_state=compress_state)
            self._create(world, meta, compress_state)
            self.take_frame(world)
            self._checkpoint(world)
            self._file["writer"][:] = h5writer.writer_id()   # named before it is in place
            self._file.close()
            os.replace(part, self.path)
            # opened straight in SWMR mode: a kill at any moment after the rename leaves a
            # file whose flags say SWMR and whose writer is named, which readers open (and
            # open_file clears once the writer is dead); "r+" then swmr_mode left an instant
            # where the flags said a plain writer held it, which nothing could tell apart
            # from another program's
            self._file = _open_swmr_writer(self.path)
            self._start_writing()
        except (OSError, RuntimeError, RunLogError) as e:
            self._abandon()
            if os.path.exists(part):
                os.remove(part)
            raise RunLogError(f"cannot write the run log {self.path!r}: {e}") from None

    def _start_writing(self):
        """SWMR mode from here on (readers may follow; a kill leaves a readable file), and
        this process named as the writer."""
        if not self._file.swmr_mode:      # a new log is opened in it (_open_swmr_writer)
            self._file.swmr_mode = True
        self._file["writer"][:] = h5writer.writer_id()
        self._file.flush()

    def _create(self, world, meta, compress_state):
        f = self._file
        f.attrs.update(meta)
        dim = world.dim
        opts = {} if self._compression is None else {"compression": self._compression}
        if self._compression == "gzip":
            opts["compression_opts"] = 1

        def table(group, name, shape, dtype, chunk, compress=True):
            # A compressed chunk gets a checksum (fletcher32: a damaged row is an error, not
            # a number): its size changes as rows are appended, so HDF5 writes it anew
            # elsewhere and a kill mid-write leaves the old one. A raw chunk is rewritten in
            # place, where a kill can tear the write: the rows it held are rewritten with the
            # same bytes, and only a checksum over the whole chunk would break.
            o = opts if compress else {}
            group.create_dataset(name, (0,) + shape, dtype, maxshape=(None,) + shape,
                                 chunks=(chunk,) + shape, shuffle=bool(o),
                                 fletcher32=bool(o), **o)

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
        table(inputs, "step", (), np.int64, 1024)
        table(inputs, "t", (), np.float64, 1024)
        # the calls' JSON as bytes end to end (variable-length strings are not SWMR-safe:
        # HDF5's global heap is not written in order)
        table(inputs, "first", (), np.int64, 1024)
        table(inputs, "size", (), np.int64, 1024)
        table(inputs, "text", (), np.uint8, 1 << 16)
        checkpoints = f.create_group("checkpoints")
        table(checkpoints, "table", (), CHECKPOINT_DTYPE, 64)
        # world files, whose arrays statefile compresses already
        table(checkpoints, "image", (), np.uint8, 1 << 16, compress=False)
        checksums.create(f)
        f.create_dataset("commit", (), COMMIT_DTYPE, data=np.zeros((), COMMIT_DTYPE))
        f.create_dataset("writer", (2,), np.int64, data=np.array(h5writer.writer_id()))

    # -- what World calls
    def call(self, world, name, method, args, kwargs):
        """Run a journaled call and record it (with the exception it raised, if any)."""
        step, t = self.steps, world.t
        # encoded before the call: an argument may be a view of the state the call changes
        entry = {"call": name, "args": encode(list(args)), "kwargs": encode(kwargs)}
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
            # a plan is checkpointed as it is set: its prediction can be made again from
            # there (spacephys plot draws it beside the flown path)
            due = self._checkpoint_due or name == "plan" or \
                time.monotonic() - self._last_checkpoint >= self.checkpoint_seconds
            if due and not error:
                self._checkpoint(world)
            self._maybe_flush()

    def record_events(self, events):
        if len(events):
            self._events.append(event_rows(events, self.steps))

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
        image = world_image(world.state())
        self._room(image.size)
        f = self._file
        row = np.zeros((), CHECKPOINT_DTYPE)
        row["step"], row["t"], row["next_time"] = self.steps, world.t, self._next_time
        for name in COUNTS[:6]:
            row[name] = c[name]
        row["extra_frame"], row["first"], row["size"] = extra_frame, self._image_end, image.size
        self._append(f["checkpoints/image"], self._image_end, image)
        self._append(f["checkpoints/table"], c["checkpoints"], row[None])
        c["checkpoints"] += 1
        self._image_end += image.size
        self._seal()
        f.flush()
        self._commit()

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
        free = room(self.path, os.path.getsize(self._file.filename))
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
            at = c["layouts"] - len(self._layouts)       # counted as they were buffered
            counts = np.array([lay[0].size for lay in self._layouts], np.int64)
            self._append(f["layouts/first"], at, first + np.cumsum(counts) - counts)
            self._append(f["layouts/count"], at, counts)
            for k, name in enumerate(LAYOUT):
                self._append(f["layouts/" + name], first,
                             np.concatenate([lay[k] for lay in self._layouts]))
            c["layout_rows"] += int(counts.sum())
            self._layouts = []
        if self._frames:
            for k, name in enumerate(("step", "t", "first", "count", "layout")):
                dtype = np.float64 if name == "t" else np.int64
                self._append(f["frames/" + name], c["frames"],
                             np.array([fr[k] for fr in self._frames], dtype))
            for k, name in enumerate(("pos", "vel")):
                self._append(f["frames/" + name], c["rows"] - self._staged,
                             self._stage[k, :self._staged, :dim])
            c["frames"] += len(self._frames)
            self._frames, self._staged = [], 0
        if self._events:
            events = np.concatenate(self._events)
            self._append(f["events"], c["events"], events)
            c["events"] += events.size
            self._events = []
        if self._inputs:
            at = c["inputs"]
            self._append(f["inputs/step"], at, np.array([e[0] for e in self._inputs],
                                                        np.int64))
            self._append(f["inputs/t"], at, np.array([e[1] for e in self._inputs]))
            texts = [e[2].encode() for e in self._inputs]
            size = np.array([len(b) for b in texts], np.int64)
            self._append(f["inputs/first"], at, self._text_end + np.cumsum(size) - size)
            self._append(f["inputs/size"], at, size)
            self._append(f["inputs/text"], self._text_end,
                         np.frombuffer(b"".join(texts), np.uint8))
            self._text_end += int(size.sum())
            c["inputs"] += len(self._inputs)
            self._inputs = []
        self._seal()
        f.flush()
        self._commit()

    def _lengths(self):
        return np.array([self._counts[name] for name in COUNTS] +
                        [self._text_end, self._image_end], np.int64)

    def _seal(self):
        """A flush row (checksums.py) for the rows appended since the last one, if any."""
        lengths = self._lengths()
        if self._sealed is not None and np.array_equal(lengths, self._sealed):
            return
        g, k = self._file["flushes"], self._flush_rows
        crcs = np.array([self._crc.get(name, 0) for name, _ in checksums.CHECKED], np.int64)
        for name, row in (("lengths", lengths), ("crc", crcs)):
            g[name].resize(k + 1, axis=0)
            g[name][k] = row
        self._flush_rows, self._crc, self._sealed = k + 1, {}, lengths

    def _resume_checksums(self):
        """Resumed at a checkpoint: keep the flush rows within its lengths (the others
        checked rows that are being replaced), and carry the CRC-32s of the rows after the
        last kept one into the next. A log written before checksums gets them from here."""
        f = self._file
        if "flushes" not in f:
            checksums.create(f)
        lengths = self._lengths()
        kept, _ = checksums.valid(f, dict(zip(checksums.LENGTHS, lengths)))
        for name in ("lengths", "crc"):
            f["flushes"][name].resize(kept.shape[0], axis=0)
        start = kept[-1] if kept.shape[0] else np.zeros_like(lengths)
        self._crc = checksums.carry(f, start, lengths)
        self._flush_rows = kept.shape[0]
        self._sealed = start
        self._seal()                 # every commit has its flush row

    def _commit(self, closed=False):
        """The rows written and flushed so far become the log's: one write of /commit, then
        flushed (a kill before it leaves the previous lengths, after it the new ones)."""
        commit = np.zeros((), COMMIT_DTYPE)
        for name in COUNTS:
            commit[name] = self._counts[name]
        commit["closed"] = closed
        commit["crc"] = _crc(commit)
        self._file["commit"][()] = commit
        self._file.flush()

    def _append(self, dataset, at, data):
        """Write rows from `at` on (rows past it, left by a killed writer, are replaced),
        and carry them into the table's CRC-32 as they will read back."""
        dataset.resize(at + len(data), axis=0)
        dataset[at:] = data
        name = dataset.name[1:]
        self._crc[name] = checksums.crc(np.asarray(data, dataset.dtype), self._crc.get(name, 0))

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
        if world.recording is self:
            world.recording = None
        if self._file is None:                     # abandoned after a failed write
            return
        try:
            if not self._broken:
                extra = self._frames_at() != self.steps
                if extra:
                    self.take_frame(world)    # the end state, off the frame schedule
                self._checkpoint(world, extra_frame=extra)
                self._guarded(self._commit, True)
        finally:
            self._file.close()
            self._file = None

    def _frames_at(self):
        """The step of the last frame taken."""
        if self._frames:
            return self._frames[-1][0]
        n = self._counts["frames"]
        return int(self._file["frames/step"][n - 1]) if n else -1


def _part(path):
    """Where a file for `path` is made before it is renamed into place (a kill leaves the
    old file or the new one, never half of one)."""
    return os.path.join(os.path.dirname(os.path.abspath(path)),
                        f".{os.path.basename(path)}.{os.getpid()}.part")


def room(path, size=0):
    """Bytes a file at `path`, now `size` bytes long, may still grow by: the free disk
    space, or the process's file size limit if that is less."""
    st = os.statvfs(os.path.dirname(os.path.abspath(path)))
    free = st.f_bavail * st.f_frsize
    limit = resource.getrlimit(resource.RLIMIT_FSIZE)[0]
    if limit != resource.RLIM_INFINITY:
        free = min(free, limit - size)
    return free


def expected_size(n, dim, frames):
    """About how many bytes a log of `frames` frames of n bodies takes: their positions and
    velocities, a frame's row, and a megabyte for the rest (the tables' first chunks, the
    checkpoints of a small scene)."""
    return frames * (n * dim * 16 + 40) + (1 << 20)


# ----------------------------------------------------------------------------- files

def world_image(state):
    """A World file (World.save's format) holding `state`, as (B,) uint8 bytes: what a
    checkpoint stores."""
    with h5py.File(f"world-{id(state)}", "w", driver="core", backing_store=False,
                   libver=LIBVER) as f:
        f.attrs.update({"format": WORLD_FORMAT, "format_version": FORMAT_VERSION})
        statefile.write(f.create_group("world"), state)
        f.flush()
        return np.frombuffer(f.id.get_file_image(), np.uint8)


def _open_swmr_writer(path):
    """An h5py File of the log at `path` opened for writing in SWMR mode in one call (HDF5's
    SWMR_WRITE access flag; h5py's File takes it for reading only), the chunk cache off as
    the log writes it."""
    fapl = h5py.h5p.create(h5py.h5p.FILE_ACCESS)
    fapl.set_libver_bounds(h5py.h5f.LIBVER_V110, h5py.h5f.LIBVER_V110)
    fapl.set_fclose_degree(h5py.h5f.CLOSE_STRONG)
    mdc, nslots, _nbytes, w0 = fapl.get_cache()
    fapl.set_cache(mdc, nslots, 0, w0)
    fid = h5py.h5f.open(os.fsencode(path), h5py.h5f.ACC_RDWR | h5py.h5f.ACC_SWMR_WRITE,
                        fapl=fapl)
    return h5py.File(fid)


def open_file(path, mode="r"):
    """An h5py File of a spacephys log or world file, its format checked; RunLogError naming
    the file and the problem otherwise. A log whose writer was killed opens (its flags
    cleared, see h5writer); one being written opens for reading in SWMR mode (follow it with
    Run.refresh) and is refused for writing. Version-1 files open (their frames, events and
    inputs read as before); their checkpoints are refused by checkpoint_state."""
    path = os.fspath(path)
    if not os.path.exists(path):
        raise RunLogError(f"{path!r}: no such file")
    if os.path.isdir(path):
        raise RunLogError(f"{path!r}: a folder, not a file")
    try:
        if h5writer.flags_set(path):
            writer = _writer(path)
            if writer is None:
                raise RunLogError(f"{path!r}: held open for writing by a program other than "
                                  f"spacephys, or left so by one that was killed")
            if writer[1] and mode != "r":
                raise RunLogError(f"{path!r}: being written by process {writer[0]} (close "
                                  f"its log first)")
            if not writer[1] and not h5writer.clear_flags(path):
                raise RunLogError(f"{path!r}: corrupt (its superblock does not check)")
        if h5writer.flags_set(path):                   # a live writer: follow it
            f = h5py.File(path, "r", swmr=True)
        else:
            f = h5py.File(path, mode, **({} if mode == "r" else {"libver": LIBVER}))
    except DAMAGE as e:
        if isinstance(e, RunLogError):
            raise
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
             "layouts/mass", "layouts/radius", "layouts/kind", "events", "inputs/step",
             "inputs/t", "checkpoints") + (
                ("commit", "writer", "checkpoints/table", "checkpoints/image", "inputs/first",
                 "inputs/size", "inputs/text") if version >= 3 else ("inputs/call",))
        for name in need:
            if name not in f:
                raise RunLogError(f"{path!r}: corrupt spacephys log: {name!r} is missing")
    except Exception as e:
        f.close()
        if isinstance(e, DAMAGE) and not isinstance(e, RunLogError):
            raise RunLogError(f"{path!r}: corrupt ({type(e).__name__}: {e})") from None
        raise
    return f


def _writer(path):
    """(pid, alive) of the process named as the log's writer, or None if none can be read."""
    try:
        with h5py.File(path, "r", swmr=True) as f:
            pid, start = (int(x) for x in f["writer"][:])
    except (OSError, KeyError, ValueError, TypeError):
        return None
    return pid, h5writer.alive(pid, start)


def committed(f):
    """The lengths of the tables that count (COUNTS) and `closed`, as a dict: /commit's in a
    version-3 log, the datasets' own in older ones."""
    if "commit" in f:
        commit = f["commit"][()]
        if int(commit["crc"]) != _crc(commit):
            raise RunLogError(f"{f.filename!r}: corrupt: /commit does not match its checksum")
        n = {name: int(commit[name]) for name in COMMIT_DTYPE.names[:-1]}
        for name, table in (("frames", "frames/step"), ("rows", "frames/pos"),
                            ("layouts", "layouts/first"), ("layout_rows", "layouts/ids"),
                            ("events", "events"), ("inputs", "inputs/first"),
                            ("checkpoints", "checkpoints/table")):
            if not 0 <= n[name] <= f[table].shape[0]:
                raise RunLogError(f"{f.filename!r}: corrupt: /commit counts {n[name]} "
                                  f"{name}, {table} holds {f[table].shape[0]}")
        return n
    ckpt = f["checkpoints"]
    n = {"frames": f["frames/step"].shape[0], "rows": f["frames/pos"].shape[0],
         "layouts": f["layouts/first"].shape[0], "layout_rows": f["layouts/ids"].shape[0],
         "events": f["events"].shape[0], "inputs": f["inputs/step"].shape[0],
         "checkpoints": len(ckpt), "closed": int(bool(f.attrs.get("closed", False)))}
    return n


def _crc(commit):
    """CRC-32 of a commit's counts (every field but crc)."""
    return zlib.crc32(np.array([commit[name] for name in COMMIT_DTYPE.names[:-1]],
                               np.int64).tobytes())


def checkpoint_table(f):
    """(C,) CHECKPOINT_DTYPE rows of the committed checkpoints (version 2: from the groups'
    attributes, first = -1)."""
    n = committed(f)["checkpoints"]
    if "table" in f["checkpoints"]:
        return f["checkpoints/table"][:n]
    table = np.zeros(n, CHECKPOINT_DTYPE)
    for k, (_, g) in enumerate(sorted(f["checkpoints"].items())):
        for name in CHECKPOINT_DTYPE.names:
            table[k][name] = g.attrs.get(name, -1)
    return table


def _state(group, path, what, version):
    """The state in `group` (a checkpoint's or a world file's "world"), from a file of
    format `version`."""
    if version < 2:
        raise RunLogError(
            f"{path!r}: format version {version}: its {what} holds a World in the layout of "
            f"spacephys 0.1 (private attributes), which this spacephys (format "
            f"{FORMAT_VERSION}) does not read; its frames, events and inputs still do "
            f"(sp.open_run). Re-run the scenario to get a version-{FORMAT_VERSION} file.")
    try:
        return statefile.read(group)
    except DAMAGE as e:
        raise RunLogError(f"{path!r}: {what} is corrupt ({type(e).__name__}: {e})") from None


def checkpoint_state(f, path, index=-1):
    """(state, attributes) of checkpoint `index` of an open log."""
    table = checkpoint_table(f)
    if not table.size:
        raise RunLogError(f"{path!r}: the log holds no checkpoint")
    try:
        row = table[index]
    except IndexError:
        raise RunLogError(f"checkpoint {index}: the log {path!r} holds "
                          f"{table.size}") from None
    attrs = {name: row[name].item() for name in CHECKPOINT_DTYPE.names}
    what = f"checkpoint {index % table.size}"
    version = int(f.attrs["format_version"])
    if "table" not in f["checkpoints"]:                     # versions 1, 2: a group each
        group = f["checkpoints"][sorted(f["checkpoints"].keys())[index]]
        if "world" not in group:
            raise RunLogError(f"{path!r}: {what} is corrupt (no world)")
        return _state(group["world"], path, what, version), attrs
    if version < 2:
        _state(None, path, what, version)
    first, size = int(row["first"]), int(row["size"])
    image = f["checkpoints/image"]
    if first < 0 or size <= 0 or first + size > image.shape[0]:
        raise RunLogError(f"{path!r}: {what} is corrupt (its image lies outside the file)")
    try:
        with h5py.File(io.BytesIO(image[first:first + size].tobytes()), "r") as world:
            return _state(world["world"], path, what, version), attrs
    except DAMAGE as e:
        raise RunLogError(f"{path!r}: {what} is corrupt ({e})") from None


def save_state(state, path):
    """Write a World's state (World.save) to an HDF5 world file: written under another name
    and renamed into place, so a kill leaves the old file or the new one."""
    path = os.fspath(path)
    part = _part(path)
    try:
        with open(part, "wb") as out:
            out.write(world_image(state).tobytes())
        os.replace(part, path)
    except OSError as e:
        if os.path.exists(part):
            os.remove(part)
        raise RunLogError(f"cannot write {path!r}: {e}") from None


def load_state(path, checkpoint=-1):
    """(state, checkpoint attributes or {}) from a world file, or from a run log's
    checkpoint (default: the last)."""
    path = os.fspath(path)
    f = open_file(path)
    try:
        if f.attrs["format"] == WORLD_FORMAT:
            return _state(f["world"], path, "world file", int(f.attrs["format_version"])), {}
        return checkpoint_state(f, path, checkpoint)
    except DAMAGE as e:
        if isinstance(e, RunLogError):
            raise
        raise RunLogError(f"{path!r}: corrupt ({type(e).__name__}: {e})") from None
    finally:
        f.close()
