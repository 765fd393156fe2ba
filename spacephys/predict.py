"""Trajectory prediction: `World.predict` and `World.predict_async`.

A prediction runs a copy of the World (every body pulling, held controls, plans, collisions
as in the World) and samples the chosen bodies inside the step kernel (the frames a recording
takes), so `points` samples cost one kernel call, not one Python call each. With the World's
own integrator and dt the predicted path is the path the World will fly, bit for bit, when
nothing else acts. The markers (apsides, closest approach, change of dominant body, impact)
are found on the samples and refined between them (kernels/markers.py).

A part of World (like forces.py): it runs the copy's steps through World's own step loop.
"""
import concurrent.futures
import math
import os
import threading
import time
from dataclasses import dataclass, field
from typing import NamedTuple

import numpy as np

from . import _validate as check
from .events import EVENT_DTYPE, EVENT_KINDS
from .forces import MUTUAL
from .integrators import get_integrator
from .kernels import markers
from .driver import FRAME_BYTES_PER_BODY
from .kernels.codes import (EV_BOUNCE, EV_DESTROY, EV_DETONATION, EV_EXPIRY, EV_MERGE,
                            EV_WALL)
from .tape import Tape
from .worldstate import Motion

# events that end a predicted path: a contact by the collision rules, a detonation, an expiry
_ENDING = (EV_BOUNCE, EV_MERGE, EV_DESTROY, EV_WALL, EV_DETONATION, EV_EXPIRY)
_IMPACTS = (EV_BOUNCE, EV_MERGE, EV_DESTROY, EV_WALL, EV_DETONATION)
# candidates for the dominant body: the pulling bodies, at most this many (the strongest pulls
# on the predicted bodies now)
MAX_CANDIDATES = 64
# frames one kernel call captures: buffers of at most 32 MB
_FRAME_BYTES = 32 << 20
# from this many paths the markers are found on two threads (_in_halves)
_SPLIT_PATHS = 8


class Apsis(NamedTuple):
    """A pericentre or apocentre of body `id` about body `about` (-1: the field's centre):
    time, position (dim,) [length], distance [length]."""
    id: int
    kind: str
    t: float
    pos: np.ndarray
    distance: float
    about: int


class Approach(NamedTuple):
    """The closest approach of body `id` to `target` over the prediction: time, distance
    [length], relative speed [length/time]."""
    id: int
    target: int
    t: float
    distance: float
    speed: float


class Change(NamedTuple):
    """Body `id`'s dominant body changes from `before` to `after` at about time t (-1: the
    field's centre)."""
    id: int
    t: float
    before: int
    after: int


class Impact(NamedTuple):
    """Body `id`'s path ends at time t by `kind` (an event name: destroy, merge, bounce, wall,
    detonation) with body `other` (-1: a wall) at point (dim,)."""
    id: int
    t: float
    other: int
    point: np.ndarray
    kind: str


@dataclass
class Prediction:
    """What World.predict returns. ids (k,); t (P,) the sample times [time]; pos, vel (k, P,
    dim) [length], [length/time], NaN after a path ended; ended (k,) the time each path ended
    (inf: it did not); about (k, P) the dominant body's id at each sample (-1: the field's
    centre or none); the markers, each a list sorted by time; events: every event of the
    prediction (EVENT_DTYPE), fuel running out included, in time order."""
    ids: np.ndarray
    t: np.ndarray
    pos: np.ndarray
    vel: np.ndarray
    ended: np.ndarray
    about: np.ndarray
    apsides: list = field(default_factory=list)
    approaches: list = field(default_factory=list)
    changes: list = field(default_factory=list)
    impacts: list = field(default_factory=list)
    events: np.ndarray = field(default_factory=lambda: np.zeros(0, EVENT_DTYPE))

    def path(self, body_id):
        """(pos (P, dim), vel (P, dim)) of one predicted body."""
        k = np.flatnonzero(self.ids == body_id)
        if not k.size:
            raise ValueError(f"id = {body_id}: not predicted (ids: {self.ids.tolist()})")
        return self.pos[k[0]], self.vel[k[0]]


class _Sampler:
    """The frames a prediction's steps take (a sink of the World's step driver, driver.py):
    the rows of the watched ids, sample by sample, into pos, vel (P, m, 3); NaN for a body
    gone. Sample j is taken counts[j] steps after the start (sample 0: the state then). When
    the watched bodies are every row in order (a ship among its candidates, as a HUD asks)
    the kernel captures straight into them: no copy. The buffers are the shadow's, kept from
    one prediction to the next (fresh pages cost a fault each)."""

    def __init__(self, world, ids, counts, buffers):
        self.world, self.ids, self.counts = world, ids, counts
        shape = (counts.size, ids.size, 3)
        if buffers.get("shape") != shape:
            buffers.clear()
            buffers.update(shape=shape, pos=np.empty(shape), vel=np.empty(shape))
        self.pos, self.vel, self.buffers = buffers["pos"], buffers["vel"], buffers
        self.next = 1                      # sample 0 is the state now
        self.taken = 0                     # steps since the start
        self.rows = None                   # the watched rows for this kernel call
        self.direct = False
        self.tables = None

    def take(self, world, j):
        rows = world.driver.rows(self.ids)
        ok = rows >= 0
        pos, vel = world.driver.view("pos", "vel")
        self.pos[j], self.vel[j] = np.nan, np.nan
        self.pos[j, ok] = pos[rows[ok]]
        self.vel[j, ok] = vel[rows[ok]]

    # ------------------------------------------------------------ the sink
    def frame_room(self, capacity):
        """Samples one kernel call may capture: buffers of at most _FRAME_BYTES."""
        return max(1, _FRAME_BYTES // (FRAME_BYTES_PER_BODY * max(capacity, 1)))

    def frame_offsets(self, world, n, limit):
        due = self.counts[self.next:self.next + limit] - self.taken
        return due[due <= n]

    def until_frame(self, world):
        return int(self.counts[self.next] - self.taken)

    def stepped(self, world, k):
        """k steps taken with every body gone: the samples they reach are NaN."""
        self.taken += k
        while self.next < self.counts.size and self.counts[self.next] <= self.taken:
            self.pos[self.next] = np.nan
            self.vel[self.next] = np.nan
            self.next += 1

    def record_events(self, events):
        pass                               # the prediction reads the copy's events

    def frame_buffers(self, F, n):
        # rows do not change within a kernel call
        self.tables = self.world.driver.plan       # replaced when bodies are removed or added
        self.rows = rows = self.world.driver.rows(self.ids)
        j = self.next
        self.direct = rows.size == n and bool(np.all(rows == np.arange(n)))
        key = ("frames", n)
        b = self.buffers.get(key)
        if b is None or b[2].shape[0] < F:
            b = self.buffers[key] = (np.empty((F, n, 3)), np.empty((F, n, 3)),
                                     np.empty((F, n)))
        if self.direct:
            return self.pos[j:j + F], self.vel[j:j + F], b[2][:F]
        return b[0][:F], b[1][:F], b[2][:F]

    def captured(self, world, at, fpos, fvel, fmass, done):
        k = int(np.searchsorted(at, done))     # the one at the last step: captured_last
        if k and not self.direct:
            rows, j = self.rows, self.next
            self.pos[j:j + k] = np.nan
            self.vel[j:j + k] = np.nan
            ok = np.flatnonzero(rows >= 0)
            self.pos[j:j + k, ok] = fpos[:k, rows[ok]]
            self.vel[j:j + k, ok] = fvel[:k, rows[ok]]
        self.next += k
        self.taken += done

    def captured_last(self, world, at, done):
        if done <= at[-1] and at[np.searchsorted(at, done)] == done:
            if not (self.direct and world.driver.plan is self.tables):   # else: the kernel's
                self.take(world, self.next)
            self.next += 1

    def paths(self, rows):
        """(pos, vel) (K, P, 3) of the watched bodies rows (K,) (indices into ids), new."""
        return _paths([self], self.ids, rows)


def _paths(samplers, ids, rows):
    """(pos, vel) (K, P, 3), new, of the bodies ids[rows], each from the first of the
    samplers that watched it."""
    P = samplers[0].pos.shape[0]
    out = np.empty((rows.size, P, 3)), np.empty((rows.size, P, 3))
    if len(samplers) == 1:                  # ids are the sampler's own
        for o, samples in zip(out, (samplers[0].pos, samplers[0].vel)):
            markers.paths(samples, rows, np.arange(rows.size), o)
        return out
    wanted = ids[rows]
    left = np.ones(rows.size, bool)
    for s in samplers:                      # ids sorted: membership by searchsorted
        at = np.minimum(np.searchsorted(s.ids, wanted), s.ids.size - 1)
        here = np.flatnonzero(left & (s.ids[at] == wanted))
        for o, samples in zip(out, (s.pos, s.vel)):
            markers.paths(samples, at[here], here, o)
        left[here] = False
    return out


class _Merged:
    """The samples of a split prediction (_Halves): paths() as _Sampler's, from the copies'
    samplers."""

    def __init__(self, ids, samplers):
        self.ids, self.samplers = ids, samplers

    def paths(self, rows):
        return _paths(self.samplers, self.ids, rows)


def _schedule(world, duration, points, integrator, dt):
    """(integrator name, dt, step counts (P,) from now at which to sample)."""
    name = world.integrator if integrator is None else integrator
    spec = get_integrator(name)
    if spec.adaptive:
        if dt is not None:
            raise ValueError(f"dt = {dt}: the adaptive {name} sets its own substeps; give "
                             f"tolerance instead")
        return name, duration / (points - 1), np.arange(points, dtype=np.int64)
    if dt is None:
        dt = world.dt
    dt = check.scalar("dt", dt, positive=True)
    nsteps = max(1, math.ceil(duration / dt * (1.0 - 1e-12)))
    P = min(points, nsteps + 1)
    # round(j nsteps / (P - 1)) in integers: rising, distinct since P - 1 <= nsteps
    counts = (2 * np.arange(P, dtype=np.int64) * nsteps + (P - 1)) // (2 * (P - 1))
    return name, dt, counts


def predict(world, ids, duration, points=256, integrator=None, dt=None, tolerance=None,
            target=None, about=None, background=False, coast=False, error=None):
    """World.predict and World.predict_async (the docstrings are there): everything is
    checked and the World's state taken in the caller's thread; background: the run goes to
    a worker thread (kernels release the GIL) and a PredictionHandle comes back."""
    ids = np.atleast_1d(np.asarray(ids))
    if ids.dtype.kind not in "iu" or ids.ndim != 1 or not ids.size:
        raise ValueError(f"ids = {ids!r}: give one body id or a list of ids")
    ids = ids.astype(np.int64)
    if ids.size == 1:                   # a HUD's ship: the plain lookup
        rows = np.array([world.index_of(int(ids[0]), "ids")], np.int64)
    else:
        rows = world.index_of(ids, "ids")
    duration = check.scalar("duration", duration, positive=True)
    if not math.isfinite(duration):
        raise ValueError(f"duration = {duration}: must be finite")
    points = check.count("points", points, minimum=2)
    if not isinstance(coast, (bool, np.bool_)):
        raise ValueError(f"coast = {coast!r}: True or False")
    if error is not None:
        error = check.scalar("error", error, positive=True)
        if integrator is not None or dt is not None or tolerance is not None:
            raise ValueError(f"error = {error}: the prediction chooses its integrator and dt "
                             f"for it; give error, or integrator, dt and tolerance, not both")
        from .prediction_settings import choose
        integrator, dt = choose(world, ids, rows, duration, points, error, bool(coast))
    if target is not None:
        world.index_of(target, "target")
    if about is not None and world.mass[world.index_of(about, "about")] <= 0.0:
        raise ValueError(f"about = {about}: a massless body has no orbit about it")
    name, step, counts = _schedule(world, duration, points, integrator, dt)
    world.driver.check_step(step, "dt" if dt is not None or not get_integrator(name).adaptive
                            else "the step duration / (points - 1)")
    if tolerance is not None:
        tolerance = check.scalar("tolerance", tolerance, positive=True)
        if not get_integrator(name).adaptive:
            raise ValueError(f"tolerance = {tolerance}: only the adaptive integrator takes a "
                             f"tolerance ({name} is fixed-step; give dt)")
    shadow = _shadow(world, name, step, tolerance, background, bool(coast))
    cand, crows, watched = _picks(shadow, world, ids, about, target)
    cmass = world.mass[crows].astype(np.float64)
    centre = _centre(world) if about is None else None
    G, own = world.G, np.where(world.pulls[rows], world.mass[rows], 0.0)

    def job():
        try:
            _yield(background)
            w = shadow.ready()
            if shadow.coast:
                w.driver.release_controls()
            sampler = _Sampler(w, watched, counts, shadow.buffers)
            sampler.take(w, 0)
            t = w.time_after(counts.astype(np.float64))     # as World.t computes the time
            if shadow.tape is not None:
                shadow.tape.start_run(w, int(counts[-1]))
            halves = None if background else _Halves.ready(shadow, w, ids, rows, watched,
                                                           counts)
            if halves is None:
                events = _run(w, sampler)
            else:
                sampler, events = halves.run(counts, watched)
            _yield(background)
            return _assemble(w, ids, watched, sampler, t, events, cand, cmass, centre,
                             target, G, own, background)
        finally:
            if shadow.tape is not None:
                shadow.tape.end_run()
            shadow.release()

    if not background:
        return job()
    return PredictionHandle(_pool().submit(job), shadow)


class _Shadow:
    """The copy of a World a prediction runs: made once (a copy, its settings, its tables)
    and brought up to date from the World's arrays before each later prediction, so that a
    prediction costs neither a copy nor a table build. Valid while the World's tables are
    those it was made beside (any change to the bodies or to a setting the tables hold
    rebuilds them) and its own run removed nobody; busy while a prediction runs on it."""

    def __init__(self, world, key, name, step, tolerance, background, coast, tape=None):
        self.world_plan = world.driver.plan   # the World's tables it was made beside
        w = world.copy()
        w.watch_energy(None)
        if coast:                         # no plans in its tables (controls: at each run)
            w.driver.release_controls()
        if name != w.integrator:
            w.integrator = name           # refuses, here, a scene it cannot run
        if step != w.dt:
            w.dt = step
        if tolerance is not None:
            w.tolerance = tolerance
        if background:
            w.threads = "never"           # beside the game's own steps, on one thread
        w.tables()
        self.tape = Tape.make(w, tape)    # the pulling bodies' recorded future (tape.py)
        self.w, self.key, self.step, self.tolerance = w, key, step, tolerance
        self.same_integrator = name == world.integrator
        self.coast = coast
        self.plan = w.driver.plan
        self.snap = None
        self.buffers = {}                 # the samplers' (_Sampler)
        self.busy = True

    def usable(self, world, key):
        return (not self.busy and self.key == key and world.driver.plan is self.world_plan
                and self.w.driver.plan is self.plan)

    def take(self, world, background):
        """The World's moving state now, in the caller's thread, for ready() to put into the
        copy (worldstate.Motion): copies for a prediction in the background (the World moves
        on meanwhile), views for one made now (ready() runs before the caller gets the World
        back: one copy, not two)."""
        self.snap = Motion.take(world, copy=background, carried=self.same_integrator)
        self.busy = True

    def ready(self):
        """The copy, in the World's state when it was taken (as a fresh copy would be)."""
        w = self.w
        if self.snap is None:
            return w                      # just made: the copy is the state
        self.snap.put(w)
        self.snap = None
        if self.step != w.dt:
            w.dt = self.step              # rebased as the fresh copy's was
        if self.tolerance is not None:
            w.tolerance = self.tolerance
        return w

    def release(self):
        self.busy = False


class _Halves:
    """A prediction on two threads: two copies of the shadow's copy, each with the pulling
    bodies and half of the predicted ones (the other bodies left out), run side by side and
    their samples and events merged. Only when nothing couples the predicted bodies but the
    pulling bodies' known motion: the tape covers the whole run (so each copy plays it back,
    bit for bit the full run's numbers), no collisions, no queued launches, every predicted
    body passive, no ship with a fuse or a guidance target other than a pulling body. The
    copies are made once per shadow and set of predicted ids (the first eligible call pays
    for them) and loaded from the shadow's copy before each run."""

    def __init__(self, w, groups):
        self.groups = groups
        self.copies = []
        for keep in groups:
            c = w.copy()
            c.watch_energy(None)
            c.threads = "never"           # two Python threads: no numba pool between them
            gone = np.setdiff1d(c.ids, keep)
            if gone.size:
                c.remove(gone)
            c.tables()
            self.copies.append(c)
        self.tapes = None                # each copy's cursor on the shadow's tape

    @staticmethod
    def ready(shadow, w, ids, rows, watched, counts):
        """The shadow's _Halves loaded with w's state and its tape's cursors, or None when
        the run cannot be split (see the class); rows: the ids' rows (w's are the World's)."""
        tape, n = shadow.tape, int(counts[-1])
        if tape is None or not tape.covers(n) or ids.size < _SPLIT_PATHS \
                or (os.cpu_count() or 1) < 2 or w.driver.plan.rules is not None \
                or w.driver.queued:
            return None
        src = w.driver.pulling()
        if np.isin(rows, src).any() or not _independent(w, src):
            return None
        src_ids = w.ids[src]
        order = np.sort(ids)              # rows follow ids: the first half's events first
        mid = order.size // 2
        others = np.setdiff1d(watched, np.concatenate([ids, src_ids]))   # a passive target
        groups = (np.union1d(np.concatenate([src_ids, others]), order[:mid]),
                  np.union1d(src_ids, order[mid:]))
        halves = shadow.__dict__.get("halves")
        if halves is None or not all(map(np.array_equal, halves.groups, groups)):
            halves = shadow.halves = _Halves(w, groups)
        if not halves.load(w, n, tape):
            return None
        return halves

    def load(self, w, n, tape):
        """Each copy in w's state (the rows of its bodies), its cursor on w's tape at w's:
        False when a cursor would not play the whole run."""
        self.tapes = []
        for c in self.copies:
            Motion.take(w, rows=w.index_of(c.ids), carried=False).put(c)
            fork = tape.fork(c)
            if fork is None:
                return False
            fork.start_run(c, n)
            self.tapes.append(fork)
            if not fork.covers(n):
                for f in self.tapes:
                    f.end_run()
                return False
        return True

    def run(self, counts, watched):
        """Both copies' runs, the second on a helper thread: (their samples of the watched
        ids (_Merged), their events merged by time (stable: the first half's first where
        times are equal))."""
        parts = []
        for c in self.copies:
            own = watched[np.isin(watched, c.ids)]
            s = _Sampler(c, own, counts, c.__dict__.setdefault("_sampler_buffers", {}))
            s.take(c, 0)
            parts.append((c, s))
        try:
            later = _pool("markers").submit(_run, parts[1][0], parts[1][1])
            events = [_run(parts[0][0], parts[0][1]), later.result()]
        finally:
            for fork in self.tapes:
                fork.end_run()
        events = np.concatenate(events)
        return (_Merged(watched, [s for _, s in parts]),
                events[np.argsort(events["time"], kind="stable")])


def _independent(w, src):
    """Whether no ship or missile reads another body but the pulling ones (src rows): no
    proximity fuse, no guidance target elsewhere."""
    e = w.driver
    if not e.has("actor"):
        return True
    actor, fuse, target, guidance, ids = e.view("actor", "fuse", "target", "guidance", "ids")
    actors = np.flatnonzero(actor)
    if not actors.size:
        return True
    if np.any(fuse[actors] > 0.0):
        return False
    targets = target[actors]
    aimed = targets[(targets >= 0) & (guidance[actors] != 0)]
    return bool(np.isin(aimed, ids[src]).all())


def _shadow(world, name, step, tolerance, background, coast):
    """The World's shadow for these settings, up to date with it, marked busy; made anew
    when there is none, it is busy, or the World's tables were rebuilt since. One for each
    of foreground / background and flown / coasting, so that a HUD asking for both each
    frame keeps both."""
    world.tables()
    key = (name, step, tolerance)
    shadows = world.__dict__.setdefault("_shadows", {})
    shadow = shadows.get((background, coast))
    if shadow is not None and shadow.usable(world, key):
        shadow.take(world, background)
        return shadow
    # the tape outlives a copy remade for new tables (a plan edited, a body added): it plays
    # on if the pulling bodies are where it has them
    tape = shadow.tape if shadow is not None and not shadow.busy and shadow.key == key else None
    shadow = _Shadow(world, key, name, step, tolerance, background, coast, tape)
    shadows[background, coast] = shadow
    return shadow


def _yield(background):
    """On the worker thread, let the game's thread take the GIL if it waits for it: it would
    otherwise wait for Python's switch interval (5 ms) while this thread runs Python (the
    kernels release the GIL; what comes before and after them does not)."""
    if background:
        time.sleep(0)


def _run(w, sampler):
    """Step the copy to the sampler's last count, sampling at the others (the World's own
    step driver); returns its events in time order."""
    w.driver.run(int(sampler.counts[-1]), sampler)
    events = w.events
    return events[np.argsort(events["time"], kind="stable")]


def _picks(shadow, world, ids, about, target):
    """(ids (C,) of the bodies that may dominate, their rows, the watched ids (sorted)): the
    pulling bodies (the strongest MAX_CANDIDATES on the predicted bodies now), or `about`
    alone. Kept on the shadow (its tables, so the bodies and their rows, are the World's)
    unless the choice depends on where the bodies are."""
    key = (ids.tobytes(), about, target)
    picks = shadow.__dict__.setdefault("picks", {})
    if key in picks:
        return picks[key]
    fixed = True
    if about is not None:
        rows = np.array([world.index_of(about)], np.int64)
    elif world.gravity not in MUTUAL:
        rows = np.zeros(0, np.int64)
    else:
        rows = np.flatnonzero(world.pulls)
        if rows.size > MAX_CANDIDATES:
            fixed = False
            p = world.pos[world.index_of(ids)]
            d2 = ((world.pos[rows][:, None, :] - p[None]) ** 2).sum(axis=2)
            pull = (world.mass[rows][:, None] / np.where(d2 > 0, d2, np.inf)).max(axis=1)
            rows = rows[np.argsort(-pull, kind="stable")[:MAX_CANDIDATES]]
    cand = world.ids[rows].astype(np.int64)
    watched = np.unique(np.concatenate([ids, cand, [] if target is None else [target]])
                        ).astype(np.int64)
    got = (cand, rows.astype(np.int64), watched)
    if fixed:
        picks[key] = got
    return got


def _centre(world):
    """The field's centre (3,) with gravity="central", else None."""
    if world.gravity != "central":
        return None
    centre = np.zeros(3)
    centre[:world.dim] = world.central_pos
    return centre


def _enders(world, ev):
    """(body, other) pairs whose path the event ends: the destroyed, the merged away, both
    bodies of a bounce, a body at a wall, a detonated missile (its target too if it died),
    an expired body."""
    a, b, kind = int(ev["a"]), int(ev["b"]), int(ev["kind"])
    if kind == EV_MERGE:
        return ((b, a),)
    if kind == EV_BOUNCE:            # the lighter body's path (both, if equal)
        ma, mb = (world.mass[world.index_of(x)] if x in world else 0.0 for x in (a, b))
        return tuple(pair for pair, light in (((a, b), ma <= mb), ((b, a), mb <= ma))
                     if light)
    if kind == EV_DETONATION and b not in world:
        return ((a, b), (b, a))
    return ((a, b),)


def _assemble(world, ids, watched, sampler, t, events, cand, cmass, centre, target, G, own,
              background=False):
    """The Prediction from the samples and the events of the copy `world`; G and own (k,),
    the predicted bodies' masses where they pull (0 elsewhere), make the apsides' mu."""
    dim = world.dim
    sel = np.searchsorted(watched, ids)                 # watched: sorted, unique
    pos, vel = sampler.paths(sel)
    ended = np.full(ids.size, np.inf)
    impacts = []
    for ev in events:
        if ev["kind"] not in _ENDING:
            continue
        for me, other in _enders(world, ev):
            k = np.flatnonzero(ids == me)
            if k.size and ended[k[0]] == np.inf:
                ended[k[0]] = ev["time"]
                if ev["kind"] in _IMPACTS:
                    impacts.append(Impact(me, float(ev["time"]), other,
                                          np.array([ev["x"], ev["y"], ev["z"]])[:dim],
                                          EVENT_KINDS[int(ev["kind"])]))
    gone = t[None, :] > ended[:, None]
    pos[gone] = np.nan
    vel[gone] = np.nan
    cs, cv, csel, cmass, cids = _candidates(world, sampler, watched, cand, cmass, centre, t.size)
    dom = np.full((ids.size, t.size), -1, np.int64)
    p = Prediction(ids, t, pos[:, :, :dim], vel[:, :, :dim], ended, None, impacts=impacts,
                   events=events)
    if cids.size:
        match = cids[None, :] == ids[:, None]
        same = np.where(match.any(axis=1), match.argmax(axis=1), -1).astype(np.int64)
        cmass = np.ascontiguousarray(cmass)
        mu = G * (cmass[None, :] + own[:, None])

        def marks(lo, hi):
            """Paths lo..hi's dominant bodies (into dom) and their changes and apsides (rows
            as markers.changes, markers.all_apsides give them, paths numbered from 0)."""
            markers.dominant(pos[lo:hi], cs, csel, cmass, same[lo:hi], dom[lo:hi])
            got = (markers.changes(t, pos[lo:hi], vel[lo:hi], cs, cv, csel, cmass, dom[lo:hi]),
                   markers.all_apsides(t, pos[lo:hi], vel[lo:hi], cs, cv, csel, mu[lo:hi],
                                       dom[lo:hi]))
            for rows in got:
                rows[:, 0] += lo
            return got

        parts = _in_halves(marks, ids.size, background)
        # the marker objects made column by column, in time order (a stable sort: by path,
        # then time, where times are equal)
        rows = np.concatenate([c for c, _ in parts])
        rows = rows[np.argsort(rows[:, 1], kind="stable")]
        col = lambda x, j: x[rows[:, j].astype(np.int64)].tolist()
        p.changes = list(map(Change, col(ids, 0), rows[:, 1].tolist(), col(cids, 2),
                             col(cids, 3)))
        _yield(background)
        rows = np.concatenate([a for _, a in parts])
        rows = rows[np.argsort(rows[:, 2], kind="stable")]
        kinds = np.where(rows[:, 1] < 0, "pericentre", "apocentre").tolist()
        p.apsides = list(map(Apsis, col(ids, 0), kinds, rows[:, 2].tolist(),
                             list(rows[:, 4:4 + dim].copy()), rows[:, 3].tolist(),
                             col(cids, 7)))
    p.about = np.where(dom >= 0, cids[np.maximum(dom, 0)] if cids.size else -1, -1)
    if target is not None:
        out = np.empty((t.size, 5))
        tpos, tvel = sampler.paths(np.searchsorted(watched, [target]))
        for k in range(ids.size):
            _yield(background)
            if ids[k] != target:
                p.approaches.append(_closest(int(ids[k]), target, t, pos[k], vel[k], tpos[0],
                                             tvel[0], out))
    p.approaches = [a for a in p.approaches if a is not None]
    return p


def _candidates(world, sampler, watched, cand, cmass, centre, P):
    """The candidates' samples for the markers (markers.dominant): (cs, cv (P, m, 3), csel
    (C,) their columns, cmass (C,), cids (C,)). A prediction's own samples where they are
    all in one sampler (no copy); else gathered, the field's centre (id -1) last, fixed."""
    if centre is None and isinstance(sampler, _Sampler):
        return sampler.pos, sampler.vel, np.searchsorted(watched, cand), cmass, cand
    cpos, cvel = sampler.paths(np.searchsorted(watched, cand))
    cids = cand
    if centre is not None:
        cpos = np.concatenate([cpos, np.broadcast_to(centre, (1, P, 3))])
        cvel = np.concatenate([cvel, np.zeros((1, P, 3))])
        cmass = np.append(cmass, world.central_mass)
        cids = np.append(cids, -1)
    cs = np.ascontiguousarray(cpos.transpose(1, 0, 2))
    cv = np.ascontiguousarray(cvel.transpose(1, 0, 2))
    return cs, cv, np.arange(cids.size, dtype=np.int64), cmass, cids


def _in_halves(fn, K, background):
    """[fn(0, K)], or [fn(0, K // 2), fn(K // 2, K)] with the second half on a helper thread
    (the marker kernels release the GIL): many paths' markers on both cores. Not for a
    prediction in the background, whose game has the other core."""
    if background or K < _SPLIT_PATHS or (os.cpu_count() or 1) < 2:
        return [fn(0, K)]
    mid = K // 2
    later = _pool("markers").submit(fn, mid, K)
    return [fn(0, mid), later.result()]


def _at(t, pos, vel, row):
    """Position and velocity (3,) of a sampled path at a marker row's time."""
    j, s = int(row[3]), row[4]
    out_p, out_v = np.empty(3), np.empty(3)
    markers.interpolate(t, np.ascontiguousarray(pos), np.ascontiguousarray(vel), j, s, out_p,
                        out_v)
    return out_p, out_v


def _closest(body, target, t, pos, vel, tpos, tvel, out):
    """The smallest distance between the two paths: a refined minimum, or an end."""
    rp = np.ascontiguousarray(pos - tpos)
    rv = np.ascontiguousarray(vel - tvel)
    ok = np.isfinite(rp).all(axis=1)
    if not ok.any():
        return None
    use = ok[:-1] & ok[1:]
    n = markers.extrema(t, rp, rv, use, out, 60)
    best = None
    for row in out[:n]:
        if row[0] < 0 and (best is None or row[2] < best[2]):
            best = row.copy()
    d = np.linalg.norm(rp, axis=1)
    j = int(np.nanargmin(np.where(ok, d, np.inf)))
    if best is None or d[j] < best[2]:
        return Approach(body, int(target), float(t[j]), float(d[j]),
                        float(np.linalg.norm(rv[j])))
    p, v = _at(t, rp, rv, best)
    return Approach(body, int(target), float(best[1]), float(best[2]), float(np.linalg.norm(v)))


class PredictionHandle:
    """What World.predict_async returns: done(), running(), result(timeout=None) (the
    Prediction, or the error the prediction raised), cancel() before it starts."""

    def __init__(self, future, shadow):
        self._future, self._shadow = future, shadow

    def done(self):
        return self._future.done()

    def running(self):
        return self._future.running()

    def result(self, timeout=None):
        return self._future.result(timeout)

    def cancel(self):
        """Cancel a prediction that has not started; True if it was."""
        if self._future.cancel():
            self._shadow.release()
            return True
        return False


_POOLS = {}
_POOL_LOCK = threading.Lock()


def _pool(name="predict"):
    """A worker thread of its own per name: "predict", the one predictions run on (one at a
    time: the game's steps keep the other core); "markers", _in_halves' helper."""
    with _POOL_LOCK:
        if name not in _POOLS:
            _POOLS[name] = concurrent.futures.ThreadPoolExecutor(1, f"spacephys-{name}")
    return _POOLS[name]
