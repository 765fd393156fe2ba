"""World: the game-facing facade over the bodies and the World's parts.

A World holds the bodies (state.Bodies) and four parts, each in a file of its own: the forces
(forces.ForceField), the collision rules (collisions.CollisionRules), the ships, missiles and
lifetimes (actors.Actors) and the integrator's stepper (steppers.py). It validates what it is
told, keeps time, and on each step hands the kernels the tables its parts build (a
steppers.Plan, rebuilt only when the set of bodies or a setting changes). Its step driver
(driver.py), state (worldstate.py), body editing (editing.py) and diagnostics (measures.py)
are modules of their own, its methods delegating to them. The parts are the World's own;
nothing else reads its private attributes (docs/architecture.md).
"""
import copy
import importlib
import math
import sys
from typing import NamedTuple, Optional

import numpy as np

from . import _validate as check
from ._jit import ThreadChoice, announced
from .actors import Actors
from .coasting import Coasting
from .collisions import CollisionRules
from .driver import Driver
# Body is sp.Body; PASSIVE_KINDS is read from here (scenario.py)
from .editing import PASSIVE_KINDS, Body  # noqa: F401
from .errors import InstabilityError
from .events import EVENT_DTYPE
from .forces import GRAVITY_MODELS, HELD, ForceField
from .integrators import get_integrator
from . import editing, journal, measures, orbits, worldstate
from .journal import journaled_setter
from .kernels import state as kstate
from .kernels.codes import BOUNDARIES, RESPONSES
from .kernels.rules import SCRATCH
from .state import Bodies
from .steppers import RAILS_REFUSED, Plan, stepper_for
from .units import get_units

STEP_CONTROLS = ("auto", "pulling", "all")
DEFAULT_KINDS = ("body", "star", "planet", "moon", "asteroid", "ship", "missile", "debris")
_first_tables = True       # no World has built its kernel tables in this process yet

__all__ = ["World", "Body", "InstabilityError", "GRAVITY_MODELS", "RESPONSES", "BOUNDARIES",
           "DEFAULT_KINDS"]


def _readonly(arr):
    view = arr.view()
    view.flags.writeable = False
    return view


# advance()'s default warp, told apart from a warp asked by its identity
NO_WARP = 1.0


def _queries():
    """spacephys.queries, imported by the first query (import spacephys stays lean); a
    look-up, not an import statement, after it (1 us of each query)."""
    return sys.modules.get(f"{__package__}.queries") or \
        importlib.import_module(f"{__package__}.queries")


class World:
    """Bodies under gravity, advanced by an integrator whose loop runs in numba.

    Parameters
    ----------
    dim : 2 or 3
    units
        "game" (G = 1), "si" (G = 6.6743e-11), "au-msun-yr" (G = 39.4769...)
    G : float >= 0
        overrides the units' G [length^3 / (mass time^2)]
    integrator
        a name of spacephys.INTEGRATORS
    dt : float > 0
        the step [time]; for an adaptive integrator the output interval: step(n)
        lands exactly on n * dt, taking as many substeps as the accuracy needs
    tolerance : float >= 0
        the adaptive integrator's error parameter (1e-9 gives machine
        precision for Gauss-Radau; 0 turns adaptivity off: steps of min(dt, max_step))
    max_step : float > 0 or None
        longest adaptive substep (so that thrust changes, collisions
        and frame boundaries are not stepped over) [time]
    min_step : float >= 0
        shortest adaptive substep; reaching it warns, since accuracy is no
        longer controlled [time]
    step_control : "auto" | "pulling" | "all"
        which bodies set the adaptive step. "pulling":
        only the bodies that pull, so test particles and passive ships never change
        their trajectories (the passive bodies are still iterated to convergence within
        those steps). "all": every body. "auto" (default): "pulling" when two or more
        bodies pull under direct gravity, else "all" (a lone star has no dynamics of its
        own to set a step)
    softening : float >= 0
        Plummer softening length [length]
    gravity
        "direct" (mutual, bodies of mass 0 or passive feel but do not pull),
        "tree" (the same, the sum by a Barnes-Hut tree: for thousands of pulling bodies
        and more, docs/tree.md), "uniform" (a constant field g), "central" (a fixed
        body central_mass at central_pos; bodies ignore each other), "none"
    theta
        the tree's opening angle, 0 < theta <= 1.5 (default 0.5; smaller: more accurate
        and slower), with gravity="tree"
    quadrupole
        the tree's nodes pull with quadrupole moments (default True) or as point
        masses, with gravity="tree"
    g : (dim,)
        uniform field [length / time^2], with gravity="uniform"
    central_mass, central_pos
        the fixed body, with gravity="central" (pos defaults to 0)
    max_substeps : int >= 1
        most steps one advance() call may take (against the spiral of death)
    capacity : int
        initial room for bodies (grows by doubling)
    seed : int >= 0
        seeds every random choice (explosions): same seed, same run
    drag : float >= 0
        linear drag rate k [1/time]: every body also accelerates by
        -k (v - wind) (an atmosphere: the wind resistance of Laird & Jamin, *Basic Game Physics*)
    wind : (dim,)
        the air's velocity [length/time] (default 0)
    coast : None | "auto"
        "auto": every ship that does not thrust coasts on patched conics (World.coast)
    """

    def __init__(self, dim=2, *, units="game", G=None, integrator="leapfrog", dt=1 / 240,
                 softening=0.0, gravity="direct", g=None, central_mass=None, central_pos=None,
                 tolerance=1e-9, max_step=None, min_step=0.0, step_control="auto",
                 max_substeps=16, capacity=64, seed=0, drag=0.0, wind=None, theta=None,
                 quadrupole=None, coast=None):
        if coast not in (None, "auto"):
            raise ValueError(f"coast = {coast!r}: must be None or 'auto'")
        if isinstance(dim, bool) or not isinstance(dim, (int, np.integer)) or dim not in (2, 3):
            raise ValueError(f"dim = {dim!r}: must be the integer 2 or 3")
        dim = int(dim)
        unit_system = get_units(units)
        G = unit_system.G if G is None else check.scalar("G", G, minimum=0.0)
        spec = get_integrator(integrator)
        dt = check.scalar("dt", dt, positive=True)
        forces = ForceField(dim, G=G, gravity=gravity, g=g, central_mass=central_mass,
                            central_pos=central_pos, softening=softening, drag=drag, wind=wind,
                            theta=theta, quadrupole=quadrupole)
        max_substeps = check.count("max_substeps", max_substeps, minimum=1)
        capacity = check.count("capacity", capacity, minimum=1)
        seed = check.count("seed", seed)
        adaptive = self._adaptive_settings(tolerance, max_step, min_step)
        step_control = self._checked_step_control(step_control)

        self._transient()
        self._dim = dim
        self._units = unit_system
        self._forces = forces
        forces.rails.auto = coast == "auto"
        forces.rails.touch()
        self._b = Bodies(capacity)
        self._kinds = list(DEFAULT_KINDS)
        self._collisions = CollisionRules(len(DEFAULT_KINDS))
        self._actors = Actors(self, seed)
        self._spec = spec
        self._stepper = stepper_for(spec)
        self._adaptive = np.array(adaptive)          # [tolerance, max_step, min_step]
        self._step_control = step_control
        self._max_substeps = max_substeps
        self._dt = dt
        self._t_base = 0.0              # t = t_base + steps * dt: no rounding build-up in t
        self._steps = 0
        self._accumulator = 0.0
        self._dropped = 0.0             # frame time advance() dropped to stay real-time
        self._events = np.zeros(256, dtype=EVENT_DTYPE)
        self._event_count = np.zeros(1, dtype=np.int64)
        self._origin = np.zeros(3)      # where the coordinates are measured from
        self._watch = None              # watch_energy's (limit, E0, body energies, ids)
        self._threads = ThreadChoice()  # whether the force loops run on threads

    # ---------------------------------------------------------------- settings
    @property
    def dim(self):
        """2 or 3: the World's dimension (positions are (n, dim))."""
        return self._dim

    @property
    def units(self):
        """The UnitSystem (name, G, unit names)."""
        return self._units

    @property
    def G(self):
        """The gravitational constant [length^3 / (mass time^2)] (from units=, or G=)."""
        return self._forces.G

    @property
    def gravity(self):
        """The gravity model's name: "direct", "tree", "uniform", "central" or "none" (as
        given to World())."""
        return self._forces.gravity

    @property
    def central_mass(self):
        """The fixed body's mass with gravity="central", else None."""
        return self._forces.field_mass if self.gravity == "central" else None

    @property
    def central_pos(self):
        """(dim,) the fixed body's position with gravity="central", else None."""
        return self._forces.field[:self._dim].copy() if self.gravity == "central" else None

    @property
    def g(self):
        """(dim,) the uniform field with gravity="uniform", else None."""
        return self._forces.field[:self._dim].copy() if self.gravity == "uniform" else None

    @property
    def seed(self):
        """The seed of every random choice (explosions)."""
        return self._actors.seed

    @property
    def t(self):
        """Simulation time [time]."""
        return self._t_base + self._steps * self._dt

    def time_after(self, steps):
        """The time after that many more steps of dt, computed as t is (for schedules)."""
        return self._t_base + (self._steps + steps) * self._dt

    @property
    def dt(self):
        """The step [time] (for an adaptive integrator the output interval); assignable."""
        return self._dt

    @dt.setter
    @journaled_setter("dt")
    def dt(self, value):
        value = check.scalar("dt", value, positive=True)
        self._actors.check_step(value, "dt")
        self._t_base, self._steps = self.t, 0
        self._dt = value

    @property
    def dropped_time(self):
        """Frame time advance() dropped to stay real-time [time]."""
        return self._dropped

    @dropped_time.setter
    @journaled_setter("dropped_time")
    def dropped_time(self, value):
        self._dropped = check.scalar("dropped_time", value, minimum=0.0)

    @property
    def threads(self):
        """Whether this World's force loops (those of 10^4 pair evaluations or more) run on
        threads: "auto" (default: while they measure faster than one thread, see
        _jit.ThreadChoice), "always" (a machine whose cores are the simulation's) or
        "never". sp.set_threads sets how many. Results are the same bit for bit."""
        return self._threads.mode

    @threads.setter
    def threads(self, mode):
        self._threads.set(mode)
        self._set_up()               # "never": the tables hold no threaded loops

    @property
    def integrator(self):
        """The integrator's name; assign a name of spacephys.INTEGRATORS to switch."""
        return self._spec.name

    @integrator.setter
    @journaled_setter("integrator")
    def integrator(self, name):
        spec = get_integrator(name)
        self._spec = spec
        self._stepper = stepper_for(spec)
        self._stepper.reset(self)            # switching voids the old method's carried state
        self._set_up()

    @property
    def integrator_spec(self):
        """The integrator's spacephys.Integrator: name, order, symplectic, adaptive, family,
        force evaluations a step and its reference."""
        return self._spec

    @property
    def stepper(self):
        """The integrator family's stepper (steppers.py): its capabilities, its counters."""
        return self._stepper

    @property
    def max_substeps(self):
        """Most steps one advance() call may take; the rest of a long frame is dropped."""
        return self._max_substeps

    @max_substeps.setter
    @journaled_setter("max_substeps")
    def max_substeps(self, value):
        self._max_substeps = check.count("max_substeps", value, minimum=1)
        self._setup = None

    @staticmethod
    def _checked_step_control(value):
        if not isinstance(value, str) or value not in STEP_CONTROLS:
            raise ValueError(f"step_control={value!r} is not known; valid: "
                             f"{', '.join(STEP_CONTROLS)}")
        return value

    @property
    def step_control(self):
        """Which bodies set an adaptive integrator's step: "auto", "pulling" or "all"."""
        return self._step_control

    @step_control.setter
    @journaled_setter("step_control")
    def step_control(self, value):
        self._step_control = self._checked_step_control(value)
        self._set_up()

    def step_control_rows(self, src):
        """Whether only the pulling bodies (src rows) set an adaptive step."""
        return self._forces.mutual and (
            self._step_control == "pulling" and src.size > 0
            or self._step_control == "auto" and src.size >= 2)

    @staticmethod
    def _adaptive_settings(tolerance, max_step, min_step):
        tolerance = check.scalar("tolerance", tolerance, minimum=0.0)
        max_step = np.inf if max_step is None else check.scalar("max_step", max_step, positive=True)
        min_step = check.scalar("min_step", min_step, minimum=0.0)
        if min_step > max_step:
            raise ValueError(f"min_step = {min_step} is larger than max_step = {max_step}")
        return tolerance, max_step, min_step

    @property
    def tolerance(self):
        """The adaptive integrator's error parameter (>= 0; 0: fixed substeps of
        min(dt, max_step)); assignable."""
        return float(self._adaptive[0])

    @tolerance.setter
    @journaled_setter("tolerance")
    def tolerance(self, value):
        self._adaptive[0] = self._adaptive_settings(value, None, 0.0)[0]

    @property
    def max_step(self):
        """The longest adaptive substep [time], or None (no limit); assignable."""
        return None if np.isinf(self._adaptive[1]) else float(self._adaptive[1])

    @max_step.setter
    @journaled_setter("max_step")
    def max_step(self, value):
        _, self._adaptive[1], _ = self._adaptive_settings(0.0, value, self._adaptive[2])

    @property
    def min_step(self):
        """The shortest adaptive substep [time] (reaching it warns); assignable."""
        return float(self._adaptive[2])

    @min_step.setter
    @journaled_setter("min_step")
    def min_step(self, value):
        max_step = None if np.isinf(self._adaptive[1]) else self._adaptive[1]
        _, _, self._adaptive[2] = self._adaptive_settings(0.0, max_step, value)

    @property
    def integrator_stats(self):
        """Counters of the adaptive integrator: steps taken, steps redone, steps held at
        min_step, steps whose corrector did not converge, corrector sweeps (each 7 force
        evaluations), and substeps of test particles that needed shorter steps than the
        bodies setting the step (zeros for the other integrators)."""
        return self._stepper.counters

    @property
    def drag(self):
        """Linear drag rate k [1/time]: each body accelerates by -k (v - wind)."""
        return float(self._forces.drag[0])

    @drag.setter
    @journaled_setter("drag")
    def drag(self, value):
        self._forces.drag[0] = check.scalar("drag", value, minimum=0.0)
        self._plan = None               # a table without drag has no drag code

    @property
    def wind(self):
        """(dim,) the velocity drag pulls bodies toward [length/time]."""
        return self._forces.drag[1:1 + self._dim].copy()

    @wind.setter
    @journaled_setter("wind")
    def wind(self, value):
        self._forces.drag[1:1 + self._dim] = check.floats("wind", value, (self._dim,))

    @property
    def softening(self):
        """The Plummer softening length [length]; assignable."""
        return self._forces.softening

    @softening.setter
    @journaled_setter("softening")
    def softening(self, value):
        self._forces.softening = check.scalar("softening", value, minimum=0.0)
        self._set_up()

    @property
    def theta(self):
        """The tree's opening angle with gravity="tree", else None."""
        return self._forces.theta if self.gravity == "tree" else None

    @theta.setter
    @journaled_setter("theta")
    def theta(self, value):
        if self.gravity != "tree":
            raise ValueError(f"theta is only used with gravity='tree' (gravity={self.gravity!r})")
        self._forces.theta = self._forces.checked_theta(value)
        self._set_up()

    @property
    def quadrupole(self):
        """Whether the tree's nodes pull with quadrupole moments, with gravity="tree"."""
        return self._forces.quadrupole if self.gravity == "tree" else None

    # ---------------------------------------------------------------- forces
    def apply_force(self, body, force):
        """Hold a force [mass length/time^2] on a body, (dim,), until changed (zeros: none):
        Box2D's ApplyForce, held across steps. Its acceleration is force / mass at every
        stage, so it follows a ship's mass as fuel burns. A body of mass 0 or a fixed body
        is refused."""
        self._hold(body, "force", force, 0)

    def apply_acceleration(self, body, acceleration):
        """Hold an acceleration [length/time^2] on a body, (dim,), until changed (zeros:
        none), whatever its mass. A fixed body is refused."""
        self._hold(body, "acceleration", acceleration, 3)

    def _hold(self, body, field, value, offset):
        i = self.index_of(body, "body")
        value = check.floats(field, value, (self._dim,))
        b = self._b
        if b.fixed[i] and np.any(value):
            raise ValueError(f"body = {body}: fixed (immovable); it takes no {field}")
        if offset == 0 and b.mass[i] == 0.0 and np.any(value):
            raise ValueError(f"body = {body}: mass 0 (a test particle): a force gives it no "
                             f"defined acceleration; use apply_acceleration")
        if HELD not in b.columns:
            b.ensure_column(HELD, (6,))
            self._plan = None
        b.held[i, offset:offset + self._dim] = value

    def applied(self, body):
        """(force (dim,), acceleration (dim,)) held on a body."""
        i = self.index_of(body, "body")
        if HELD not in self._b.columns:
            return np.zeros(self._dim), np.zeros(self._dim)
        row = self._b.held[i]
        return row[:self._dim].copy(), row[3:3 + self._dim].copy()

    def add_force(self, fn, params=()):
        """Add a user force: fn(t, pos, vel, mass, ids, params, out), a numba function
        (@numba.njit) that adds every body's acceleration [length/time^2] into out (n, 3);
        t [time], pos, vel (n, 3), mass (n,), ids (n,) int64, params (p,) float64 (given
        here). It is called inside the step kernels at every force evaluation, with no
        Python per step. A passive body's acceleration may depend on the pulling bodies and
        on itself only (passive bodies act on nothing). Returns the force's index (for
        set_force_params, remove_force). Save, load and replay find fn by its module and
        name: define it at the top level of an importable module."""
        k = self._forces.add(fn, params)
        self._set_up()
        return k

    def set_force_params(self, k, params):
        """Replace user force k's params (p,) float64."""
        self._forces.set_params(k, params)
        self._set_up()

    def remove_force(self, k):
        """Remove user force k (the later ones move down by one)."""
        self._forces.remove(k)
        self._set_up()

    @property
    def forces(self):
        """The user forces: a list of (fn, params copy)."""
        return [(fn, p.copy()) for fn, p in self._forces.user]

    # ---------------------------------------------------------------- kinds
    @property
    def kinds(self):
        """Kind names; a body's kind code indexes this tuple."""
        return tuple(self._kinds)

    def add_kind(self, name):
        """Declare a kind (idempotent); returns its code."""
        if not isinstance(name, str) or not name:
            raise ValueError(f"kind name = {name!r}: must be a non-empty string")
        if name == "*":
            raise ValueError("kind name = '*': reserved for 'every kind' in set_collision")
        if name not in self._kinds:
            if len(self._kinds) >= np.iinfo(np.int16).max:
                raise ValueError(f"kind {name!r}: too many kinds ({len(self._kinds)})")
            self._kinds.append(name)
            self._collisions.add_kind()
            self._set_up()
        return self._kinds.index(name)

    def kind_code(self, name):
        """The code of a declared kind name."""
        return int(editing.kind_codes(self, name, 1, "kind")[0])

    # ---------------------------------------------------------------- bodies
    def __len__(self):
        return self._b.n

    @property
    def n(self):
        """Number of live bodies."""
        return self._b.n

    # Index-aligned, read-only views of the live bodies. They reflect steps in place; an add or
    # remove may move rows, so take them afresh after changing the set of bodies.
    @property
    def ids(self):
        """(n,) int64: each live body's id, row by row (generation << 32 | slot)."""
        return _readonly(self._b.ids[:self._b.n])

    @property
    def pos(self):
        """(n, dim) positions [length]."""
        return _readonly(self._b.pos[:self._b.n, :self._dim])

    @property
    def vel(self):
        """(n, dim) velocities [length / time]."""
        return _readonly(self._b.vel[:self._b.n, :self._dim])

    @property
    def mass(self):
        """(n,) masses [mass]."""
        return _readonly(self._b.mass[:self._b.n])

    @property
    def radius(self):
        """(n,) radii [length] (a compound body's: the circle holding its circles)."""
        return _readonly(self._b.radius[:self._b.n])

    @property
    def kind(self):
        """(n,) int16 kind codes; names in w.kinds."""
        return _readonly(self._b.kind[:self._b.n])

    @property
    def category(self):
        """(n,) int64 collision-filter bits: what each body is (queries' mask= tests them)."""
        return _readonly(self._b.category[:self._b.n])

    @property
    def group(self):
        """(n,) int64 collision groups: bodies of one group > 0 never collide (0: none)."""
        return _readonly(editing.column(self, editing.GROUP))

    @property
    def tags(self):
        """(n,) int64: each body's tag, the game's own integer (add_body's tag=; 0: none)."""
        return _readonly(editing.column(self, editing.TAG))

    @property
    def mask(self):
        """(n,) int64 collision-filter bits: the categories each body meets (a query's
        filter= tests them with its category)."""
        return _readonly(self._b.mask[:self._b.n])

    @property
    def active(self):
        """(n,) bool: the bodies allowed to pull (by default all but ships, missiles and
        debris); w.pulls says which actually do."""
        return _readonly(self._b.active[:self._b.n])

    @property
    def pulls(self):
        """(n,) bool: True where a body pulls others, i.e. is active and has mass; the others
        (test particles, passive ships) feel gravity only."""
        b = self._b
        return b.active[:b.n] & (b.mass[:b.n] > 0)

    def add_body(self, mass, pos, vel=None, *, radius=0.0, kind="body", active=None,
                 fixed=False, category=1, mask=-1, group=0, lifetime=None, explosion=None,
                 tag=0, shape=None):
        """Add one body; returns its id.

        mass [mass] >= 0 (0: a test particle); pos, vel : (dim,); radius [length] >= 0;
        kind : a declared kind name or code; active : may pull others (it does when it has
        mass); default True, except for the kinds ship, missile and debris; fixed : immovable
        (it stays put, and collisions treat its mass as infinite); category, mask : collision
        filter bits: two bodies interact only if each one's category meets the other's mask
        (default: category 1, mask all bits); group : int >= 0, bodies of one group > 0 never
        collide (0: none; a ship and its own missiles, a fleet); lifetime [time] > 0: removed
        that long from now, with an expiry event (None: never); explosion : an
        sp.ExplosionSpec whose debris it throws out when a collision or a detonation destroys
        it (an asteroid that breaks up), as a ship's or missile's spec gives them; tag : an
        integer of the game's own (what the body is to it: a player, a score, an index into
        its tables), read back in w.tags and carried by nothing else; shape : an sp.Circles,
        a compound hitbox of circles (spheres) fixed in the body's frame, turning with it
        (radius then left out: the shape's bounding radius; the body gets an orientation,
        and contacts turn it: docs/guide/collisions.md#compound-hitboxes).
        """
        return editing.add_body(self, mass, pos, vel, radius, kind, active, fixed, category,
                                mask, group, lifetime, explosion, tag, shape)

    def add_bodies(self, mass, pos, vel=None, *, radius=0.0, kind="body", active=None,
                   fixed=False, category=1, mask=-1, group=0, lifetime=None,
                   explosion=None, tag=0, shape=None):
        """Add k bodies at once; returns their (k,) int64 ids.

        mass : number or (k,); pos, vel : (k, dim); radius : number or (k,);
        kind : one name/code or k of them; active, fixed : None/bool or (k,) bools (see
        add_body); category, mask, group, tag : int or (k,) ints; lifetime : None, a number
        or (k,) numbers > 0; explosion : one sp.ExplosionSpec for all (see add_body); shape :
        one sp.Circles for all, or a list of k (Circles or None). Everything is checked before
        anything is added.
        """
        return editing.add_bodies(self, mass, pos, vel, radius, kind, active, fixed, category,
                                  mask, group, lifetime, explosion, tag, shape)

    index_of = editing.index_of        # itself, not a call to it: a game's every-frame call

    def __contains__(self, body_id):
        return editing.contains(self, body_id)

    def get(self, body_id):
        """A copy of one body's state as a Body namedtuple."""
        return editing.get(self, body_id)

    def set_body(self, body_id, *, pos=None, vel=None, mass=None, radius=None, kind=None,
                 active=None, fixed=None, category=None, mask=None, group=None,
                 explosion=None, tag=None, angular_velocity=None, shape=None):
        """Change one body between steps; everything is checked before anything changes.

        A new pos also resets the body's render interpolation (a teleport, not a smear); a
        new pos or vel of a coasting body makes it integrated from there (coast="auto" sets
        it coasting again at the next call); of a body on rails, it is refused.
        explosion : an sp.ExplosionSpec it throws out when destroyed, or False for none;
        angular_velocity [rad/time] : body-frame, a number (2D, about z) or (3,): any body
        spins at it from then on (heading and orientation follow; no torque changes a
        rotor's), a ship or missile with physical rotation (ShipSpec.moment_of_inertia) until
        its thrusters turn it; shape : an sp.Circles (its radius becomes the shape's bounding
        radius), or False for round again.
        """
        editing.set_body(self, body_id, pos, vel, mass, radius, kind, active, fixed, category,
                         mask, group, explosion, tag, angular_velocity, shape)

    def shape(self, body):
        """The body's compound hitbox (an sp.Circles), or None for a round body."""
        return editing.shape_of(self, body)

    def circles(self, body=None):
        """Where hitboxes are now. For a body: (centres (k, dim), radii (k,)) of its circles
        (a round body: its centre and radius). For None: every circle of every compound body,
        (ids (C,), index of the circle in its body's Circles (C,), centres (C, dim),
        radii (C,))."""
        return editing.circles(self, body)

    def set_rails(self, body, about=None, *, ephemeris=None, entry=None):
        """Put a body on rails: from now on it moves along the Kepler orbit of its present
        state about body `about` (ellipse or hyperbola; mu = G (m_about + m_body) now, G
        m_about for a fixed parent; the parent itself integrated or on rails), never integrated: it pulls the others and
        feels nothing, and does not drift (kernels/rails.py solves Kepler's equation at
        each force evaluation's time). about=None takes it off rails, integrated again from
        where its rails had it. Its parent's removal takes it off rails. Not with
        Wisdom-Holman (its Jacobi drifts cannot take a body moved from outside).
        ephemeris : an sp.Ephemeris instead of about: the body follows its polynomials
        (entry: which of the ephemeris's bodies, default the body's id); stepping past the
        ephemeris's end is refused."""
        why = RAILS_REFUSED if self.integrator.startswith("wisdom_holman") else None
        editing.set_rails(self, body, about,
                          why if (about is not None or ephemeris is not None) else None,
                          ephemeris, entry)

    @property
    def rails(self):
        """(R,) structured (spacephys.rails.RAILS_DTYPE): id, about, a (negative: a
        hyperbola), e, period (inf: a hyperbola) and coasting (set by coast()) of each body
        on rails."""
        return self._forces.rails.listing()

    def coast(self, ids, on=True):
        """Patched conics: each body of ids (an id or ids) moves on the Kepler conic of its
        dominant body from now on, changing parent where it crosses a sphere of influence
        (Laplace's radius of a body on Kepler rails: set_rails), with events soi_exit and
        soi_enter at the times found; it returns to integration when it thrusts (control,
        a plan's burn), comes down to its parent's surface or within coast_near of an
        integrated body, or on coast(ids, False). Not for a body on rails, fixed,
        tethered, a missile or a thrusting ship (ValueError naming it; nothing changes).
        spacephys/coasting.py has the rules."""
        if on and self.integrator.startswith("wisdom_holman"):
            raise ValueError(f"ids: {RAILS_REFUSED} (coasting bodies are on rails)")
        self._coasting.coast(ids, bool(on))

    @property
    def coasting(self):
        """(C,) int64 ids of the coasting bodies."""
        r = self._forces.rails
        return r.ids[r.coast, 0].copy()

    @property
    def coast_auto(self):
        """Whether every ship that does not thrust coasts by itself (World(coast="auto"))."""
        return self._forces.rails.auto

    @coast_auto.setter
    @journaled_setter("coast_auto")
    def coast_auto(self, on):
        if not isinstance(on, (bool, np.bool_)):
            raise ValueError(f"coast_auto = {on!r}: must be True or False")
        self._forces.rails.auto = bool(on)
        self._forces.rails.touch()
        self._set_up()

    @property
    def coast_near(self):
        """The distance [length] beyond the two surfaces within which a coasting body
        returns to integration (0 by default: at the step before contact)."""
        return self._forces.rails.near

    @coast_near.setter
    @journaled_setter("coast_near")
    def coast_near(self, value):
        self._forces.rails.near = check.scalar("coast_near", value, minimum=0.0)
        self._set_up()

    @property
    def warp(self):
        """The time warp of the last advance() given one: Warp(asked, granted, reason),
        granted the factor the frame ran at and reason why it is less than asked (None when
        it is not); None before any."""
        return self._warp

    def tether(self, a, b, length=None, *, stiffness=None, rigid=False, break_force=None):
        """Join bodies a and b with a tether of length `length` [length] (default: their
        distance now); returns its id (World.tethers lists them).

        A rope (rigid=False) is slack below its length, a rod (rigid=True) holds it both
        ways. stiffness None: inextensible, held exactly (a constraint force in every force
        evaluation, the drift projected away after each step; a rope snapping taut loses its
        ends' relative speed along it); stiffness k [mass/time^2]: a spring pulling with
        k (r - L), its energy in potential_energy. break_force [mass length/time^2]: it
        breaks (a tether_break event) after a step whose tension passed it. Both ends need
        mass (or are fixed); removing either end removes the tether. Wisdom-Holman takes
        springs only.
        """
        return editing.tether(self, a, b, length, stiffness, rigid, break_force)

    def untether(self, tether):
        """Remove tether `tether` (an id of World.tethers)."""
        editing.untether(self, tether)

    @property
    def tethers(self):
        """(T,) structured: id, a, b, length, stiffness, rigid, break_force of each tether."""
        return editing.tethers(self)

    def _tether_rows(self):
        """(T, 2) rows of the tethers' ends (those of removed bodies and the broken ones
        dropped first), or None without tethers."""
        return editing.tether_rows(self)

    def remove(self, ids):
        """Remove one id or an array of ids (all must be live; duplicates count once)."""
        editing.remove(self, ids)

    # ---------------------------------------------------------------- copies
    def __getstate__(self):
        state = self.__dict__.copy()
        state["_plan"] = None                          # kernel tables: rebuilt on demand
        state["_scratch"] = None
        state["_log"] = None                           # a copy is not recorded
        state["_setup"] = None                         # a copy's snapshots are its own
        state["_token"] = None
        state.pop("_shadows", None)                    # predictions' copies (predict.py)
        for name in JOURNALED:
            state.pop(name, None)
        return state

    def __setstate__(self, state):
        self.__dict__.update(state)
        self._token = object()

    def copy(self):
        """An independent deep copy (same ids, state, time and settings)."""
        # the integrator spec is immutable and shared: a copied (writeable) table would make
        # numba compile the kernels a second time for a different array type
        return copy.deepcopy(self, memo={id(self._spec): self._spec})

    def snapshot(self):
        """The whole World as it is now, in memory, for restore(): every bit of the bodies
        (ids and their generations included), the clock, the events of the last call, the
        pairs in touch, the integrator's carried state, launches waiting, plans, forces and
        settings. Costs microseconds (the bodies are copied in one block; the settings are
        taken once per change and shared): made for rollback, a snapshot per frame. A
        snapshot restores only this World, in this process (World.state() is the state to
        keep or send)."""
        return worldstate.Snapshot.take(self)

    def restore(self, snapshot):
        """Make this World exactly as it was when `snapshot` (from its snapshot()) was
        taken: stepping on gives the same bits as if it had never left. A snapshot of
        another World, or taken by another spacephys, is a ValueError and nothing changes;
        so is a World being recorded (its run log cannot jump back). The snapshot stays
        valid: restore it as often as needed."""
        if not isinstance(snapshot, worldstate.Snapshot):
            raise ValueError(f"snapshot = {type(snapshot).__name__}: give what "
                             f"World.snapshot() returned")
        snapshot.put(self)

    def digest(self):
        """A 64-bit hash of the whole state (an int in [0, 2**64)): equal on two Worlds in
        the same state, whatever machine, process or history brought them there (a World
        restored, loaded with from_state or stepped alike); one bit changed anywhere changes
        it. For peers comparing their Worlds, and tests."""
        return worldstate.digest(self)

    # ---------------------------------------------------------------- run logs and files
    def record(self, path, *, every=1, every_time=None, checkpoint_every=None,
               checkpoint_seconds=10.0, flush_seconds=1.0, compression=None,
               compress_state=False, scenario=None):
        """Record this World into an HDF5 run log (see spacephys/runlog.py, docs/runlog.md);
        returns the RunLog (close it, or use it in a with-block).

        every : a frame every this many steps, or every_time : a frame whenever the time
        passes a multiple of it [time] (then every=None); frames hold ids, pos, vel, mass,
        radius and kind of the live bodies. Every step's events and every call that changes
        the World are recorded too; a checkpoint (the whole state, for resume) every
        checkpoint_seconds of wall time, or every checkpoint_every frames if that comes
        first, at the end of the call in which it fell due; the file is written every
        flush_seconds of wall time (and when 8 MB of state are waiting). compression: None
        (the default: a kill at any moment loses nothing committed), "gzip" or "lzf" for
        every table but positions and velocities, which are compressed too with
        compress_state=True (they shrink by about a fifth, at 20-50x the cost of writing
        them). Compressed tables are smaller (events and layouts by 100x) and checksummed,
        but a kill during a flush can destroy the last chunk of one, rows committed before
        included: HDF5 may rewrite a compressed chunk in place (docs/runlog.md). scenario: a
        text kept with the log. The file is created at once, so an unwritable path fails
        here, before anything runs.
        """
        from .runlog import RunLog
        if self._log is not None:
            raise ValueError(f"this World is already recorded into {self._log.path!r}")
        if every_time is not None:
            every_time = check.scalar("every_time", every_time, positive=True)
            if every not in (None, 1):
                raise ValueError(f"every = {every!r} and every_time = {every_time}: give one")
            every = None
        else:
            every = check.count("every", every, minimum=1)
        if checkpoint_every is not None:
            checkpoint_every = check.count("checkpoint_every", checkpoint_every, minimum=1)
        checkpoint_seconds = check.scalar("checkpoint_seconds", checkpoint_seconds,
                                          minimum=0.0)
        flush_seconds = check.scalar("flush_seconds", flush_seconds, minimum=0.0)
        if compression not in ("gzip", "lzf", None):
            raise ValueError(f"compression = {compression!r}: must be 'gzip', 'lzf' or None")
        if not isinstance(compress_state, (bool, np.bool_)):
            raise ValueError(f"compress_state = {compress_state!r}: must be True or False")
        if scenario is not None and not isinstance(scenario, str):
            raise ValueError(f"scenario = {scenario!r}: must be text")
        self.recording = RunLog(self, path, every=every, every_time=every_time,
                                checkpoint_every=checkpoint_every,
                                checkpoint_seconds=checkpoint_seconds,
                                flush_seconds=flush_seconds, compression=compression,
                                compress_state=bool(compress_state), scenario=scenario)
        return self._log

    @property
    def recording(self):
        """The RunLog recording this World, or None (run logs attach and detach theirs)."""
        return self._log

    @recording.setter
    def recording(self, log):
        self._log = log
        journal.attach(self, log, JOURNALED)

    def save(self, path):
        """Write the whole state to an HDF5 file; World.load(path) continues it bit for
        bit."""
        from .runlog import save_state
        save_state(self.state(), path)

    @staticmethod
    def load(path, checkpoint=-1):
        """A World from World.save's file or from a run log's checkpoint (default: the
        last)."""
        from .runlog import load_state
        return World.from_state(load_state(path, checkpoint)[0])

    def state(self):
        """The whole state as named fields (dicts of arrays and numbers): everything a
        bit-exact restart needs, nothing derived. docs/runlog.md documents every field;
        World.from_state(state) is the World again. Version STATE_VERSION (worldstate.py
        defines it)."""
        return worldstate.state(self)

    @classmethod
    def from_state(cls, s):
        """The World a state() describes, continuing bit for bit."""
        w = cls.__new__(cls)
        w._transient()
        w._actors = Actors(w, 0)
        w._threads = ThreadChoice()
        worldstate.load(w, s)
        return w

    def _transient(self):
        """What a World holds besides its state: derived or per-session (its tables, its
        scratch, its run log), set afresh."""
        self._log = None                   # the RunLog recording this World, if one is
        self._precision_warned = False     # PrecisionWarning given (once)
        self._plan = None                  # the kernels' tables for the bodies now (Plan)
        self._scratch = None               # per-body scratch kept at the capacity
        self._warning = None               # a warning to give once a call is booked
        self._setup = None                 # the setup snapshots share (worldstate.Setup)
        self._token = object()             # whose snapshots restore() takes: this World's
        self._driver = Driver(self)        # its step driver, and its extensions' interface
        self._coasting = Coasting(self)    # its patched conics (their state: the rails')
        self._warp = None                  # the last advance()'s Warp

    # ---------------------------------------------------------------- collisions
    def _kind_list(self, kind, field):
        if kind == "*":
            return list(range(len(self._kinds)))
        return [int(editing.kind_codes(self, kind, 1, field)[0])]

    def set_collision(self, kind_a, kind_b, response, restitution=None):
        """What happens when a body of kind_a meets one of kind_b (either order).

        response : "ignore" (the default for every pair), "sensor" (an event only),
        "elastic", "bounce" (with restitution in [0, 1]: 1 elastic, 0 no rebound), "merge"
        (one body with the pair's mass, momentum and centre of mass; radius from the summed
        volume in 3D, area in 2D), "destroy_a", "destroy_b", "destroy_both" (a: the body of
        kind_a), "break_a", "break_b" (a bounce, restitution default 1, after which that body
        is destroyed: the brick of Laird & Jamin, *Basic Game Physics*). A kind may be "*" for every kind.
        """
        self._collisions.set(self._kind_list(kind_a, "kind_a"),
                             self._kind_list(kind_b, "kind_b"), response, restitution)
        self._set_up()

    def collision(self, kind_a, kind_b):
        """The response set for (kind_a, kind_b), and its restitution."""
        return self._collisions.rule(self.kind_code(kind_a), self.kind_code(kind_b))

    def add_plane(self, point, normal, restitution=1.0):
        """An immovable wall: the plane (a line in 2D) through point, bodies on the side the
        normal points to. Returns its index in w.walls."""
        k = self._collisions.plane(point, normal, restitution, self._dim)
        self._set_up()
        return k

    def add_segment(self, a, b, restitution=1.0):
        """An immovable wall segment from a to b (with round ends): the circle-on-wall of Laird & Jamin,
        *Basic Game Physics*.
        Returns its index in w.walls."""
        k = self._collisions.segment(a, b, restitution, self._dim)
        self._set_up()
        return k

    @property
    def walls(self):
        """(W, 8) rows [type (0 plane, 1 segment), x0, y0, z0, x1, y1, z1, restitution]."""
        return _readonly(self._collisions.walls)

    def clear_walls(self):
        """Remove every wall (add_plane's and add_segment's); the boundary box stays."""
        self._collisions.walls = np.zeros((0, 8))
        self._set_up()

    def set_boundary(self, mode, lo=None, hi=None, restitution=1.0):
        """The world's edge: "open" (none), "reflect" (walls of the box lo..hi) or "periodic"
        (Asteroids-style: leaving one side enters the opposite one; contacts across the seam
        count; gravity itself is not periodic)."""
        self._collisions.set_boundary(mode, lo, hi, restitution, self._dim)
        self._set_up()

    @property
    def boundary(self):
        """(mode, lo, hi, restitution)."""
        return self._collisions.boundary_of(self._dim)

    @property
    def collision_cell(self):
        """The broad phase's grid cell [length]; None (default): the largest diameter."""
        return self._collisions.cell

    @collision_cell.setter
    @journaled_setter("collision_cell")
    def collision_cell(self, value):
        self._collisions.set_cell(value)
        self._set_up()

    @property
    def collides(self):
        """Whether anything can collide: a response set, a wall, or a boundary."""
        return self._collisions.enabled()

    @property
    def events(self):
        """Structured array (spacephys.EVENT_DTYPE) of what happened in the last step() or
        advance() (launches made before it included): kind, ids a and b, time, time within
        its step, contact point, normal, closing speed, kinetic energy lost, distance."""
        return self._events[:self._event_count[0]].copy()

    # ---------------------------------------------------------------- ships and missiles
    def add_ship(self, spec, pos, vel=None, heading=None):
        """Add a ship; returns its id. spec : ShipSpec; pos, vel : (dim,); heading : the
        direction the main engine pushes, an angle [rad] from +x (2D) or a vector (2D or
        3D); default +x. It starts with full fuel, throttle 0 and no turning."""
        return self._actors.add_ship(spec, pos, vel, heading)

    def control(self, body, *, throttle=None, turn=None, strafe=None):
        """Set a ship's (or missile's) controls, held until changed.

        throttle in [0, 1] of max_thrust; turn in [-1, 1]: 2D a number (+ counter-clockwise),
        3D (roll, pitch, yaw) about the body axes (x forward, y left, z up), fractions of
        turn_rate (arcade) or of torque (physical rotation); strafe in [-1, 1]: 2D a number
        (+ to the left of the heading), 3D (left, up), fractions of side_thrust. Guided
        missiles steer themselves and ignore turn."""
        self._actors.control(body, throttle, turn, strafe)

    def controls(self, body):
        """(throttle, turn, strafe) of a ship or missile as control() last left them: numbers
        in 2D, turn (3,) and strafe (2,) in 3D (a guided missile's turn is its guidance's,
        not these)."""
        return self._actors.controls(body)

    def heading(self, body):
        """Where the body's x axis points (a ship's main engine): an angle [rad] in
        (-pi, pi] in 2D, a unit (3,) vector in 3D; 0 (+x) for a body never given one."""
        return self._actors.heading(body)

    @property
    def headings(self):
        """Every body's heading at once, for renderers: (n,) angles [rad] in 2D, (n, 3) unit
        vectors in 3D; NaN for the bodies never given an orientation (heading() reads 0)."""
        return self._actors.headings()

    def orientation(self, body):
        """The unit quaternion (w, x, y, z) turning body axes (x forward, y left, z up) into
        world axes; (1, 0, 0, 0) for a body never given one."""
        return self._actors.orientation(body)

    def set_heading(self, body, heading):
        """Point any body: an angle [rad] (2D) or a vector; stops its rotation. A body that
        is not a ship or missile gets an orientation of its own from then on (it turns at
        its angular_velocity, see set_body); bodies never given one carry none."""
        self._actors.set_heading(body, heading)

    def angular_velocity(self, body):
        """Body-frame angular velocity [rad/time]: the z rate in 2D, (3,) in 3D (physical
        rotation; arcade turning has none between steps); 0 for a body never given one."""
        return self._actors.angular_velocity(body)

    def fuel(self, body):
        """Fuel left [mass]."""
        return self._actors.fuel(body)

    def set_fuel(self, body, fuel):
        """Refuel (or drain) an actor; its mass becomes dry + fuel."""
        self._actors.set_fuel(body, fuel)

    def delta_v(self, body):
        """Speed change the fuel left can still give, ve ln((dry + fuel) / dry)
        (Tsiolkovsky) [length/time]."""
        return self._actors.delta_v(body)

    def engine(self, body):
        """(max_thrust [mass length/time^2], exhaust_speed [length/time]) of a ship's or
        missile's main engine."""
        return self._actors.engine(body)

    def is_ship(self, body_id):
        """True for a ship (add_ship), False for a missile or any other body."""
        return self._actors.is_ship(body_id)

    def plan(self, ship, burns):
        """Give a ship a manoeuvre plan: burns, a list of sp.Burn in time order, each starting
        now or later and at least one step (dt) after the one before stops; [] clears it.
        While a burn covers a step the autopilot flies the ship: heading held along the
        burn's direction in its frame (taken at each step's start), the burn's throttle,
        thrust from its start to its stop to the exact time (fuel and the ship's burn time
        still limit it: a fuel_empty event says so). Between burns, and at a step where the
        burn's direction is undefined (no motion relative to its frame), the ship's own
        controls fly it. Replaces the ship's earlier plan; checked whole before anything
        changes."""
        self._actors.plan(ship, burns)

    def planned(self, ship):
        """The ship's plan: a list of sp.Burn, frames resolved to ids."""
        return self._actors.planned(ship)

    def launch(self, parent, spec, target=None, heading=None, *, category=None, mask=None,
               group=None):
        """Launch a missile from any live body; returns its id.

        It appears just outside the parent (centres r_parent + r_missile apart) along the
        heading (default: the parent's own, if it is a ship), with the parent's velocity plus
        spec.launch_speed along the heading; with spec.recoil the parent gives up the
        missile's mass and takes the opposite momentum. target : an id to guide toward and
        fuse against. category, mask, group : this missile's collision filter instead of the
        spec's (add_body's: a side's bits, its ship's group). It never meets its launcher
        unless spec.hits_launcher (then only once armed). A launch event is reported with
        the next step's events."""
        return self._actors.launch(parent, spec, target, heading, category, mask, group)

    def explode(self, body, spec=None):
        """Remove a body and throw out its debris: spec, or the ExplosionSpec it was made
        with. Returns the (count,) ids of the debris."""
        return self._actors.explode(body, spec)

    @property
    def actor_ids(self):
        """(k,) int64 ids of the ships and missiles, in row order."""
        b = self._b
        return b.ids[self._actors.engines()]

    @property
    def engines_lit(self):
        """(n,) bool, for renderers: whether each body's engine is lit (a ship or missile
        with throttle > 0 and fuel left: controls() and fuel() of each at once)."""
        return self._actors.engines_lit()

    @property
    def intensity(self):
        """(n,) float in [0, 1] for renderers: (1 - age/lifetime)^fade for bodies with a
        lifetime (debris fade out), 1 for the others."""
        return self._actors.intensity()

    # ---------------------------------------------------------------- the kernels' tables
    def _invalidate(self):
        """The set of bodies or a per-body setting the tables derive from changed."""
        self._plan = None
        measures.rewatch(self)

    def _set_up(self):
        """A setting changed: the tables are built anew, and the next snapshot takes the
        setup again (worldstate.Setup)."""
        self._plan = None
        self._setup = None

    def _sources(self):
        """(src, passive, still): the bodies that pull, the others, the immovable ones."""
        b = self._b
        pulls = b.active[:b.n] & (b.mass[:b.n] > 0)
        return (np.flatnonzero(pulls).astype(np.int64, copy=False),
                np.flatnonzero(~pulls).astype(np.int64, copy=False),
                np.flatnonzero(b.fixed[:b.n]).astype(np.int64, copy=False))

    def _scratch_rows(self, n):
        """Per-body scratch (State's acc, pos0, vel0, alive; the collision pass's once the
        scene collides), kept at the capacity (fresh arrays every step cost more in page
        faults than the work done in them), as views of n rows."""
        cap = self._b.capacity
        if self._scratch is None or self._scratch["acc"].shape[0] != cap:
            self._scratch = {}
        shapes = {"acc": (3, np.float64), "pos0": (3, np.float64), "vel0": (3, np.float64),
                  "alive": ((), np.bool_), **(SCRATCH if self._collisions.enabled() else {})}
        for name, (shape, dtype) in shapes.items():
            if name not in self._scratch:
                self._scratch[name] = np.zeros((cap,) + ((shape,) if shape != () else ()),
                                               dtype)
        return {name: a[:n] for name, a in self._scratch.items()}

    def bytes_per_body(self):
        """Memory held per body [bytes], by part: the state columns (ids, pos, vel, prev, mass,
        radius, kind, flags, collision bits, serial and whatever ships, lifetimes or
        Gauss-Radau added), the id slots, the kernels' scratch (kept at the capacity)."""
        b = self._b
        self._scratch_rows(b.n)
        per = lambda a: a.itemsize * int(np.prod(a.shape[1:]))
        return {"state columns": sum(per(getattr(b, c)) for c in b.columns),
                "id slots": b.generation.itemsize + b.index.itemsize,
                "kernel scratch": sum(per(a) for a in self._scratch.values())}

    def tables(self):
        """The kernels' tables for the bodies now alive (a steppers.Plan: state, forces,
        rules, actors, method), built when something they hold changed. For tools that time
        or test the kernels on a World (bench, tests); a game never needs it. Refuses (with
        the reason) an integrator that cannot run the scene."""
        plan = self._plan
        if plan is not None:
            return plan
        global _first_tables
        if _first_tables:                     # the tables' builders: compiled or loaded once
            _first_tables = False
            with announced("the tables of this scene"):
                return self.tables()
        b = self._b
        n = b.n
        sources = self._sources()
        actors = self._actors.rows()
        self._stepper.check(self, sources, self._actors.engines())
        b.ensure_columns(self._stepper.columns)     # before any table takes a column
        scratch = self._scratch_rows(n)
        alive = scratch["alive"]
        alive[:] = True
        state = kstate.make(pos=b.pos[:n], vel=b.vel[:n], prev=b.prev[:n], mass=b.mass[:n],
                            ids=b.ids[:n], alive=alive, acc=scratch["acc"],
                            pos0=scratch["pos0"], vel0=scratch["vel0"], events=self._events,
                            count=self._event_count, dim=self._dim)
        work = self._forces.work(n, sources[0].size)
        threads = self._threads.min_pairs if self._threads.mode != "never" and \
            self._forces.threaded(work) else None
        entries = len(self._forces.rails)
        rails = self._forces.rails.table(b.lookup, b.active[:n] & (b.mass[:n] > 0))
        if len(self._forces.rails) != entries:
            self._setup = None   # a body whose parent is gone left its rails: a setting
        forces = self._forces.table(b.mass[:n], b.ids[:n], *sources,
                                    b.held[:n] if HELD in b.columns else None, threads,
                                    self._tether_rows(), b.fixed[:n], b.pos[:n], rails)
        immovable = b.fixed[:n]
        if rails is not None:          # a body on rails: no contact moves it
            immovable = immovable.copy()
            immovable[rails.rows] = True
        owners = self._actors.owners()
        rules = self._collisions.table(b.kind[:n].astype(np.int64), b.radius[:n],
                                       b.category[:n], b.mask[:n], editing.optional(self, editing.GROUP),
                                       immovable, owners, self._dim,
                                       b.index, scratch, *self._shape_columns(n))
        kactors = self._actors.table(actors)
        clocks = ((self._actors.clock,) if kactors is not None else ()) + \
            ((self._forces.rails.clock,) if rails is not None else ())
        plan = Plan(self, state, forces, rules, kactors, self._stepper.method(self, sources),
                    alive, work, clocks, self._forces.rails.until)
        moving = ~b.fixed[:n]
        if rails is not None:
            moving[rails.rows] = False
        plan.free = np.flatnonzero(moving)
        plan.rails = rails
        plan.special = rails is not None or self._forces.rails.active
        plan.owners = None if rules is None else owners     # the table's own (shared)
        self._plan = plan
        measures.check_precision(self, b.pos[:n, :self._dim])
        return plan

    def _shape_columns(self, n):
        """(the shape column, the orientation columns (quat, omega, inertia)) for the
        collision table, (None, None) when no body has a shape."""
        b = self._b
        if editing.SHAPE not in b.columns:
            return None, None
        return b.shape[:n], (b.quat[:n], b.omega[:n], b.inertia[:n])

    # ---------------------------------------------------------------- stepping
    def step(self, n=1):
        """Advance n steps of dt, the loop inside numba; returns the new time. w.events then
        holds what happened during these steps."""
        if type(n) is not int or n < 0:
            n = check.count("n", n)
        self._driver.run(n, self._log)
        return self._t_base + self._steps * self._dt

    @property
    def driver(self):
        """What runs this World's steps, and the interface spacephys's own extensions
        (predictions, their tape, queries) read it through: see spacephys/driver.py."""
        return self._driver

    def warn_later(self, message):
        """A RuntimeWarning given once the current call has booked its steps (a warning
        turned into an error must find the World consistent)."""
        self._warning = message

    def advance(self, frame_time, warp=NO_WARP):
        """Fixed-step accumulator for variable frame time; returns alpha in [0, 1).

        Adds frame_time [time] x warp to the accumulator and takes as many whole steps of dt
        as fit, at most max_substeps (the excess goes to dropped_time, so a slow frame slows
        the simulation down instead of making the next frame slower still). Draw
        w.interpolate(alpha), between the states before and after the last step.

        warp : simulated time per frame time (> 0, finite). When nothing is integrated
        (every body that moves is on rails or coasting, and no ship turns) time passes in
        jumps, whatever the warp, and events between frames are found by time; otherwise at
        most max_substeps steps are integrated a frame, so the warp granted is less:
        w.warp says what was asked, granted, and why.
        """
        if warp is not NO_WARP:       # (the default's own object: a game's every-frame call)
            return self._warped(frame_time, warp)
        if type(frame_time) is not float or not 0.0 <= frame_time < math.inf:
            frame_time = check.scalar("frame_time", frame_time, minimum=0.0)
        n, left, dropped = self._substeps(self._accumulator + frame_time, self._max_substeps)
        steps = self._steps
        try:
            self.step(n)                 # the only part that can fail: nothing changed before
        except InstabilityError:
            if self._steps - steps == n:     # the steps were taken; the check found them bad
                self._accumulator = left
                self._dropped += dropped
            raise
        self._accumulator = left
        self._dropped += dropped
        return min(left / self._dt, 0.9999999999999999)

    def _substeps(self, acc, cap):
        """(steps, what is left in the accumulator, what is dropped) for `acc` of time and at
        most `cap` steps."""
        dt = self._dt
        # a hair of slack so that 4 frames of dt/4 make one step, not 0.99999 of one
        whole = acc / dt * (1.0 + 1e-12)
        if whole >= cap + 1:          # also a frame of inf steps
            return cap, 0.0, acc - cap * dt
        n = int(whole)
        return n, max(acc - n * dt, 0.0), 0.0

    def _warped(self, frame_time, warp):
        """advance() with a warp: time passes in jumps when nothing is integrated, else at
        most max_substeps steps are integrated; w.warp says what was granted and why."""
        frame_time = check.scalar("frame_time", frame_time, minimum=0.0)
        warp = check.scalar("warp", warp, positive=True)
        if not math.isfinite(warp):
            raise ValueError(f"warp = {warp}: must be finite")
        reason = self._coasting.why_integrated()
        n, left, dropped = self._substeps(self._accumulator + frame_time * warp,
                                          math.inf if reason is None else self._max_substeps)
        steps = self._steps
        driver = self._driver
        driver.budget, driver.cut = self._max_substeps, 0
        try:
            self.step(n)
        except InstabilityError:
            if self._steps - steps == n:
                self._accumulator = left
                self._dropped += dropped
            raise
        finally:
            driver.budget = None
        if driver.cut:                   # a body integrated from within the frame: its budget
            dropped += driver.cut * self._dt
            reason = reason or self._coasting.why_integrated()
            driver.cut = 0
        self._accumulator = left
        self._dropped += dropped
        granted = warp if not dropped else \
            max(warp - dropped / frame_time, 0.0) if frame_time > 0 else warp
        self._warp = Warp(warp, granted, reason if granted < warp else None)
        return min(left / self._dt, 0.9999999999999999)

    def interpolate(self, alpha):
        """(n, dim) positions for rendering: prev + alpha (pos - prev), alpha in [0, 1]."""
        alpha = check.scalar("alpha", alpha, minimum=0.0)
        if alpha > 1.0:
            raise ValueError(f"alpha = {alpha}: must be <= 1")
        b = self._b
        prev = b.prev[:b.n, :self._dim]
        return prev + alpha * (b.pos[:b.n, :self._dim] - prev)

    # ---------------------------------------------------------------- instability
    def named(self, rows, most=5):
        """'body 3 (planet), body 7 (moon) and 12 more' for rows of live bodies."""
        return measures.named(self, rows, most)

    def closest_pulling_pair(self):
        """The rows of the two pulling bodies closest together (none if fewer than 2, or too
        many to compare all pairs for an error message)."""
        return measures.closest_pulling_pair(self)

    def watch_energy(self, limit):
        """From now on, raise InstabilityError after any step() or advance() that leaves the
        relative energy error of the pulling bodies (since this call) above limit, naming the
        bodies whose own energy changed most; limit=None stops watching. For scenes that
        conserve energy: thrust, drag, and collisions that merge or break change it. Costs
        an energy sum, O(N_pulling^2), per call."""
        measures.watch_energy(self, limit)

    # ---------------------------------------------------------------- origin
    @property
    def origin(self):
        """(dim,) where this World's coordinates are measured from, in the coordinates it
        started with [length]: the absolute position of a body is origin + pos."""
        return self._origin[:self._dim].copy()

    def shift_origin(self, delta):
        """Move the coordinate origin by delta (dim,) [length]: every position (bodies, the
        central body, walls, the boundary box, launches not yet reported) drops by delta,
        velocities stay. A double resolves 1e15 only to 0.125, so a scene far from the origin
        loses its small motions; shifted to near 0 it keeps them (a floating origin: follow
        the player's ship). The forces depend on differences only, so the motion is the one
        the scene would have had if built at the new origin."""
        delta = np.array(check.floats("delta", delta, (self._dim,)))   # may be a view of pos
        b = self._b
        d = self._dim
        b.pos[:b.n, :d] -= delta
        b.prev[:b.n, :d] -= delta
        d3 = np.zeros(3)
        d3[:d] = delta
        self._forces.shift(d3)
        self._collisions.shift(delta, d)
        self._actors.shift(delta)
        self._origin[:d] += delta
        self._set_up()
        measures.rewatch(self)       # a uniform field's potential has no natural zero

    # ---------------------------------------------------------------- spatial queries
    def _query_kinds(self, kinds):
        """A query's kinds= (a name or code, or a list of them) as codes, checked as every
        kind argument is (None: every kind)."""
        if kinds is None:
            return None
        one = isinstance(kinds, (str, int, np.integer))
        k = 1 if one else len(kinds)
        if k == 0:
            raise ValueError("kinds = []: give at least one kind, or None for every kind")
        return editing.kind_codes(self, kinds, k, "kinds")

    # every query takes kinds= (names), mask= (bodies with a category bit in it), filter=
    # (sp.Filter(category, mask): the collision rule, as if the query were a body with these
    # bits) and ignore= (an id or ids left out)
    def query_radius(self, centers, r, kinds=None, mask=None, ignore=None, filter=None):
        """The bodies within distance r of each center (the gap to their surface: a body of
        radius R counts from |d| <= r + R): an sp.Hits (hits[q] -> (ids, distances), sorted
        by distance then id). centers (dim,) or (Q, dim); r >= 0, a number or (Q,). Periodic
        boundaries wrap."""
        return _queries().query_radius(self, centers, r, self._query_kinds(kinds), mask,
                                       ignore, filter)

    def query_box(self, lo, hi, kinds=None, mask=None, ignore=None, filter=None):
        """The bodies overlapping each axis-aligned box lo..hi ((dim,) or (Q, dim) each): an
        sp.Hits sorted by the distance of their centres from the box's centre."""
        return _queries().query_box(self, lo, hi, self._query_kinds(kinds), mask, ignore, filter)

    def raycast(self, origins, directions, max_distance, kinds=None, mask=None, first=True,
                walls=True, ignore=None, filter=None):
        """Rays from origins along directions ((dim,) or (Q, dim); non-zero) up to
        max_distance (finite, >= 0): the bodies and walls (walls=True) they meet, an
        sp.RayHits: per hit ids, walls, distances, points, normals (hits[q] for ray q), the
        nearest per ray (first=True) or every one, nearest first; per ray hit, body, wall,
        distance of its nearest. A ray from inside a body meets it at 0: ignore= the
        shooter. Periodic boundaries: rays run on through the seam. A compound body is met
        at its circles (per hit `circles`, per ray `circle`: which one; -1 round or a
        wall), as every query meets them."""
        return _queries().raycast(self, origins, directions, max_distance,
                                  self._query_kinds(kinds), mask, first, walls, ignore, filter)

    def shapecast(self, shape, displacement, kinds=None, mask=None, walls=True, ignore=None,
                  filter=None):
        """The first body or wall a circle (2D) or sphere (3D) would meet moving by
        displacement ((dim,) or (Q, dim), not zero): shape a body id or ids (their pos and
        radius; the body itself ignored) or (pos, radius). An sp.RayHits of at most one hit
        per shape: distances along the move (over |displacement|: the time of impact),
        points the shape's centre at first contact, normals toward it. A compound body
        (met, or cast as `shape`) is its circles, as they are now."""
        return _queries().shapecast(self, shape, displacement, self._query_kinds(kinds), mask,
                                    walls, ignore, filter)

    def nearest(self, points, k=1, kinds=None, mask=None, ignore=None, filter=None):
        """The k bodies nearest each point (by the gap to their surface): (ids (Q, k),
        distances (Q, k)), sorted; -1 and inf past the bodies there are."""
        return _queries().nearest(self, points, k, self._query_kinds(kinds), mask, ignore, filter)

    # ---------------------------------------------------------------- diagnostics
    def gravity_accelerations(self, ids=None, exact=False):
        """(k, dim) the acceleration by gravity now [length / time^2] of the bodies `ids`
        (default: every body, in row order); drag, held and user forces and thrust left out,
        a fixed body's given though it does not move. With gravity="tree", the tree's;
        exact=True: the direct sum it approximates."""
        return measures.gravity_accelerations(self, ids, exact)

    def kinetic_energy(self, pulling_only=False):
        """sum m v^2 / 2 [mass length^2 / time^2] (pulling_only: of the pulling bodies)."""
        return measures.kinetic_energy(self, pulling_only)

    def potential_energy(self, pulling_only=False, exact=False):
        """Potential energy in the gravity model (passive bodies in the pulling ones' field).
        With gravity="tree", the tree's (what its forces conserve), or with exact=True the
        direct sum over pairs (O(n^2): for checks)."""
        return measures.potential_energy(self, pulling_only, exact)

    def energy(self, pulling_only=False, exact=False):
        """Kinetic + potential energy [mass length^2 / time^2] (exact: see
        potential_energy)."""
        return measures.energy(self, pulling_only, exact)

    def momentum(self, pulling_only=False):
        """(dim,) total linear momentum sum m v [mass length / time]."""
        return measures.momentum(self, pulling_only)

    def angular_momentum(self, pulling_only=False):
        """sum m r x v about the origin: (3,) in 3D, the scalar z component in 2D."""
        return measures.angular_momentum(self, pulling_only)

    def total_mass(self):
        """The sum of the masses [mass]."""
        return measures.total_mass(self)

    def center_of_mass(self):
        """(dim,) mass-weighted mean position [length]; ValueError if the total mass is 0."""
        return measures.center_of_mass(self)

    def center_of_mass_velocity(self):
        """(dim,) velocity of the centre of mass [length / time]."""
        return measures.center_of_mass_velocity(self)

    def elements(self, body_id, about=None):
        """The osculating orbital elements (sp.Elements: a, e, i, Omega, omega, f, M,
        period, pericentre, apocentre, the times to them) of a body about the body `about`
        (an id), by default the one pulling on it hardest, or the field's centre with
        gravity="central"; mu = G (m_about + m), m = 0 for a passive body (it does not pull
        back). 2D: i is 0, or pi for a clockwise orbit."""
        return orbits.orbit_of(self, body_id, about)

    def set_orbit(self, body_id, about=None, **elements):
        """Put a body on an orbit about `about` (as in elements()): a= (or q=, the
        pericentre distance), e=, i=, Omega=, omega=, f= or M= (sp.state_from_elements);
        a set_body of its position and velocity, so recorded and replayed as that."""
        orbits.put_on_orbit(self, body_id, about, elements)

    def predict(self, ids, duration, *, points=256, integrator=None, dt=None, tolerance=None,
                target=None, about=None, coast=False, error=None):
        """The predicted paths of the bodies `ids` (an id or a list) over `duration` [time]:
        a copy of this World is stepped (this one is unchanged), every body pulling, held
        controls, plans and collisions as here, with `integrator` (default this World's) and
        dt (default this World's; fixed-step) or tolerance (gauss_radau, points evenly
        spaced). With this World's integrator and dt the path is the one it will fly, bit
        for bit, when nothing else acts. Returns an sp.Prediction: t (P,), pos and vel (k, P,
        dim), sampled at `points` times from now, the first now (fixed-step: at whole steps,
        the last at or just past duration, at most one sample a step), and the markers:
        apsides about the dominant body (or `about`), the closest approach to `target`,
        changes of the dominant body (the one pulling hardest), impacts (a path ends where
        its body is destroyed, merged away, detonates or expires, at its first wall, or at
        its first bounce off a body at least as heavy). coast=True: the paths if every ship's
        controls were released now (throttle, turn and strafe 0, plans dropped; missiles fly
        on), as a HUD shows them during a burn. Many passive bodies predicted
        together whose only coupling is the pulling bodies' motion, already recorded by the
        last prediction (spacephys/tape.py), run in two halves on two threads, bit for bit
        the same paths (predict._Halves).

        error: instead of integrator, dt and tolerance, the largest error wanted, relative to
        each body's distance from the body pulling it hardest (1e-6: a millionth of its orbit's
        radius). The prediction chooses the fixed-step method and dt that meet it with the
        fewest force evaluations, trying them on this scene at its first call (a few
        predictions), and reuses the choice while the scene's character holds
        (spacephys/prediction_settings.py). Without error, integrator or dt, the path is the
        one this World will fly."""
        from .predict import predict
        return predict(self, ids, duration, points, integrator, dt, tolerance, target, about,
                       coast=coast, error=error)

    def predict_async(self, ids, duration, **options):
        """predict() on a worker thread: the World's state is taken now (it is what is
        predicted), the arguments checked now, and a copy stepped beside the caller's own
        steps (the kernels release the GIL, and the copy's force loops stay on one thread).
        Start the next when the last is done(). Returns a handle:
        done(), running(), result(timeout=None) -> sp.Prediction, cancel(). With error=, the
        trials that choose the settings (the first call's) run in the caller's thread."""
        from .predict import predict
        return predict(self, ids, duration, background=True, **options)

    def move_to_center_of_mass(self):
        """Shift every body so that the centre of mass rests at the origin."""
        r, v = self.center_of_mass(), self.center_of_mass_velocity()
        b = self._b
        b.pos[:b.n, :self._dim] -= r
        b.prev[:b.n, :self._dim] -= r
        b.vel[:b.n, :self._dim] -= v
        measures.rewatch(self)

    def __repr__(self):
        return (f"World(dim={self._dim}, n={self.n}, gravity={self.gravity!r}, "
                f"integrator={self.integrator!r}, dt={self._dt!r}, t={self.t!r})")


class Warp(NamedTuple):
    """World.warp: the last advance()'s time warp."""
    asked: float
    granted: float
    reason: Optional[str]     # why granted < asked (a body integrated, a ship turning)


# the calls a run log records (journal.py): every public method that changes the World
JOURNALED = ("step", "advance", "watch_energy", "shift_origin", "move_to_center_of_mass",
             "add_kind", "add_body", "add_bodies", "set_body", "remove", "set_collision",
             "add_plane", "add_segment", "clear_walls", "set_boundary", "add_ship", "control",
             "set_heading", "set_fuel", "plan", "launch", "explode", "apply_force",
             "apply_acceleration", "add_force", "set_force_params", "remove_force",
             "tether", "untether", "set_rails", "coast")
