"""World: the game-facing object holding bodies, the gravity model and the integrator."""
import copy
import warnings
from collections import namedtuple

import numpy as np
from numba import typed

from . import _validate as check
from .actors import Actors
from .integrators import get_integrator
from .kernels import diagnostics
from .events import EVENT_DTYPE
from .kernels import collide
from .kernels.arrays import Work
from .kernels import gauss_radau as gr
from .kernels.gravity import CENTRAL, DIRECT, NONE, UNIFORM
from ._dispatch import fast_call
from .kernels import integrate
from .kernels.wisdom_holman import wisdom_holman_steps as _wisdom_holman_steps
from .runlog import journaled
from .state import Bodies
from .units import get_units

# the step kernels, called past numba's per-call typing (see _dispatch.py)
splitting_steps = fast_call(integrate.splitting_steps)
rk_steps = fast_call(integrate.rk_steps)
gauss_radau_steps = fast_call(gr.gauss_radau_steps)
wisdom_holman_steps = fast_call(_wisdom_holman_steps)
# no frames to capture (the step kernels' last four arguments, see integrate.splitting_steps)
_NO_FRAMES = (np.zeros(0, np.int64), np.zeros((0, 0, 3)), np.zeros((0, 0, 3)), np.zeros((0, 0)))

GRAVITY_MODELS = {"none": NONE, "direct": DIRECT, "uniform": UNIFORM, "central": CENTRAL}
STEP_CONTROLS = ("auto", "pulling", "all")
RESPONSES = {"ignore": collide.IGNORE, "sensor": collide.SENSOR, "elastic": collide.ELASTIC,
             "bounce": collide.BOUNCE, "merge": collide.MERGE, "destroy_a": collide.DESTROY_A,
             "destroy_b": collide.DESTROY_B, "destroy_both": collide.DESTROY_BOTH,
             "break_a": collide.BREAK_A, "break_b": collide.BREAK_B}
BOUNDARIES = {"open": collide.OPEN, "reflect": collide.REFLECT, "periodic": collide.PERIODIC}
_MIRRORED = {collide.DESTROY_A: collide.DESTROY_B, collide.DESTROY_B: collide.DESTROY_A,
             collide.BREAK_A: collide.BREAK_B, collide.BREAK_B: collide.BREAK_A}
# kinds whose bodies feel gravity but do not pull unless told to (active=True): their mass is
# for thrust and collisions, and their pull on planets would only cost time
PASSIVE_KINDS = ("ship", "missile", "debris")
DEFAULT_KINDS = ("body", "star", "planet", "moon", "asteroid", "ship", "missile", "debris")


class InstabilityError(FloatingPointError):
    """The integration broke down: a body's state became NaN or infinite, or the energy
    error passed the limit set with World.watch_energy. ids: the bodies concerned, worst
    first; t: the World's time when it was found."""

    def __init__(self, message, ids, t):
        super().__init__(message)
        self.ids = ids
        self.t = t


Body = namedtuple("Body", "id pos vel mass radius kind active pulls")
Body.__doc__ = ("A copy of one body's state: id, pos/vel (dim,), mass, radius, kind name, "
                "active (may pull) and pulls (active and massive).")


def _bools(name, value, k):
    """None-free bool or (k,) bools as a (k,) array (no 0/1 ints: a typo guard)."""
    arr = np.asarray(value)
    if arr.dtype != np.bool_ or arr.shape not in ((), (k,)):
        raise ValueError(f"{name} = {value!r}: must be a bool or {k} bools")
    return np.broadcast_to(arr, (k,))


def _bits(name, value, k):
    """An int or (k,) ints fitting int64, as a (k,) int64 array."""
    arr = np.asarray(value)
    if arr.dtype.kind not in "iu" or arr.shape not in ((), (k,)):
        raise ValueError(f"{name} = {value!r}: must be an integer or {k} integers (bits)")
    if arr.dtype.kind == "u" and arr.size and arr.max() > np.iinfo(np.int64).max:
        raise ValueError(f"{name} = {value!r}: bits beyond 63 do not fit")
    return np.broadcast_to(arr.astype(np.int64), (k,))


def _readonly(arr):
    view = arr.view()
    view.flags.writeable = False
    return view


class World(Actors):
    """Bodies under gravity, advanced by a fixed-step integrator whose loop runs in numba.

    Parameters
    ----------
    dim : 2 or 3
    units : "game" (G = 1), "si" (G = 6.6743e-11), "au-msun-yr" (G = 39.4769...)
    G : float >= 0, overrides the units' G [length^3 / (mass time^2)]
    integrator : a name of spacephys.INTEGRATORS
    dt : float > 0, the step [time]; for an adaptive integrator the output interval: step(n)
         lands exactly on n * dt, taking as many substeps as the accuracy needs
    tolerance : float >= 0, the adaptive integrator's error parameter (1e-9 gives machine
                precision for Gauss-Radau; 0 turns adaptivity off: steps of min(dt, max_step))
    max_step : float > 0 or None, longest adaptive substep (so that thrust changes, collisions
               and frame boundaries are not stepped over) [time]
    min_step : float >= 0, shortest adaptive substep; reaching it warns, since accuracy is no
               longer controlled [time]
    step_control : "auto" | "pulling" | "all", which bodies set the adaptive step. "pulling":
               only the bodies that pull, so test particles and passive ships never change
               their trajectories (the passive bodies are still iterated to convergence within
               those steps). "all": every body. "auto" (default): "pulling" when two or more
               bodies pull under direct gravity, else "all" (a lone star has no dynamics of its
               own to set a step)
    softening : float >= 0, Plummer softening length [length]
    gravity : "direct" (mutual, bodies of mass 0 or passive feel but do not pull),
              "uniform" (a constant field g), "central" (a fixed body central_mass at
              central_pos; bodies ignore each other), "none"
    g : (dim,) uniform field [length / time^2], with gravity="uniform"
    central_mass, central_pos : the fixed body, with gravity="central" (pos defaults to 0)
    max_substeps : int >= 1, most steps one advance() call may take (against the spiral of death)
    capacity : int, initial room for bodies (grows by doubling)
    seed : int >= 0, seeds every random choice (explosions): same seed, same run
    drag : float >= 0, linear drag rate k [1/time]: every body also accelerates by
           -k (v - wind) (an atmosphere, the seed's wind resistance); fixed-step integrators
    wind : (dim,) the air's velocity [length/time] (default 0)
    """

    def __init__(self, dim=2, *, units="game", G=None, integrator="leapfrog", dt=1 / 240,
                 softening=0.0, gravity="direct", g=None, central_mass=None, central_pos=None,
                 tolerance=1e-9, max_step=None, min_step=0.0, step_control="auto",
                 max_substeps=16, capacity=64, seed=0, drag=0.0, wind=None):
        if isinstance(dim, bool) or not isinstance(dim, (int, np.integer)) or dim not in (2, 3):
            raise ValueError(f"dim = {dim!r}: must be the integer 2 or 3")
        unit_system = get_units(units)
        G = unit_system.G if G is None else check.scalar("G", G, minimum=0.0)
        spec = get_integrator(integrator)
        dt = check.scalar("dt", dt, positive=True)
        softening = check.scalar("softening", softening, minimum=0.0)
        if not isinstance(gravity, str) or gravity not in GRAVITY_MODELS:
            raise ValueError(f"gravity={gravity!r} is not known; valid: {', '.join(GRAVITY_MODELS)}")
        field = np.zeros(3)
        field_mass = 0.0
        if gravity == "uniform":
            if g is None:
                raise ValueError("gravity='uniform' needs g, the field vector, e.g. g=(0, -9.81)")
            field[:dim] = check.floats("g", g, (dim,))
        elif g is not None:
            raise ValueError(f"g = {g!r} is only used with gravity='uniform' (gravity={gravity!r})")
        if gravity == "central":
            if central_mass is None:
                raise ValueError("gravity='central' needs central_mass, the fixed body's mass")
            field_mass = check.scalar("central_mass", central_mass, minimum=0.0)
            if central_pos is not None:
                field[:dim] = check.floats("central_pos", central_pos, (dim,))
        elif central_mass is not None or central_pos is not None:
            raise ValueError(f"central_mass/central_pos are only used with gravity='central' "
                             f"(gravity={gravity!r})")
        max_substeps = check.count("max_substeps", max_substeps, minimum=1)
        capacity = check.count("capacity", capacity, minimum=1)
        seed = check.count("seed", seed)
        drag_table = np.zeros(4)
        drag_table[0] = check.scalar("drag", drag, minimum=0.0)
        if wind is not None:
            drag_table[1:1 + dim] = check.floats("wind", wind, (dim,))
        tolerance, max_step, min_step = self._adaptive_settings(tolerance, max_step, min_step)
        step_control = self._checked_step_control(step_control)

        self._dim = int(dim)
        self._drag = drag_table           # [k, wind (3,)]: the step kernels' drag argument
        self._max_substeps = max_substeps
        self._step_control = step_control
        self._units = unit_system
        self._G = G
        self._spec = spec
        self._softening = softening
        self._gravity = gravity
        self._model = GRAVITY_MODELS[gravity]
        self._field = field
        self._field_mass = field_mass
        self._b = Bodies(capacity)
        self._kinds = list(DEFAULT_KINDS)
        # collisions: the kind x kind matrix (all ignore until set), walls, the boundary
        self._response = np.zeros((len(DEFAULT_KINDS),) * 2, dtype=np.int64)
        self._restitution = np.ones((len(DEFAULT_KINDS),) * 2)
        self._walls = np.zeros((0, 8))
        self._boundary = collide.OPEN
        self._box = np.zeros((2, 3))
        self._box_restitution = 1.0
        self._cell = None
        # the event buffer, in a typed list so that the kernels can grow it mid-step
        self._event_box = typed.List([np.zeros(256, dtype=EVENT_DTYPE)])
        self._event_count = np.zeros(1, dtype=np.int64)
        self._sources = None            # (src, passive, still) index arrays, rebuilt when stale
        self._jacobi = None             # Wisdom-Holman's order and masses, with its key
        self._dt = dt
        self._t_base = 0.0              # t = t_base + steps * dt: no rounding build-up in t
        self._steps = 0
        self._accumulator = 0.0
        self.dropped_time = 0.0         # frame time advance() dropped to stay real-time
        # adaptive integrators: [tolerance, max_step, min_step, next step, step the per-body
        # polynomials are scaled to, have a prediction] and counters (see kernels/gauss_radau.py)
        self._adaptive = np.array([tolerance, max_step, min_step, min(dt, max_step),
                                   min(dt, max_step), 0.0])
        self._adaptive_stats = np.zeros(7, dtype=np.int64)
        self._pending_warning = None
        # ships and missiles (actors.py): explosion specs by index, thrust curve rows, launch
        # events waiting for the next step's events
        self._seed = seed
        self._explosion_specs = []
        self._curves = np.zeros((0, 2))
        self._queued_events = []
        self._work = None                  # kernels' scratch (see _workspace)
        self._log = None                   # the RunLog recording this World, if one is
        self._origin = np.zeros(3)         # where the coordinates are measured from
        self._watch = None                 # watch_energy's (limit, E0, body energies, ids)

    # ---------------------------------------------------------------- settings
    @property
    def dim(self):
        return self._dim

    @property
    def units(self):
        """The UnitSystem (name, G, unit names)."""
        return self._units

    @property
    def G(self):
        return self._G

    @property
    def gravity(self):
        return self._gravity

    @property
    def t(self):
        """Simulation time [time]."""
        return self._t_base + self._steps * self._dt

    @property
    def dt(self):
        return self._dt

    @dt.setter
    def dt(self, value):
        value = check.scalar("dt", value, positive=True)
        self._t_base, self._steps = self.t, 0
        self._dt = value

    @property
    def integrator(self):
        """The integrator's name; assign a name of spacephys.INTEGRATORS to switch."""
        return self._spec.name

    @integrator.setter
    def integrator(self, name):
        self._spec = get_integrator(name)
        self._reset_adaptive()           # switching voids the old method's carried state

    @property
    def integrator_spec(self):
        return self._spec

    @property
    def max_substeps(self):
        """Most steps one advance() call may take; the rest of a long frame is dropped."""
        return self._max_substeps

    @max_substeps.setter
    def max_substeps(self, value):
        self._max_substeps = check.count("max_substeps", value, minimum=1)

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
    def step_control(self, value):
        self._step_control = self._checked_step_control(value)

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
        return float(self._adaptive[0])

    @tolerance.setter
    def tolerance(self, value):
        self._adaptive[0] = self._adaptive_settings(value, None, 0.0)[0]

    @property
    def max_step(self):
        return None if np.isinf(self._adaptive[1]) else float(self._adaptive[1])

    @max_step.setter
    def max_step(self, value):
        _, self._adaptive[1], _ = self._adaptive_settings(0.0, value, self._adaptive[2])

    @property
    def min_step(self):
        return float(self._adaptive[2])

    @min_step.setter
    def min_step(self, value):
        max_step = None if np.isinf(self._adaptive[1]) else self._adaptive[1]
        _, _, self._adaptive[2] = self._adaptive_settings(0.0, max_step, value)

    @property
    def integrator_stats(self):
        """Counters of the adaptive integrator: steps taken, steps redone, steps held at
        min_step, steps whose corrector did not converge, corrector sweeps (each 7 force
        evaluations), and substeps of test particles that needed shorter steps than the
        bodies setting the step."""
        s = self._adaptive_stats
        return {"steps": int(s[gr.STEPS]), "rejected": int(s[gr.REJECTED]),
                "at_min_step": int(s[gr.AT_MIN_STEP]), "not_converged": int(s[gr.NOT_CONVERGED]),
                "sweeps": int(s[gr.SWEEPS]), "rider_substeps": int(s[gr.RIDER_SUBSTEPS])}

    @property
    def drag(self):
        """Linear drag rate k [1/time]: each body accelerates by -k (v - wind)."""
        return float(self._drag[0])

    @drag.setter
    def drag(self, value):
        self._drag[0] = check.scalar("drag", value, minimum=0.0)

    @property
    def wind(self):
        """(dim,) the velocity drag pulls bodies toward [length/time]."""
        return self._drag[1:1 + self._dim].copy()

    @wind.setter
    def wind(self, value):
        self._drag[1:1 + self._dim] = check.floats("wind", value, (self._dim,))

    @property
    def softening(self):
        return self._softening

    @softening.setter
    def softening(self, value):
        self._softening = check.scalar("softening", value, minimum=0.0)

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
            k = len(self._kinds)
            response, restitution = np.zeros((k, k), np.int64), np.ones((k, k))
            response[:-1, :-1] = self._response
            restitution[:-1, :-1] = self._restitution
            self._response, self._restitution = response, restitution
        return self._kinds.index(name)

    def kind_code(self, name):
        """The code of a declared kind name."""
        return int(self._kind_codes(name, 1, "kind")[0])

    def _kind_codes(self, kind, k, field):
        if isinstance(kind, np.ndarray) and kind.ndim == 0:
            kind = kind.item()
        names = [kind] * k if isinstance(kind, (str, int, np.integer)) else list(kind)
        if len(names) != k:
            raise ValueError(f"{field} has {len(names)} entries, expected {k}")
        codes = np.empty(k, dtype=np.int16)
        for i, name in enumerate(names):
            label = field if isinstance(kind, (str, int, np.integer)) else f"{field}[{i}]"
            if isinstance(name, str):
                if name not in self._kinds:
                    raise ValueError(f"{label} = {name!r} is not a declared kind; declared: "
                                     f"{', '.join(self._kinds)} (declare with add_kind)")
                codes[i] = self._kinds.index(name)
            elif isinstance(name, (int, np.integer)) and not isinstance(name, bool) \
                    and 0 <= name < len(self._kinds):
                codes[i] = name
            else:
                raise ValueError(f"{label} = {name!r} is not a kind name or code")
        return codes

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
        return _readonly(self._b.mass[:self._b.n])

    @property
    def radius(self):
        return _readonly(self._b.radius[:self._b.n])

    @property
    def kind(self):
        """(n,) int16 kind codes; names in w.kinds."""
        return _readonly(self._b.kind[:self._b.n])

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
                 fixed=False, category=1, mask=-1, lifetime=None):
        """Add one body; returns its id.

        mass [mass] >= 0 (0: a test particle); pos, vel : (dim,); radius [length] >= 0;
        kind : a declared kind name or code; active : may pull others (it does when it has
        mass); default True, except for the kinds ship, missile and debris; fixed : immovable
        (it stays put, and collisions treat its mass as infinite); category, mask : collision
        filter bits: two bodies interact only if each one's category meets the other's mask
        (default: category 1, mask all bits); lifetime [time] > 0: removed that long from
        now, with an expiry event (None: never).
        """
        pos = check.floats("pos", pos, (self._dim,))
        vel = np.zeros(self._dim) if vel is None else check.floats("vel", vel, (self._dim,))
        mass = check.scalar("mass", mass, minimum=0.0)
        radius = check.scalar("radius", radius, minimum=0.0)
        if active is not None and not isinstance(active, (bool, np.bool_)):
            raise ValueError(f"active = {active!r}: must be True, False or None")
        return int(self.add_bodies(mass, pos[None], vel[None], radius=radius, kind=kind,
                                   active=active, fixed=fixed, category=category,
                                   mask=mask, lifetime=lifetime)[0])

    def add_bodies(self, mass, pos, vel=None, *, radius=0.0, kind="body", active=None,
                   fixed=False, category=1, mask=-1, lifetime=None):
        """Add k bodies at once; returns their (k,) int64 ids.

        mass : number or (k,); pos, vel : (k, dim); radius : number or (k,);
        kind : one name/code or k of them; active, fixed : None/bool or (k,) bools (see
        add_body); category, mask : int or (k,) ints; lifetime : None, a number or (k,)
        numbers > 0. Everything is checked before anything is added.
        """
        pos = check.floats("pos", pos, (None, self._dim))
        k = pos.shape[0]
        vel = np.zeros((k, self._dim)) if vel is None else check.floats("vel", vel, (k, self._dim))
        mass = check.per_body("mass", mass, k, minimum=0.0)
        radius = check.per_body("radius", radius, k, minimum=0.0)
        codes = self._kind_codes(kind, k, "kind")
        if active is None:
            passive_codes = [self._kinds.index(k) for k in PASSIVE_KINDS if k in self._kinds]
            act = ~np.isin(codes, passive_codes)
        else:
            act = _bools("active", active, k)
        still = _bools("fixed", fixed, k)
        category = _bits("category", category, k)
        mask = _bits("mask", mask, k)
        if lifetime is not None:
            lifetime = check.per_body("lifetime", lifetime, k, minimum=0.0)
            if np.any(lifetime == 0):
                raise ValueError(f"lifetime[{int(np.argmin(lifetime))}] = 0: must be > 0")
        p3 = np.zeros((k, 3))
        v3 = np.zeros((k, 3))
        p3[:, :self._dim] = pos
        v3[:, :self._dim] = np.where(still[:, None], 0.0, vel)    # a fixed body never moves
        ids = self._b.add({"pos": p3, "vel": v3, "mass": mass, "radius": radius,
                           "kind": codes, "active": act, "fixed": still, "category": category,
                           "mask": mask})
        self._set_lifetimes(ids, lifetime)
        self._invalidate()
        return ids

    def index_of(self, ids, field="id"):
        """Rows of live bodies in the views: int for an id, (k,) int64 for an array of ids."""
        scalar = np.ndim(ids) == 0
        arr = np.atleast_1d(np.asarray(ids))
        if arr.size and arr.dtype.kind not in "iu":
            raise ValueError(f"{field} = {ids!r}: ids are integers")
        rows = self._b.lookup(arr.astype(np.int64))
        bad = np.flatnonzero(rows < 0)
        if bad.size:
            raise ValueError(f"{field} = {int(arr[bad[0]])} names no live body "
                             f"(removed, or never created)")
        return int(rows[0]) if scalar else rows

    def __contains__(self, body_id):
        if isinstance(body_id, bool) or not isinstance(body_id, (int, np.integer)):
            return False
        if not 0 <= body_id <= np.iinfo(np.int64).max:
            return False
        return int(self._b.lookup([body_id])[0]) >= 0

    def get(self, body_id):
        """A copy of one body's state as a Body namedtuple."""
        i = self.index_of(body_id)
        b = self._b
        return Body(int(b.ids[i]), b.pos[i, :self._dim].copy(), b.vel[i, :self._dim].copy(),
                    float(b.mass[i]), float(b.radius[i]), self._kinds[b.kind[i]],
                    bool(b.active[i]), bool(b.active[i] and b.mass[i] > 0))

    def set_body(self, body_id, *, pos=None, vel=None, mass=None, radius=None, kind=None,
                 active=None, fixed=None, category=None, mask=None):
        """Change one body between steps; everything is checked before anything changes.

        A new pos also resets the body's render interpolation (a teleport, not a smear).
        """
        i = self.index_of(body_id)
        if mass is not None and "actor" in self._b.columns and self._b.actor[i]:
            raise ValueError(f"mass of {body_id}: a ship's or missile's mass is dry + fuel; "
                             f"use set_fuel")
        new = {}
        if pos is not None:
            new["pos"] = check.floats("pos", pos, (self._dim,))
        if vel is not None:
            new["vel"] = check.floats("vel", vel, (self._dim,))
        if mass is not None:
            new["mass"] = check.scalar("mass", mass, minimum=0.0)
        if radius is not None:
            new["radius"] = check.scalar("radius", radius, minimum=0.0)
        if kind is not None:
            new["kind"] = self._kind_codes(kind, 1, "kind")[0]
        for name, value in (("active", active), ("fixed", fixed)):
            if value is not None:
                if not isinstance(value, (bool, np.bool_)):
                    raise ValueError(f"{name} = {value!r}: must be True or False")
                new[name] = value
        for name, value in (("category", category), ("mask", mask)):
            if value is not None:
                new[name] = _bits(name, value, 1)[0]
        b = self._b
        if new.get("fixed", b.fixed[i]):
            new["vel"] = np.zeros(self._dim)          # a fixed body never moves
        for name, value in new.items():
            col = getattr(b, name)
            if name in ("pos", "vel"):
                col[i, :self._dim] = value
            else:
                col[i] = value
        if "pos" in new:
            b.prev[i] = b.pos[i]
        # a jump in the state voids its rounding compensation
        for name, key in (("csx", "pos"), ("csv", "vel")):
            if key in new and name in b.columns:
                getattr(b, name)[i] = 0.0
        if "mass" in new or "active" in new or "fixed" in new:
            self._invalidate()
        else:
            self._rewatch()

    def remove(self, ids):
        """Remove one id or an array of ids (all must be live; duplicates count once)."""
        rows = np.unique(np.atleast_1d(self.index_of(ids)))
        self._b.remove(rows)
        self._invalidate()

    # copies and pickles carry the event buffer as a plain array (typed lists do not copy)
    def __getstate__(self):
        state = self.__dict__.copy()
        state["_event_box"] = self._event_box[0]
        state["_work"] = None                          # scratch: not part of the state
        state["_log"] = None                           # a copy is not recorded
        return state

    def __setattr__(self, name, value):
        # a recording journals settings changed by assignment (w.dt = ..., w.integrator = ...)
        log = self.__dict__.get("_log")
        if log is None or name.startswith("_") or log.depth:
            object.__setattr__(self, name, value)
        else:
            log.call(self, "setattr", object.__setattr__, (name, value), {})

    # ---------------------------------------------------------------- run logs and files
    def record(self, path, *, every=1, every_time=None, checkpoint_every=None,
               checkpoint_seconds=10.0, flush_seconds=1.0, compression="gzip", compress_state=False, scenario=None):
        """Record this World into an HDF5 run log (see spacephys/runlog.py, docs/runlog.md);
        returns the RunLog (close it, or use it in a with-block).

        every : a frame every this many steps, or every_time : a frame whenever the time
        passes a multiple of it [time] (then every=None); frames hold ids, pos, vel, mass,
        radius and kind of the live bodies. Every step's events and every call that changes
        the World are recorded too; a checkpoint (the whole state, for resume) every
        checkpoint_seconds of wall time, or every checkpoint_every frames if that comes
        first, at the end of the call in which it fell due; the file is written every
        flush_seconds of wall time (and when 8 MB of state are waiting). compression: "gzip",
        "lzf" or None, for every table but positions and velocities, which are compressed
        too with compress_state=True (they shrink by about a fifth, at 20-50x the cost of
        writing them: see the README's figures). scenario: a text kept with the log. The file
        is created at once, so an unwritable path fails here, before anything runs.
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
        log = RunLog(self, path, every=every, every_time=every_time,
                     checkpoint_every=checkpoint_every,
                     checkpoint_seconds=checkpoint_seconds, flush_seconds=flush_seconds,
                     compression=compression, compress_state=bool(compress_state),
                     scenario=scenario)
        self._log = log
        return log

    @property
    def recording(self):
        """The RunLog recording this World, or None."""
        return self._log

    def save(self, path):
        """Write the whole state to an HDF5 file; World.load(path) continues it bit for
        bit."""
        from .runlog import save_world
        save_world(self, path)

    @staticmethod
    def load(path, checkpoint=-1):
        """A World from World.save's file or from a run log's checkpoint (default: the
        last)."""
        from .runlog import load_world
        return load_world(path, checkpoint)

    def __setstate__(self, state):
        self.__dict__.update(state)
        self._event_box = typed.List([state["_event_box"]])

    def copy(self):
        """An independent deep copy (same ids, state, time and settings)."""
        # the integrator spec is immutable and shared: a copied (writeable) table would make
        # numba compile the kernels a second time for a different array type
        return copy.deepcopy(self, memo={id(self._spec): self._spec})

    # ---------------------------------------------------------------- collisions
    def _kind_list(self, kind, field):
        if kind == "*":
            return list(range(len(self._kinds)))
        return [int(self._kind_codes(kind, 1, field)[0])]

    def set_collision(self, kind_a, kind_b, response, restitution=None):
        """What happens when a body of kind_a meets one of kind_b (either order).

        response : "ignore" (the default for every pair), "sensor" (an event only),
        "elastic", "bounce" (with restitution in [0, 1]: 1 elastic, 0 no rebound), "merge"
        (one body with the pair's mass, momentum and centre of mass; radius from the summed
        volume in 3D, area in 2D), "destroy_a", "destroy_b", "destroy_both" (a: the body of
        kind_a), "break_a", "break_b" (a bounce, restitution default 1, after which that body
        is destroyed: the seed's brick). A kind may be "*" for every kind.
        """
        codes_a = self._kind_list(kind_a, "kind_a")
        codes_b = self._kind_list(kind_b, "kind_b")
        if not isinstance(response, str) or response not in RESPONSES:
            raise ValueError(f"response={response!r} is not known; valid: {', '.join(RESPONSES)}")
        code = RESPONSES[response]
        if code in (collide.BREAK_A, collide.BREAK_B) and restitution is None:
            restitution = 1.0
        if code in (collide.BOUNCE, collide.BREAK_A, collide.BREAK_B):
            if restitution is None:
                raise ValueError("response='bounce' needs restitution, in [0, 1]")
            restitution = check.scalar("restitution", restitution, minimum=0.0)
            if restitution > 1.0:
                raise ValueError(f"restitution = {restitution}: must be <= 1")
        elif restitution is not None:
            raise ValueError(f"restitution = {restitution!r} is only used with response='bounce'")
        for a in codes_a:
            for b in codes_b:
                self._response[a, b] = code
                self._response[b, a] = _MIRRORED.get(code, code) if a != b else code
                if restitution is not None:
                    self._restitution[a, b] = self._restitution[b, a] = restitution

    def collision(self, kind_a, kind_b):
        """The response set for (kind_a, kind_b), and its restitution."""
        a = self.kind_code(kind_a)
        b = self.kind_code(kind_b)
        name = next(k for k, v in RESPONSES.items() if v == self._response[a, b])
        return name, float(self._restitution[a, b])

    def add_plane(self, point, normal, restitution=1.0):
        """An immovable wall: the plane (a line in 2D) through point, bodies on the side the
        normal points to. Returns its index in w.walls."""
        point = check.floats("point", point, (self._dim,))
        normal = check.floats("normal", normal, (self._dim,))
        length = float(np.linalg.norm(normal))
        if length == 0:
            raise ValueError("normal = 0: a plane needs a direction")
        return self._add_wall(collide.PLANE, point, normal / length, restitution)

    def add_segment(self, a, b, restitution=1.0):
        """An immovable wall segment from a to b (with round ends): the seed's circle-on-wall.
        Returns its index in w.walls."""
        a = check.floats("a", a, (self._dim,))
        b = check.floats("b", b, (self._dim,))
        if np.array_equal(a, b):
            raise ValueError(f"a = b = {a.tolist()}: a segment needs two distinct ends")
        return self._add_wall(collide.SEGMENT, a, b, restitution)

    def _add_wall(self, kind, p, q, restitution):
        restitution = check.scalar("restitution", restitution, minimum=0.0)
        if restitution > 1.0:
            raise ValueError(f"restitution = {restitution}: must be <= 1")
        row = np.zeros(8)
        row[0] = kind
        row[1:1 + self._dim] = p
        row[4:4 + self._dim] = q
        row[7] = restitution
        self._walls = np.vstack([self._walls, row])
        return len(self._walls) - 1

    @property
    def walls(self):
        """(W, 8) rows [type (0 plane, 1 segment), x0, y0, z0, x1, y1, z1, restitution]."""
        return _readonly(self._walls)

    def clear_walls(self):
        self._walls = np.zeros((0, 8))

    def set_boundary(self, mode, lo=None, hi=None, restitution=1.0):
        """The world's edge: "open" (none), "reflect" (walls of the box lo..hi) or "periodic"
        (Asteroids-style: leaving one side enters the opposite one; contacts across the seam
        count; gravity itself is not periodic)."""
        if not isinstance(mode, str) or mode not in BOUNDARIES:
            raise ValueError(f"boundary={mode!r} is not known; valid: {', '.join(BOUNDARIES)}")
        box = np.zeros((2, 3))
        if mode != "open":
            if lo is None or hi is None:
                raise ValueError(f"boundary={mode!r} needs lo and hi, the box's corners")
            box[0, :self._dim] = check.floats("lo", lo, (self._dim,))
            box[1, :self._dim] = check.floats("hi", hi, (self._dim,))
            bad = np.flatnonzero(box[1, :self._dim] <= box[0, :self._dim])
            if bad.size:
                raise ValueError(f"hi[{bad[0]}] = {box[1, bad[0]]} is not above "
                                 f"lo[{bad[0]}] = {box[0, bad[0]]}")
        restitution = check.scalar("restitution", restitution, minimum=0.0)
        if restitution > 1.0:
            raise ValueError(f"restitution = {restitution}: must be <= 1")
        self._boundary, self._box, self._box_restitution = BOUNDARIES[mode], box, restitution

    @property
    def boundary(self):
        """(mode, lo, hi, restitution)."""
        mode = next(k for k, v in BOUNDARIES.items() if v == self._boundary)
        return mode, self._box[0, :self._dim].copy(), self._box[1, :self._dim].copy(), \
            self._box_restitution

    @property
    def collision_cell(self):
        """The broad phase's grid cell [length]; None (default): the largest diameter."""
        return self._cell

    @collision_cell.setter
    def collision_cell(self, value):
        self._cell = None if value is None else check.scalar("collision_cell", value,
                                                             positive=True)

    @property
    def events(self):
        """Structured array (spacephys.EVENT_DTYPE) of what happened in the last step() or
        advance() (launches made before it included): kind, ids a and b, time, time within
        its step, contact point, normal, closing speed, kinetic energy lost, distance."""
        return self._event_box[0][:self._event_count[0]].copy()

    def _giants(self):
        """(rows of the giants, grid cell). With the default cell: the largest bodies above
        the widest gap (at least 2x in radius) among the 65 largest, at most 64 of them, are
        giants, tested against every body; the cell is the largest diameter of the rest.
        A cell set by the user puts every body in the grid."""
        r = self._b.radius[:self._b.n]
        if self._cell is not None:
            return np.zeros(0, np.int64), self._cell
        if r.size == 0:
            return np.zeros(0, np.int64), 1.0
        top = min(r.size, 65)
        rows = np.argpartition(-r, top - 1)[:top] if top < r.size else np.arange(r.size)
        rows = rows[np.argsort(-r[rows], kind="stable")]
        ordered = r[rows]
        giants = 0
        if ordered.size > 1:
            with np.errstate(divide="ignore", invalid="ignore"):
                # a body with a radius above points: an infinite gap; between points: none
                gaps = np.where(ordered[1:] > 0, ordered[:-1] / ordered[1:],
                                np.where(ordered[:-1] > 0, np.inf, 1.0))
            k = int(np.argmax(gaps))
            if gaps[k] >= 2.0 and k < 64:
                giants = k + 1
        biggest = ordered[giants] if giants < ordered.size else 0.0
        return np.sort(rows[:giants]).astype(np.int64), 2.0 * biggest if biggest > 0 else 1.0

    def _collisions_enabled(self):
        """Whether anything can collide: a response set, a wall, or a boundary."""
        return bool(self._response.any() or len(self._walls) or self._boundary != collide.OPEN)

    def _collision_setup(self):
        b = self._b
        n = b.n
        enabled = self._collisions_enabled()
        kind = b.kind[:n].astype(np.int64)
        if enabled:
            giants, cell = self._giants()
            # a kind needs the grid if it can meet a kind with bodies besides giants (itself:
            # two)
            gridded = np.ones(n, np.bool_)
            gridded[giants] = False
            K = len(self._kinds)
            counts = np.bincount(kind[gridded], minlength=K)
            meets = (self._response != collide.IGNORE) & \
                (counts[None, :] > np.eye(K, dtype=np.int64))
            gridded &= meets.any(axis=1)[kind]
        else:                     # no collisions: no grid to plan (a cheaper step() call)
            giants, cell, gridded = np.zeros(0, np.int64), 1.0, np.zeros(n, np.bool_)
        return collide.Setup(enabled, b.ids[:n], kind, b.radius[:n],
                             np.ones(n, dtype=np.bool_), self._event_box, self._event_count,
                             self.t, self._response, self._restitution, b.category[:n],
                             b.mask[:n], b.fixed[:n], self._walls, self._boundary, self._box,
                             self._box_restitution, cell, self._dim,
                             np.full(n, -1, np.int64), giants, gridded)

    # ---------------------------------------------------------------- stepping
    def _invalidate(self):
        """The set of bodies, a mass or an active flag changed: derived lists are stale."""
        self._sources = None
        self._jacobi = None
        self._rewatch()

    def _rewatch(self):
        """The World was changed between steps (bodies added, removed or set, the origin
        moved): the watched energy starts again from here."""
        if self.__dict__.get("_watch") is not None:
            self._watch = (self._watch[0],) + self._energy_reference()

    def _source_lists(self):
        """(src, passive, still): the bodies that pull, the others, the immovable ones."""
        if self._sources is None:
            b = self._b
            pulls = b.active[:b.n] & (b.mass[:b.n] > 0)
            self._sources = (np.flatnonzero(pulls).astype(np.int64),
                             np.flatnonzero(~pulls).astype(np.int64),
                             np.flatnonzero(b.fixed[:b.n]).astype(np.int64))
        return self._sources

    def _gravity_args(self):
        """The gravity arguments of the kernels, after pos (see kernels/gravity.py)."""
        b = self._b
        src, passive, still = self._source_lists()
        return (self._model, b.mass[:b.n], src, passive, self._G, self._softening ** 2,
                self._field, self._field_mass, still)

    def _run(self, nsteps, frame_at=None):
        """Take nsteps steps; a kernel call ends early after a collision removed or merged
        bodies (or filled the event buffer), and is resumed once World has caught up.
        frame_at : sorted step counts (from now) after which the recording takes a frame
        inside the kernel (fixed-step integrators only)."""
        consumed = 0
        while nsteps:
            setup = self._collision_setup()
            ctrl = self._control_setup(setup)
            first_event = int(self._event_count[0])
            frames = None if frame_at is None else self._frame_buffers(frame_at, consumed)
            done = None
            try:
                done = self._run_kernel(nsteps, setup, ctrl, frames)
            finally:
                # bodies destroyed or merged away leave, even if the integration then failed;
                # the destroyed ones with an explosion throw out their debris
                self._merged_actors(first_event)
                if frames is not None and done is not None:
                    self._log.captured(self, *frames, done)
                dead = np.flatnonzero(~setup.alive)
                if dead.size:
                    blasts = self._explode_dead(setup, first_event)
                    self._b.remove(dead)
                    self._invalidate()
                    self._spawn_debris(blasts)
            self._steps += done
            if frames is not None:
                self._log.captured_last(self, frames[0], done)
            nsteps -= done
            consumed += done
            if self._pending_warning:
                message, self._pending_warning = self._pending_warning, None
                warnings.warn(message, RuntimeWarning, stacklevel=4)

    def _frame_room(self):
        """Frames one kernel call may capture: buffers of at most 8 MB."""
        return max(1, min(256, (8 << 20) // (56 * self._b.capacity)))

    def _frame_buffers(self, frame_at, consumed):
        """(at, fpos, fvel, fmass) for a kernel call starting `consumed` steps into the run:
        the frame step counts relative to it, and the recording's buffers to capture into."""
        at = frame_at[frame_at > consumed] - consumed
        return (at,) + self._log.frame_buffers(at.size, self._b.n)

    def _workspace(self):
        """arrays.Work with n rows, views of buffers kept at the capacity (see arrays.Work)."""
        cap, n = self._b.capacity, self._b.n
        if self._work is None or self._work.acc.shape[0] != cap:
            shapes = {"ever": np.bool_, "touched": np.bool_, "in_focus": np.bool_,
                      "is_giant": np.bool_, "merged": np.int64, "partners": np.int64,
                      "tb": np.float64}
            self._work = Work(*(np.zeros(cap, shapes[name]) if name in shapes
                                else np.zeros((cap, 3)) for name in Work._fields))
        return Work(*(a[:n] for a in self._work))

    def _run_kernel(self, nsteps, setup, ctrl, frames=None):
        b = self._b
        spec = self._spec
        frames = _NO_FRAMES if frames is None else frames
        if spec.family == "splitting":
            return splitting_steps(b.pos[:b.n], b.vel[:b.n], *self._gravity_args(), spec.drift,
                                   spec.kick, self._drag, self._dt, nsteps, setup, ctrl,
                                   self._workspace(), *frames)
        if spec.family == "rk":
            return rk_steps(b.pos[:b.n], b.vel[:b.n], *self._gravity_args(), spec.a, spec.b,
                            self._drag, self._dt, nsteps, setup, ctrl, self._workspace(),
                            *frames)
        if self._drag[0] > 0.0:
            raise ValueError(f"drag = {self._drag[0]:g}: integrator {spec.name!r} has no drag "
                             f"yet; use a fixed-step one (leapfrog, yoshida4..8, rk4)")
        if spec.family == "gauss_radau":
            return self._run_gauss_radau(nsteps, setup, ctrl)
        return self._run_wisdom_holman(nsteps, setup, ctrl)

    def _run_wisdom_holman(self, nsteps, setup, ctrl):
        if self._model != DIRECT:
            raise ValueError(f"integrator {self._spec.name!r} needs gravity='direct' with a "
                             f"dominant body among the bodies (gravity={self._gravity!r})")
        b = self._b
        n = b.n
        args = self._gravity_args()
        src, passive, still = args[2], args[3], args[8]
        if still.size:
            raise ValueError(f"integrator {self._spec.name!r} cannot hold bodies fixed "
                             f"({still.size} are): use a fixed-step or the adaptive integrator")
        pulling_actors = ctrl.actors[np.isin(ctrl.actors, src)]
        if pulling_actors.size:
            raise ValueError(f"integrator {self._spec.name!r}: ship or missile "
                             f"{int(b.ids[pulling_actors[0]])} pulls (active): its mass changes "
                             f"as it burns, which the Jacobi frames cannot follow; make it "
                             f"passive or use another integrator")
        order, m = self._jacobi_order(src, passive)
        saved = b.pos[:n].copy(), b.vel[:n].copy()
        done, ok = wisdom_holman_steps(b.pos[:n], b.vel[:n], *args, order, m, self._dt, nsteps,
                                       self._spec.corrector > 0, setup, ctrl,
                                       self._workspace())
        if not ok:
            if done == 0:
                b.pos[:n], b.vel[:n] = saved
            self._steps += done          # the kernel undid the failed step (see its docstring)
            setup.alive[:] = True
            raise FloatingPointError(
                f"{self._spec.name}: a Kepler drift did not converge: a body sits at the centre "
                f"of mass of the bodies before it (its Jacobi orbit is singular), or the state "
                f"is NaN. The state is that at t = {self.t:g}. Wisdom-Holman is for scenes "
                f"with one dominant mass; use gauss_radau or yoshida6 otherwise.")
        return done

    def _jacobi_order(self, src, passive):
        """The bodies in Jacobi order and their Jacobi masses, cached with the source lists:
        the heaviest pulling body is the centre, the other pulling bodies follow in their
        order (add planets inside out: each Jacobi orbit is about the bodies before it), then
        the passive ones, which do not move the Jacobi frames (mass 0)."""
        b = self._b
        if self._jacobi is None:
            if src.size == 0:
                order = np.arange(b.n, dtype=np.int64)
            else:
                src = src[np.argsort(b.serial[src], kind="stable")]    # in order of addition
                central = src[np.argmax(b.mass[src])]
                order = np.concatenate([[central], src[src != central], passive]).astype(np.int64)
            m = np.zeros(b.n)
            m[:src.size] = b.mass[order[:src.size]]
            self._jacobi = (order, m)
        return self._jacobi

    def _run_gauss_radau(self, nsteps, setup, ctrl):
        b = self._b
        n = b.n
        cols = [b.ensure_column(name, shape)[:n] for name, shape in
                (("csx", (3,)), ("csv", (3,)), ("gr_b", (7, 3)), ("gr_e", (7, 3)))]
        args = self._gravity_args()
        src, passive = args[2], args[3]
        pulling = self._model == DIRECT and (
            self.step_control == "pulling" and src.size
            or self.step_control == "auto" and src.size >= 2)
        if pulling:
            control, riders = src, passive
        else:
            control, riders = np.arange(n, dtype=np.int64), passive[:0]
        spec = self._spec
        stats = self._adaptive_stats
        before = stats.copy()
        done = gauss_radau_steps(b.pos[:n], b.vel[:n], *args, *cols, control, riders,
                                    spec.nodes, spec.c_gb, spec.d_bg, self._dt, nsteps,
                                    self._adaptive, stats, setup, ctrl, self._workspace())
        if stats[gr.FAILED]:
            stats[gr.FAILED] = 0
            self._steps += done          # the state is that of the last completed interval
            self._reset_adaptive()       # the failed step's tiny proposal and wild polynomial
            b.prev[:n] = b.pos[:n]       # nothing to interpolate across a failure
            pair = self._closest_pair(src)
            met = (f"; the closest pulling bodies are {self._named(pair)}, which may have "
                   f"met (or the coordinates are too far from the origin to resolve the "
                   f"step: see shift_origin)" if pair.size else "")
            raise InstabilityError(
                f"gauss_radau: the step shrank below the resolution of time or became NaN "
                f"after t = {self.t:g} (next step {self._adaptive[3]:.3g}){met}. The state "
                f"is that at t = {self.t:g}. Set min_step, or soften gravity.",
                b.ids[pair].copy(), self.t)
        if stats[gr.AT_MIN_STEP] > before[gr.AT_MIN_STEP]:
            # warned by _run once the time is booked (a warning turned error must find the
            # World consistent)
            self._pending_warning = (
                f"gauss_radau: {stats[gr.AT_MIN_STEP] - before[gr.AT_MIN_STEP]} substeps were "
                f"held at min_step = {self._adaptive[2]:g}; the error is no longer controlled "
                f"there")
        return done

    def _closest_pair(self, rows):
        """The two rows of `rows` closest together (none if fewer than 2, or too many to
        compare all pairs in a failure's message)."""
        if not 2 <= rows.size <= 2048:
            return rows[:0]
        p = self._b.pos[rows]
        d2 = ((p[:, None, :] - p[None, :, :]) ** 2).sum(axis=2)
        d2[np.diag_indices(rows.size)] = np.inf
        i, j = np.unravel_index(np.argmin(d2), d2.shape)
        return rows[[i, j]]

    def _reset_adaptive(self):
        """Forget the adaptive integrator's carried state: step proposal, prediction, the
        per-body polynomials and compensations."""
        self._adaptive[3:5] = min(self._dt, self._adaptive[1])
        self._adaptive[5] = 0.0
        for name in ("gr_b", "gr_e", "csx", "csv"):
            if name in self._b.columns:
                getattr(self._b, name)[:] = 0.0

    def step(self, n=1):
        """Advance n steps of dt, the loop inside numba; returns the new time. w.events then
        holds what happened during these steps."""
        n = check.count("n", n)
        t0 = self.t
        self._event_count[:] = 0
        self._write_queued_events()
        if n:
            if n > 1:
                self._run_framed(n - 1)
            b = self._b
            b.prev[:b.n] = b.pos[:b.n]
            self._run_framed(1)
        if self._log is not None:
            self._log.record_events(self.events)
        if n:
            self._check_health(t0)
        return self.t

    def _run_framed(self, n):
        """_run, with the frames a recording takes: captured inside the fixed-step kernels,
        or by cutting the run at each frame for the adaptive and Wisdom-Holman ones."""
        log = self._log
        inside = self._spec.family in ("splitting", "rk")
        while n:
            if log is not None and inside and self._b.n:
                room = self._frame_room()
                at = log.frame_offsets(self, n, room)
                k = int(at[-1]) if at.size == room else n
                self._run(k, at)
            else:
                k = n if log is None else min(n, log.until_frame(self))
                if self._b.n:
                    self._run(k)
                else:
                    self._steps += k
                if log is not None:
                    log.stepped(self, k)
            n -= k

    def _write_queued_events(self):
        """Launches made since the last step open this step's events."""
        queued, self._queued_events = self._queued_events, []
        if queued:
            buf = self._event_box[0]
            if len(buf) < len(queued):
                self._event_box[0] = buf = np.zeros(2 * len(queued), dtype=EVENT_DTYPE)
            buf[:len(queued)] = queued
            self._event_count[0] = len(queued)

    def advance(self, frame_time):
        """Fixed-step accumulator for variable frame time; returns alpha in [0, 1).

        Adds frame_time [time] to the accumulator and takes as many whole steps of dt as fit,
        at most max_substeps (the excess goes to dropped_time, so a slow frame slows the
        simulation down instead of making the next frame slower still). Draw
        w.interpolate(alpha), between the states before and after the last step.
        """
        frame_time = check.scalar("frame_time", frame_time, minimum=0.0)
        acc = self._accumulator + frame_time
        # a hair of slack so that 4 frames of dt/4 make one step, not 0.99999 of one
        whole = acc / self._dt * (1.0 + 1e-12)
        if whole >= self._max_substeps + 1:          # also a frame of inf steps
            n, left, dropped = self._max_substeps, 0.0, acc - self._max_substeps * self._dt
        else:
            n = int(whole)
            left, dropped = max(acc - n * self._dt, 0.0), 0.0
        steps = self._steps
        try:
            self.step(n)                 # the only part that can fail: nothing changed before
        except InstabilityError:
            if self._steps - steps == n:     # the steps were taken; the check found them bad
                self._accumulator = left
                self.dropped_time += dropped
            raise
        self._accumulator = left
        self.dropped_time += dropped
        return min(left / self._dt, np.nextafter(1.0, 0.0))

    def interpolate(self, alpha):
        """(n, dim) positions for rendering: prev + alpha (pos - prev), alpha in [0, 1]."""
        alpha = check.scalar("alpha", alpha, minimum=0.0)
        if alpha > 1.0:
            raise ValueError(f"alpha = {alpha}: must be <= 1")
        b = self._b
        prev = b.prev[:b.n, :self._dim]
        return prev + alpha * (b.pos[:b.n, :self._dim] - prev)

    # ---------------------------------------------------------------- instability
    def _named(self, rows, most=5):
        """'body 3 (planet), body 7 (moon) and 12 more' for rows of live bodies."""
        b = self._b
        names = [f"body {int(b.ids[r])} ({self._kinds[b.kind[r]]})" for r in rows[:most]]
        more = f" and {len(rows) - most} more" if len(rows) > most else ""
        return ", ".join(names) + more

    def _check_health(self, t0):
        """After a step() from time t0: InstabilityError if a body's state is not finite, or
        if the watched energy error passed its limit."""
        b = self._b
        n = b.n
        if n and not diagnostics.finite_state(b.pos[:n], b.vel[:n]):
            rows = np.flatnonzero(~(np.isfinite(b.pos[:n]).all(axis=1)
                                    & np.isfinite(b.vel[:n]).all(axis=1)))
            if rows.size:
                raise InstabilityError(
                    f"the state became NaN or infinite between t = {t0:g} and t = {self.t:g}: "
                    f"{self._named(rows)}. A step too long for a close approach, bodies "
                    f"meeting without softening, or a speed past the range of doubles; take "
                    f"a shorter dt, soften gravity, or use gauss_radau (w.remove(ids) drops "
                    f"them)", b.ids[rows].copy(), self.t)
        if self._watch is None:
            return
        limit, E0, e0, ids0 = self._watch
        if E0 == 0.0:                      # bodies removed since: no scale left to judge by
            return
        error = abs(self.energy(True) / E0 - 1.0)
        if error <= limit:                 # (a NaN energy is not <= limit either)
            return
        # the bodies whose own energy changed most, as a fraction of |E0|
        now = self._body_energies()
        _, then_rows, now_rows = np.intersect1d(ids0, b.ids[:n], return_indices=True)
        change = np.abs(now[now_rows] - e0[then_rows]) / abs(E0)
        order = np.argsort(-np.nan_to_num(change, nan=np.inf), kind="stable")
        rows = now_rows[order]
        shares = ", ".join(f"{change[k]:.2g}" for k in order[:5])
        raise InstabilityError(
            f"energy error {error:.3g} since watch_energy passed its limit {limit:g} between "
            f"t = {t0:g} and t = {self.t:g}; the energy changed most in {self._named(rows)} "
            f"({shares} of |E0|). Their orbits are not resolved by dt = {self._dt:g} with "
            f"{self.integrator}: take a shorter dt or use gauss_radau",
            b.ids[rows].copy(), self.t)

    def _body_energies(self):
        model, mass, src, passive, G, eps2, field, field_mass, still = self._gravity_args()
        b = self._b
        out = np.empty(b.n)
        diagnostics.body_energies(b.pos[:b.n], b.vel[:b.n], model, self._masses(True), src, G,
                                  eps2, field, field_mass, out)
        return out

    def watch_energy(self, limit):
        """From now on, raise InstabilityError after any step() or advance() that leaves the
        relative energy error of the pulling bodies (since this call) above limit, naming the
        bodies whose own energy changed most; limit=None stops watching. For scenes that
        conserve energy: thrust, drag, and collisions that merge or break change it. Costs
        an energy sum, O(N_pulling^2), per call."""
        if limit is None:
            self._watch = None
            return
        limit = check.scalar("limit", limit, positive=True)
        reference = self._energy_reference()
        if reference[0] == 0.0:
            raise ValueError("watch_energy: the pulling bodies' energy is 0, so a relative "
                             "error has no scale (no massive bodies, or none moving)")
        self._watch = (limit,) + reference

    def _energy_reference(self):
        """(E0, body energies, ids): what watch_energy measures against."""
        return (self.energy(True), self._body_energies(), self._b.ids[:self._b.n].copy())

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
        if self._model == CENTRAL:
            self._field[:d] -= delta
        if len(self._walls):
            self._walls[:, 1:1 + d] -= delta
            segments = self._walls[:, 0] == collide.SEGMENT
            self._walls[segments, 4:4 + d] -= delta
        if self._boundary != collide.OPEN:
            self._box[:, :d] -= delta
        for ev in self._queued_events:      # launches waiting for the next step's events
            for c, name in enumerate("xyz"[:d]):
                ev[name] -= delta[c]
        self._origin[:d] += delta
        self._rewatch()              # a uniform field's potential has no natural zero

    # ---------------------------------------------------------------- diagnostics
    # Diagnostics cover every body by default. With pulling_only=True they cover the bodies that
    # pull only: when passive bodies have mass (ships), those are the quantities the dynamics
    # conserve, since a passive body is pulled without pulling back.
    def _masses(self, pulling_only):
        b = self._b
        return np.where(self.pulls, b.mass[:b.n], 0.0) if pulling_only else b.mass[:b.n]

    def kinetic_energy(self, pulling_only=False):
        b = self._b
        return diagnostics.kinetic_energy(b.vel[:b.n], self._masses(pulling_only))

    def potential_energy(self, pulling_only=False):
        """Potential energy in the gravity model (passive bodies in the pulling ones' field)."""
        model, mass, src, passive, *rest = self._gravity_args()
        if pulling_only:
            mass, passive = self._masses(True), passive[:0]
        return diagnostics.potential_energy(self._b.pos[:self._b.n], model, mass, src, passive,
                                            *rest)

    def energy(self, pulling_only=False):
        """Kinetic + potential energy [mass length^2 / time^2]."""
        return self.kinetic_energy(pulling_only) + self.potential_energy(pulling_only)

    def momentum(self, pulling_only=False):
        """(dim,) total linear momentum sum m v [mass length / time]."""
        b = self._b
        return (self._masses(pulling_only)[:, None] * b.vel[:b.n]).sum(axis=0)[:self._dim]

    def angular_momentum(self, pulling_only=False):
        """sum m r x v about the origin: (3,) in 3D, the scalar z component in 2D."""
        b = self._b
        L = (self._masses(pulling_only)[:, None] * np.cross(b.pos[:b.n], b.vel[:b.n])).sum(axis=0)
        return L if self._dim == 3 else float(L[2])

    def total_mass(self):
        return float(self._b.mass[:self._b.n].sum())

    def center_of_mass(self):
        """(dim,) mass-weighted mean position [length]; ValueError if the total mass is 0."""
        b = self._b
        M = self.total_mass()
        if M <= 0:
            raise ValueError("center_of_mass: the total mass is 0 (only test particles)")
        return (b.mass[:b.n, None] * b.pos[:b.n]).sum(axis=0)[:self._dim] / M

    def center_of_mass_velocity(self):
        """(dim,) velocity of the centre of mass [length / time]."""
        M = self.total_mass()
        if M <= 0:
            raise ValueError("center_of_mass_velocity: the total mass is 0 (only test particles)")
        return self.momentum() / M

    def move_to_center_of_mass(self):
        """Shift every body so that the centre of mass rests at the origin."""
        r, v = self.center_of_mass(), self.center_of_mass_velocity()
        b = self._b
        b.pos[:b.n, :self._dim] -= r
        b.prev[:b.n, :self._dim] -= r
        b.vel[:b.n, :self._dim] -= v
        self._rewatch()

    def __repr__(self):
        return (f"World(dim={self._dim}, n={self.n}, gravity={self._gravity!r}, "
                f"integrator={self.integrator!r}, dt={self._dt!r}, t={self.t!r})")


# the calls a run log records (runlog.py): every public method that changes the World
for _name in ("add_kind", "add_body", "add_bodies", "set_body", "remove", "set_collision",
              "add_plane", "add_segment", "clear_walls", "set_boundary", "step", "advance",
              "move_to_center_of_mass", "add_ship", "control", "set_heading", "set_fuel",
              "launch", "explode", "watch_energy", "shift_origin"):
    setattr(World, _name, journaled(getattr(World, _name)))
