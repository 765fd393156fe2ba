"""What runs a World's steps, and what its extensions reach it through.

The step driver (`Engine.run`): n steps in as few kernel calls as it can, the frames a sink
takes captured inside the kernels (a run log's, a prediction's samples), bodies that died
removed (their debris spawned) and the call resumed, failures and NaN reported. World.step
calls it with its run log; a prediction with its sampler: one driver for both.

A sink takes frames at step counts it chooses (`frame_offsets`, `until_frame`), at most
`frame_room(capacity)` in one kernel call, in buffers of its own (`frame_buffers`: frames of
FRAME_BYTES_PER_BODY bytes a body), is told what the kernel captured (`captured`, then
`captured_last` once the steps are booked) and of steps taken with no body to capture
(`stepped`), and gets each call's events (`record_events`).

Predictions (predict.py), their tape (tape.py) and the spatial queries (queries.py) read the
World through the rest of this interface (`view`, `rows`, `plan`, `pulling`, ...), never its
private attributes. A part of World: it holds the World and reads its parts.
"""
import warnings

import numpy as np

from . import editing, measures, space_order
from .errors import caller_level
from .events import EVENT_DTYPE
from .kernels import parties as kparties
from .kernels import rails as krails
from .kernels import state as kstate
from .kernels.codes import FAILED, NONFINITE, PERIODIC, REMOVED

# bytes a frame holds per body: pos, vel (3 float64 each) and mass
FRAME_BYTES_PER_BODY = 56


class Driver:
    """World w's step driver and its extensions' interface (see the module)."""

    def __init__(self, world):
        self.w = world
        # set by a warped advance(): the most steps a call may integrate (the rest may only
        # pass in jumps), and how many steps it left untaken
        self.budget = None
        self.cut = 0
        # the spatial queries' grids and what they were built from, and their memory, reused
        # by the next ones (queries._grid, queries._Memory)
        self.grids = {}
        self.grid_memory = None
        # the settings predictions chose to meet an error (prediction_settings.choose)
        self.choices = {}
        # space order (space_order.py): the plan last judged and its steps between sorts (0:
        # never)
        self.judged = None
        self.every = 0

    def __getstate__(self):
        state = self.__dict__.copy()
        state["grids"] = {}            # a copy (World.copy, a prediction's) builds its own
        state["grid_memory"] = None    # in memory of its own
        state["judged"] = None
        return state

    # ---------------------------------------------------------------- the interface
    def view(self, *names):
        """The live bodies' columns `names` (n rows; positions and velocities with 3
        components, z = 0 in 2D): the World's own arrays, not copies; one array for one
        name, else a tuple. For code that hands them to kernels; read, never write."""
        got = self.w._b.live(names)
        return got[0] if len(got) == 1 else got

    def periodic(self):
        """Whether the boundary is periodic."""
        return self.w._collisions.boundary == PERIODIC

    def periodic_box(self):
        """(lo (3,), period (3,)): a periodic boundary's corner and sides, period 0 on open
        axes (both 0 without one). New arrays."""
        c = self.w._collisions
        if c.boundary != PERIODIC:
            return np.zeros(3), np.zeros(3)
        return c.box[0].copy(), c.box[1] - c.box[0]

    def has(self, column):
        """Whether the bodies have the column (ships' columns come with the first ship)."""
        return column in self.w._b.columns

    def rows(self, ids):
        """(k,) int64 rows of the ids, -1 where an id names no live body."""
        return self.w._b.lookup(ids)

    def release_controls(self):
        """Every ship's controls released and its plan dropped, missiles left flying: the
        copy World.predict(coast=True) runs."""
        self.w._actors.release()

    @property
    def plan(self):
        """The kernels' tables now (a steppers.Plan), or None when they will be built anew
        (bodies or a setting they hold changed): World.tables() builds them."""
        return self.w._plan

    def pulling(self):
        """(k,) int64 rows of the bodies that pull (active, of mass > 0)."""
        return self.w._sources()[0]

    @property
    def capacity(self):
        """The rows the bodies' columns hold, used or not."""
        return self.w._b.capacity

    def actors_among(self, rows):
        """Whether any of these rows is a ship or missile."""
        return self.w._actors.any_of(rows)

    def check_step(self, step, what):
        """ValueError naming `what` when ships and missiles cannot be stepped by `step`."""
        self.w._actors.check_step(step, what)

    @property
    def queued(self):
        """Whether launches wait for the next step (their events open it)."""
        return bool(self.w._actors.queued)

    def attach_tape(self, tape):
        """Give every force table built from now on a prediction's tape (tape.py), and
        build the tables with it now."""
        self.w._forces.tape = tape
        self.w._plan = None
        self.w.tables()

    # ---------------------------------------------------------------- the driver
    def run(self, n, sink=None):
        """Take n steps (>= 0), frames into `sink` (or None): the call World.step makes.
        Returns the status bits of the last kernel call (kernels/codes.py)."""
        w = self.w
        t0 = w._t_base + w._steps * w._dt
        w._event_count[0] = 0
        if self.grids and n:
            self.grids.clear()         # the bodies move: the queries' grid and its copies go
        if w._actors.queued:
            self._begin_events()
        b = w._b
        status = 0
        if sink is None and b.n:
            status = self._calls(n) if n else 0
        else:
            left = n
            while left:
                if sink is not None and b.n:
                    room = sink.frame_room(b.capacity)
                    at = sink.frame_offsets(w, left, room)
                    k = int(at[-1]) if at.size == room else left
                    status = self._calls(k, at, sink)
                else:
                    k = left if sink is None else min(left, sink.until_frame(w))
                    if b.n:
                        status = self._calls(k)
                    else:
                        w._steps += k          # no body to move: time still passes
                    if sink is not None:
                        sink.stepped(w, k)
                left -= k
                if self.cut:
                    break
        if sink is not None:
            sink.record_events(w.events)
        if n and (status & NONFINITE or w._watch is not None):
            measures.check_health(w, t0, status)
        return status

    def sorts(self, plan):
        """Steps between sorts of the rows in space order for the scene `plan` holds (0:
        never; space_order.py says when)."""
        w = self.w
        f = w._forces
        if plan.rules is None or plan.actors is not None or plan.special or \
                w._b.n < space_order.MIN_BODIES or f.mutual or f.user or \
                f.tape is not None or f.tether_ids.shape[0] or \
                not w._stepper.capabilities.rows_free:
            return 0
        return space_order.EVERY

    def _sort(self):
        """Put the rows in space order; True when a row moved (the tables go)."""
        b = self.w._b
        rows = space_order.order(b.pos[:b.n], b.ids[:b.n])
        if rows is None or (rows == np.arange(b.n)).all():
            return False
        b.reorder(rows)
        self.w._plan = None
        return True

    def _special(self, plan, nsteps, frame_at):
        """With bodies on rails or coasting: (steps to take, whether time passes in one jump,
        whether bodies coast, the tables), the coasting bodies released or set coasting
        first (coasting.py)."""
        w = self.w
        jumping = self._jumps(plan)
        coasting = w._forces.rails.active
        take = nsteps
        if coasting:
            # with frames to take a jump ends at each change of parent (the frames before it
            # are on the old conic), else the changes are made first, at their own times
            take = w._coasting.chunk(nsteps, jumping and frame_at is None)
            if w._plan is not plan:                # bodies were released: integrated now
                plan = w._plan or w.tables()
                if jumping and not self._jumps(plan):
                    jumping = False
                    take = w._coasting.chunk(nsteps, False)
                    plan = w._plan or w.tables()
        return take, jumping, coasting, plan

    def _jumps(self, plan):
        """Whether time may pass in one jump: bodies on rails, and nothing integrated."""
        return plan.rails is not None and not plan.free.size and \
            self.w._coasting.blocker(plan) is None

    def _begin_events(self):
        """This step's events open with the launches made since the last one."""
        w = self.w
        if not w._actors.write_queued(w._events, w._event_count):
            w._events = np.zeros(2 * len(w._actors.queued), dtype=EVENT_DTYPE)
            w._plan = None
            w._actors.write_queued(w._events, w._event_count)
        self._name_bodies(0)

    def _name_bodies(self, first):
        """The kinds and tags of the bodies a and b of the events from `first` on, read
        before the bodies a call destroyed or merged away leave (kernels/parties.py)."""
        w = self.w
        b = w._b
        kparties.name_bodies(w._events, first, w._event_count.item(0), b.index, b.ids, b.kind,
                             editing.optional(w, editing.TAG))

    def _calls(self, nsteps, frame_at=None, sink=None):
        """Take nsteps steps; a kernel call ends early after a collision removed or merged
        bodies (or a detonation, an expiry), and is resumed once the World has caught up.
        frame_at : sorted step counts (from now) after which `sink` takes a frame. Returns
        the last call's status."""
        w = self.w
        consumed = 0
        status = 0
        budget = self.budget          # a warped frame's: the most steps to integrate
        while nsteps:
            plan = w._plan or w.tables()
            take, jumping, coasting = nsteps, False, False
            if plan is not self.judged:
                self.judged, self.every = plan, self.sorts(plan)
            # the rows in space order before a call whose steps pass a multiple of `every`
            # (decided by the step count and the call alone: a World restored, or stepped
            # alike without sorting, makes the same calls)
            if self.every and (w._steps + nsteps - 1) // self.every > \
                    (w._steps - 1) // self.every and self._sort():
                plan = self.judged = w.tables()
            if plan.special:                       # bodies on rails, or coasting
                take, jumping, coasting, plan = self._special(plan, nsteps, frame_at)
            first = w._event_count.item(0)
            frames = None
            if frame_at is not None:
                at = frame_at[frame_at > consumed] - consumed
                frames = (at,) + sink.frame_buffers(at.size, w._b.n)
            if plan.until is not None and w._t_base + (w._steps + take) * w._dt > plan.until:
                raise ValueError(f"n = {nsteps}: the ephemerides flown end at t = "
                                 f"{plan.until}, before the steps would (t = {w.t})")
            for clock in plan.clocks:          # the actors' plans' and the rails' clocks
                clock[0] = w._t_base           # (element-wise: a slice assignment from a
                clock[1] = w._steps            # tuple costs a microsecond)
            if jumping:
                # nothing is integrated: time passes in one jump (the bodies on rails placed
                # at its end, a step before it in prev; the frames it passes, at theirs)
                b = w._b
                if frames is not None:
                    n = b.n
                    krails.jump_frames(plan.rails, frames[0], take, w._dt, b.pos[:n],
                                       b.vel[:n], b.mass[:n], *frames[1:])
                krails.jump(plan.rails, take, w._dt, b.pos, b.vel, b.prev)
                done, status, timing = take, 0, None
            else:
                if budget is not None:
                    if not budget:
                        self.cut = nsteps              # the frame's budget is spent
                        break
                    take = min(take, budget)
                timing = w._threads.begin(plan.work, take)
                done, status = w._stepper.run(plan, frames, w._dt, take,
                                              w._t_base + w._steps * w._dt)
                if budget is not None:
                    budget -= done
            if timing is not None:
                w._threads.end(timing, done)
            if w._event_count[0] > w._events.shape[0]:
                w._events = kstate.events_of(plan.state)        # the kernel grew it
                w._plan = None
            if w._event_count.item(0) > first:     # (most calls: nothing happened)
                self._name_bodies(first)
                if w._forces.broken().any():       # tethers broke: gone from the setup
                    editing.tether_rows(w)           # now (a snapshot or copy next keeps them)
            if plan.rules is not None:
                w._collisions.caught_up(plan.rules)
            if frames is not None:
                sink.captured(w, *frames, done)
            w._steps += done
            if status & REMOVED:
                # bodies destroyed or merged away leave, at the end of the step they died in;
                # the destroyed ones with an explosion throw out their debris, born then
                events = w._events[first:w._event_count[0]]
                w._actors.merged(events)
                dead = np.flatnonzero(~plan.alive)
                dead = dead[np.argsort(w._b.ids[dead], kind="stable")]   # by id, not row
                blasts = w._actors.explode_dead(dead, events)
                w._b.remove(dead)
                w._invalidate()
                w._actors.spawn_debris(blasts)
            if frames is not None:
                sink.captured_last(w, frames[0], done)
            if status & FAILED:
                w._b.prev[:w._b.n] = w._b.pos[:w._b.n]   # nothing to interpolate
                w._stepper.failed(w, done)
            if coasting:
                w._coasting.caught_up()
            nsteps -= done
            consumed += done
            if w._warning:
                message, w._warning = w._warning, None
                warnings.warn(message, RuntimeWarning, stacklevel=caller_level())
        if budget is not None:
            self.budget = budget
        return status
