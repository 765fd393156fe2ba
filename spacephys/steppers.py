"""Steppers: one object per integrator family, holding what the family carries from call to
call, what it can do, and how its kernel is called. World holds one and never asks which
family it is.

One step kernel runs every family, kernels/step.run(state, forces, rules, actors, frames,
method, dt, nsteps, t0) -> (steps done, status); a stepper supplies `method`, the family's
table (a namedtuple whose type names the family's integration, kernels/step.register) with
its carried state, checks that it can run the scene, and turns a failed call into an error
that says why. Adding an integrator family: its table and integration registered with
kernels/step.py (a kernel file of its own) and a Stepper subclass registered in STEPPERS (a
method of an existing family is only a table in integrators.py).
"""
from dataclasses import dataclass

import numpy as np

from ._jit import announced, compiling, side_by_side
from .errors import InstabilityError
from .integrators import get_integrator
from .kernels import gauss_radau as kgr
from .kernels import integrate
from .kernels import step as kstep
from .kernels.wisdom_holman import WisdomHolman as WisdomHolmanTable


# World.integrator_stats: name -> index in the adaptive kernel's stats array
COUNTERS = {"steps": kgr.STEPS, "rejected": kgr.REJECTED, "at_min_step": kgr.AT_MIN_STEP,
            "not_converged": kgr.NOT_CONVERGED, "sweeps": kgr.SWEEPS,
            "rider_substeps": kgr.RIDER_SUBSTEPS}


@dataclass(frozen=True)
class Capabilities:
    """What a family can do. drag: linear drag toward a wind; models: the gravity models it
    integrates; fixed_bodies: immovable bodies; pulling_actors: ships whose mass changes while
    they pull; split_invariant: step(n) equals n calls of step(1) bit for bit; frames: a
    recording's frames taken inside the kernel; dominant_mass: it is made for scenes with one
    dominant mass (its Kepler drifts are about it); rows_free: a step is each body's own,
    nothing summed over bodies or carried in row order, so the rows may be put in another
    order (space_order.py)."""
    drag: bool = True
    models: tuple = ("none", "direct", "uniform", "central", "tree")
    fixed_bodies: bool = True
    pulling_actors: bool = True
    split_invariant: bool = True
    frames: bool = True
    dominant_mass: bool = False
    rows_free: bool = True


class Stepper:
    """The base: a fixed-step family with nothing carried between calls."""
    family = None
    kernel = staticmethod(kstep.run)
    capabilities = Capabilities()

    def __init__(self, spec):
        self.spec = spec

    # why a family without pulling_actors cannot follow a pulling ship's mass change
    moving_mass = None
    # per-body columns it carries, {name: (shape, dtype, default)}: World's bodies hold them
    columns = {}

    def check(self, world, sources, actors):
        """Raise ValueError (naming the setting) when this family cannot run the scene, as
        its capabilities say; sources = (src, passive, still) rows, actors the actor rows.
        Nothing is changed."""
        caps = self.capabilities
        if world.gravity not in caps.models:
            why = (": a tree's forces jump where a node opens, which its error control would "
                   "chase; use a fixed-step integrator" if world.gravity == "tree" else "")
            raise ValueError(f"integrator {self.spec.name!r} needs gravity in "
                             f"{caps.models} (gravity={world.gravity!r}{why})")
        src, _, still = sources
        if still.size and not caps.fixed_bodies:
            raise ValueError(f"integrator {self.spec.name!r} cannot hold bodies fixed "
                             f"({still.size} are): use a fixed-step or the adaptive integrator")
        pulling = actors[np.isin(actors, src)] if not caps.pulling_actors else actors[:0]
        if pulling.size:
            raise ValueError(f"integrator {self.spec.name!r}: ship or missile "
                             f"{int(world.ids[pulling[0]])} pulls (active): its mass changes "
                             f"as it burns, which {self.moving_mass} cannot follow; make it "
                             f"passive or use another integrator")

    def method(self, world, sources):
        """The kernel's `method` argument for the bodies now alive."""
        raise NotImplementedError

    def run(self, plan, frames, dt, nsteps, t0):
        """Call the kernel: (steps done, status bits)."""
        return plan.call(self.kernel, frames, dt, nsteps, t0, f"the {self.spec.name} step")

    def failed(self, world, done):
        """The kernel reported FAILED after `done` steps: raise the error that says why."""
        raise FloatingPointError(f"{self.spec.name}: the integration failed at t = {world.t:g}")

    def reset(self, world):
        """Forget what was carried from call to call (the scene jumped, or the integrator
        was switched to this one)."""

    def state(self):
        """What a checkpoint keeps of the carried state (named arrays)."""
        return {}

    def load(self, state):
        pass

    def tape_evaluations(self):
        """Force evaluations per step when a prediction's copy may keep a tape of the pulling
        bodies (spacephys/tape.py: a fixed sequence of them per step, whatever the bodies do),
        else None."""
        return None

    @property
    def counters(self):
        """World.integrator_stats: the adaptive family's counters, zeros for the others."""
        return dict.fromkeys(COUNTERS, 0)


class Splitting(Stepper):
    """Drift/kick compositions (symplectic Euler, leapfrog, Yoshida 4/6/8)."""
    family = "splitting"

    def method(self, world, sources):
        return integrate.Splitting(self.spec.drift, self.spec.kick)

    def tape_evaluations(self):
        return int(np.count_nonzero(self.spec.kick))


class RungeKutta(Stepper):
    """Explicit Runge-Kutta tableaux (Euler, RK4)."""
    family = "rk"

    def method(self, world, sources):
        return integrate.RungeKutta(self.spec.a, self.spec.b)

    def tape_evaluations(self):
        return int(self.spec.b.size)


# Gauss-Radau's per-body carried state: name -> trailing shape
GR_COLUMNS = {"csx": ((3,), np.float64, 0.0), "csv": ((3,), np.float64, 0.0),
              "gr_b": ((7, 3), np.float64, 0.0), "gr_e": ((7, 3), np.float64, 0.0)}


class GaussRadau(Stepper):
    """Adaptive 15th-order Gauss-Radau. Carries the next step's proposal, the step its
    polynomials are scaled to, whether a prediction exists, the counters, and per body
    (columns of World's bodies, so they move with them) the Kahan compensations and the
    polynomials."""
    family = "gauss_radau"
    capabilities = Capabilities(models=("none", "direct", "uniform", "central"),
                                rows_free=False)
    columns = GR_COLUMNS

    def __init__(self, spec):
        super().__init__(spec)
        # [tolerance, max_step, min_step] (World's settings, refreshed before each call),
        # then [next step, step of the polynomials, have a prediction] (carried)
        self.params = np.array([0.0, np.inf, 0.0, np.nan, np.nan, 0.0])
        self.stats = np.zeros(6, np.int64)
        self.before = self.stats.copy()

    def method(self, world, sources):
        src, passive, _ = sources
        b = world._b
        n = b.n
        cols = [getattr(b, name)[:n] for name in GR_COLUMNS]
        if world.step_control_rows(src):
            control, riders = src, passive
        else:
            control, riders = np.arange(n, dtype=np.int64), passive[:0]
        spec = self.spec
        return kgr.GaussRadau(*cols, control, riders, spec.nodes, spec.c_gb, spec.d_bg,
                              self.params, self.stats)

    def run(self, plan, frames, dt, nsteps, t0):
        world = plan.world
        p = self.params
        p[0], p[1], p[2] = world.tolerance, world.max_step or np.inf, world.min_step
        if not p[3] == p[3]:                         # nothing carried yet: start at dt
            p[3] = p[4] = min(dt, p[1])
        self.before[:] = self.stats
        result = plan.call(self.kernel, frames, dt, nsteps, t0, f"the {self.spec.name} step")
        held = self.stats[kgr.AT_MIN_STEP] - self.before[kgr.AT_MIN_STEP]
        if held:
            world.warn_later(f"gauss_radau: {held} substeps were held at min_step = "
                             f"{p[2]:g}; the error is no longer controlled there")
        return result

    def failed(self, world, done):
        next_step = self.params[3]
        self.reset(world)            # the failed step's tiny proposal and wild polynomial
        pair = world.closest_pulling_pair()
        met = (f"; the closest pulling bodies are {world.named(pair)}, which may have "
               f"met (or the coordinates are too far from the origin to resolve the "
               f"step: see shift_origin)" if pair.size else "")
        raise InstabilityError(
            f"gauss_radau: the step shrank below the resolution of time or became NaN "
            f"after t = {world.t:g} (next step {next_step:.3g}){met}. The state "
            f"is that at t = {world.t:g}. Set min_step, or soften gravity.",
            world.ids[pair].copy(), world.t)

    def reset(self, world):
        self.params[3:] = (np.nan, np.nan, 0.0)
        for name in GR_COLUMNS:
            if name in world._b.columns:
                getattr(world._b, name)[:] = 0.0

    def tape_evaluations(self):
        """Force evaluations per step when a prediction's copy may keep a tape of the pulling
        bodies (spacephys/tape.py: a fixed sequence of them per step, whatever the bodies do),
        else None."""
        return None

    @property
    def counters(self):
        return {name: int(self.stats[k]) for name, k in COUNTERS.items()}

    def state(self):
        return {"carried": self.params[3:].copy(), "stats": self.stats.copy()}

    def load(self, state):
        self.params[3:] = state["carried"]
        self.stats[:] = state["stats"]


# why Wisdom-Holman refuses an inextensible tether (World.tether checks it too)
INEXTENSIBLE = ("an inextensible tether's force holds against every other acceleration, "
                "which the Kepler drifts do not show it; give the tether a stiffness (a "
                "spring), or use another integrator")

RAILS_REFUSED = ("Wisdom-Holman drifts every body along its Jacobi Kepler orbit and cannot "
                 "take one moved from outside; put bodies on rails with another integrator "
                 "(leapfrog, yoshida4, rk4, gauss_radau)")


class WisdomHolman(Stepper):
    """Wisdom-Holman in Jacobi coordinates about the heaviest pulling body; carries nothing
    but the Jacobi order, derived from the bodies."""
    family = "wisdom_holman"
    capabilities = Capabilities(models=("direct",), fixed_bodies=False, pulling_actors=False,
                                split_invariant=False, dominant_mass=True, rows_free=False)

    moving_mass = "the Jacobi frames"

    def check(self, world, sources, actors):
        if world._forces.inextensible:
            raise ValueError(f"integrator {self.spec.name!r}: {INEXTENSIBLE}")
        if len(world._forces.rails):
            raise ValueError(f"integrator {self.spec.name!r} with bodies on rails: "
                             f"{RAILS_REFUSED}")
        if world.gravity != "direct":
            raise ValueError(f"integrator {self.spec.name!r} needs gravity='direct' with a "
                             f"dominant body among the bodies (gravity={world.gravity!r}: no "
                             f"Kepler orbit to drift along exactly; use leapfrog or yoshida4)")
        super().check(world, sources, actors)

    def method(self, world, sources):
        """The bodies in Jacobi order and their Jacobi masses: the heaviest pulling body is
        the centre, the other pulling bodies follow in their order of addition (add planets
        inside out: each Jacobi orbit is about the bodies before it), then the passive ones,
        which do not move the Jacobi frames (mass 0)."""
        src, passive, _ = sources
        b = world._b
        if src.size == 0:
            order = np.arange(b.n, dtype=np.int64)
        else:
            src = src[np.argsort(b.serial[src], kind="stable")]
            central = src[np.argmax(b.mass[src])]
            order = np.concatenate([[central], src[src != central], passive]).astype(np.int64)
        m = np.zeros(b.n)
        m[:src.size] = b.mass[order[:src.size]]
        return WisdomHolmanTable(order, m, self.spec.corrector > 0)

    def failed(self, world, done):
        raise FloatingPointError(
            f"{self.spec.name}: a Kepler drift did not converge: a body sits at the centre "
            f"of mass of the bodies before it (its Jacobi orbit is singular), or the state "
            f"is NaN. The state is that at t = {world.t:g}. Wisdom-Holman is for scenes "
            f"with one dominant mass; use gauss_radau or yoshida6 otherwise.")


class Plan:
    """The kernels' tables for the bodies now alive (kernels/state.State, forces.Forces,
    rules.Rules or None, control.Actors or None, the family's method) and the compiled entry
    points that take them: a call goes straight to machine code, past numba's typing of the
    arguments. Rebuilt by World whenever the set of bodies or a setting the tables hold
    changes; arrays are shared with World, so values changed in place need no rebuild."""
    __slots__ = ("world", "state", "forces", "rules", "actors", "method", "alive", "work",
                 "clocks", "until", "entries", "free", "rails", "special", "owners")

    def __init__(self, world, state, forces, rules, actors, method, alive, work, clocks=(),
                 until=None):
        self.world, self.state, self.forces, self.rules = world, state, forces, rules
        self.actors, self.method, self.alive, self.work = actors, method, alive, work
        self.clocks = clocks     # (2,) arrays the tables share: [time base, steps], per call
        self.until = until       # the last time the ephemerides flown cover (None: none)
        self.entries = {}
        self.free = np.zeros(0, np.int64)  # the rows integrated: neither fixed nor on rails
        self.rails = None                  # the bodies on rails' table (RailsArrays) or None
        self.special = False               # bodies on rails or coasting: driver._special
        self.owners = None                 # (n,) int64: the rules table's owner array

    def call(self, kernel, frames, dt, nsteps, t0, label="the step"):
        args = (self.state, self.forces, self.rules, self.actors, frames, self.method,
                float(dt), int(nsteps), float(t0))
        key = (kernel, frames is None)
        entry = self.entries.get(key)
        if entry is None:
            # the tables' types say which machine code takes them (the method's arrays are
            # of one type per family, whose table type names it): a plan rebuilt for new
            # bodies finds it here
            kinds = (kernel, frames is None, type(self.method)) + tuple(
                getattr(a, "_numba_type_", None) for a in args[:4])
            entry = _ENTRIES.get(kinds)
            if entry is None:                  # new in this process: compile or load once
                sig = tuple(kernel.typeof_pyval(a) for a in args)
                with announced(f"{label} for this scene"):
                    _compile(kernel, sig)
                _ENTRIES[kinds] = self.entries[key] = kernel.overloads[sig].entry_point
                return kernel(*args)
            self.entries[key] = entry
        return entry(*args)


def _compile(kernel, sig):
    """Compile (or load) the step kernel for the argument types sig, the parts it calls by
    address compiled side by side (_jit.side_by_side). Under numba's lock: no other thread
    runs the kernel before every part is in place; what a call that failed left typed and
    not compiled is completed before the kernel runs."""
    with side_by_side(), compiling():
        if sig not in kernel.overloads:
            kernel.compile(sig)


# (kernel, frames or not, the tables' types) -> the compiled entry point: plans rebuilt for
# new bodies find the machine code here instead of asking numba to type their arguments again
_ENTRIES = {}


STEPPERS = {cls.family: cls for cls in (Splitting, RungeKutta, GaussRadau, WisdomHolman)}


def stepper_for(spec):
    """A new stepper for the integrator spec (an entry of spacephys.INTEGRATORS)."""
    return STEPPERS[spec.family](spec)


def capabilities(name):
    """The Capabilities of the integrator registered under name."""
    return STEPPERS[get_integrator(name).family].capabilities
