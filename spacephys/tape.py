"""A prediction's tape: the pulling bodies' future, recorded by one prediction and played back
by the next while the World flies the same steps (the kernels' side: kernels/tape.py).

A HUD predicts every frame from a World a step or two further on, and a player editing a burn
predicts the same World again and again; the planets' future is the same each time. The tape
keeps their sources at every force evaluation, so a later prediction integrates only the
passive bodies (the ship): the same numbers in the same sums, the full run's path bit for bit.
It plays from step k when the copy's pulling bodies are, bit for bit, where the tape has them
after k steps (the World flew those steps: its own integrator and dt) and nothing else that
sets how they move changed (held forces, fixed flags, drag, softening); otherwise it records
anew. A collision that leaves a pulling body elsewhere than the recording's did, or removes
one, stops it. Only for the fixed-step families, splitting and Runge-Kutta (a fixed sequence
of evaluations per step), direct gravity and no user forces, no pulling ship or missile. A
part of World (predict.py's copy).
"""
import numpy as np

from .forces import HELD
from .kernels import tape as ktape

# the most a tape holds: past it a prediction runs in full (10 000 steps of yoshida6 among 10
# bodies take 27 MB)
MAX_BYTES = 64 << 20


class Tape:
    """The tape of one prediction copy `w` (made beside its tables, see `make`)."""

    def __init__(self, w, per_step, src):
        self.src_ids = w.ids[src]
        self.per_step = per_step
        self.at = np.zeros(5, np.int64)
        self.at[ktape.PER_STEP] = per_step
        self.tape = np.zeros((0, 4, src.size))
        self.ends = np.zeros((0, src.size, 14))
        self.table = ktape.TapeArrays(self.tape, self.ends, self.at)   # the kernels' tape
        self.origin = None          # (time, dt) of the tape's step 0
        self.start = None           # (ns, 7): the pulling bodies then (pos, vel, mass)
        self.moved = None           # what else sets how they move (_moved)
        self.played = 0             # steps played back over the tape's life
        self._run = None            # (first step, steps recorded) of the run under way
        self._bind(w, src)

    def _bind(self, w, src):
        """Ride on w: every force table it builds gets the tape (table_for)."""
        w.driver.attach_tape(self)

    def table_for(self, src, src_ids):
        """The kernels' tape for a Forces table just built for the copy (its pulling rows src,
        their ids), if the same bodies pull in the same order; else None, and the tape
        stops (the copy's own run removed a pulling body)."""
        if np.array_equal(src_ids, self.src_ids):
            self.src = src
            return self.table
        self.at[ktape.ON] = 0
        return None

    @staticmethod
    def make(w, old=None):
        """A Tape for the copy w (the old copy's, when the same bodies pull in the same
        rows), or None when its scene cannot have one."""
        per_step = w.stepper.tape_evaluations()
        if per_step is None or w.gravity != "direct" or w.forces or len(w.tethers):
            return None
        src = w.driver.pulling()
        if old is not None and old.per_step == per_step \
                and np.array_equal(old.src_ids, w.ids[src]):
            old._bind(w, src)
            return old
        return Tape(w, per_step, src)

    def _state(self, w):
        pos, vel, mass = w.driver.view("pos", "vel", "mass")
        src = self.src
        return np.concatenate([pos[src], vel[src], mass[src][:, None]], axis=1)

    def _moved(self, w):
        """What else sets how the pulling bodies move: their held forces, whether they are
        fixed, drag and softening (comparable with ==)."""
        e, src = w.driver, self.src
        held = tuple(e.view(HELD)[src].ravel()) if e.has(HELD) else None
        return (held, tuple(e.view("fixed")[src]), w.drag, tuple(w.wind), w.softening, w.G)

    def start_run(self, w, nsteps):
        """Point the tape at the copy's state now, before a run of nsteps steps: play from
        where it matches, else record from here."""
        at = self.at
        at[ktape.ON] = 0
        self._run = None
        if w.driver.actors_among(self.src):               # a pulling ship: its controls
            return                                        # move the pulling bodies
        moved = self._moved(w)
        k = self._matching_step(w, moved)
        if k is None:
            self.origin = (w.t, w.dt)
            self.start, self.moved = self._state(w), moved
            at[ktape.VALID] = 0
            k = 0
        elif k > 0 and k + nsteps > self.ends.shape[0]:   # drop the steps flown since
            valid, per = int(at[ktape.VALID]), self.per_step
            self.start = self.ends[k - 1, :, 7:].copy()
            self.tape[:(valid - k) * per] = self.tape[k * per:valid * per]
            self.ends[:valid - k] = self.ends[k:valid]
            t0, dt = self.origin
            self.origin = (t0 + k * dt, dt)
            at[ktape.VALID] = valid - k
            k = 0
        if not self._room(w, k + nsteps):
            return
        at[ktape.STEP] = k
        at[ktape.ON] = 1
        self._run = (k, int(at[ktape.VALID]))

    def _matching_step(self, w, moved):
        """k when the copy now is the tape's state after k steps (and nothing else moves the
        pulling bodies differently), else None. The time only finds k: the pulling bodies'
        steps do not read it (no user forces, no pulling ship), their state decides."""
        if self.origin is None:
            return None
        t0, dt = self.origin
        k = round((w.t - t0) / dt)
        if w.dt != dt or not 0 <= k <= self.at[ktape.VALID]:
            return None
        if moved != self.moved:
            return None
        then = self.start if k == 0 else self.ends[k - 1, :, 7:]   # after its collisions
        return k if np.array_equal(self._state(w), then) else None

    def _room(self, w, steps):
        """Room for `steps` steps, grown within MAX_BYTES to twice that (a HUD's World moves
        on a few steps a call: the tape's start is dropped only when the room runs out), the
        copy w's tables built anew with the grown arrays; False when past it."""
        if steps <= self.ends.shape[0]:
            return True
        per_step = (self.per_step * 4 + 14) * self.src_ids.size * 8
        if steps * per_step > MAX_BYTES:
            return False
        size = min(2 * steps, MAX_BYTES // per_step)
        valid = int(self.at[ktape.VALID])
        ns = self.src_ids.size
        tape = np.zeros((size * self.per_step, 4, ns))
        ends = np.zeros((size, ns, 14))
        tape[:valid * self.per_step] = self.tape[:valid * self.per_step]
        ends[:valid] = self.ends[:valid]
        self.tape, self.ends = tape, ends
        self.table = ktape.TapeArrays(tape, ends, self.at)
        w.driver.attach_tape(self)
        return True

    def covers(self, nsteps):
        """After start_run: whether the whole run of nsteps plays back (the pulling bodies'
        motion known beforehand, every other body moves on its own)."""
        at = self.at
        return bool(at[ktape.ON]) and int(at[ktape.STEP]) + nsteps <= int(at[ktape.VALID])

    def fork(self, w):
        """A cursor of its own on this tape for another copy w whose pulling bodies are the
        same (a prediction split between threads, predict._Halves): it shares the recording
        and plays it back where this tape would, never records, and books what it played
        here. None when w's pulling bodies differ."""
        src = w.driver.pulling()
        if not np.array_equal(self.src_ids, w.ids[src]):
            return None
        other = Tape.__new__(Tape)
        other.__dict__.update(self.__dict__)
        other.at = self.at.copy()
        other.table = ktape.TapeArrays(other.tape, other.ends, other.at)
        other.parent = self
        other._bind(w, src)
        return other

    def end_run(self):
        """The run is over: the copy's table no longer touches the tape."""
        if self._run is not None:
            k, valid = self._run
            played = max(0, min(int(self.at[ktape.STEP]), valid) - k)
            self.played += played
            if getattr(self, "parent", None) is not None:
                self.parent.played += played
            self._run = None
        self.at[ktape.ON] = 0
