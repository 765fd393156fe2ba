"""World: the game-facing object holding bodies, the gravity model and the integrator."""
import copy
from collections import namedtuple

import numpy as np

from . import _validate as check
from .integrators import get_integrator
from .kernels import diagnostics
from .kernels.gravity import CENTRAL, DIRECT, NONE, UNIFORM
from .kernels.integrate import rk_steps, splitting_steps
from .state import Bodies
from .units import get_units

GRAVITY_MODELS = {"none": NONE, "direct": DIRECT, "uniform": UNIFORM, "central": CENTRAL}
DEFAULT_KINDS = ("body", "star", "planet", "moon", "asteroid", "ship", "missile", "debris")

Body = namedtuple("Body", "id pos vel mass radius kind active")
Body.__doc__ = "A copy of one body's state: id, pos/vel (dim,), mass, radius, kind name, active."


def _readonly(arr):
    view = arr.view()
    view.flags.writeable = False
    return view


class World:
    """Bodies under gravity, advanced by a fixed-step integrator whose loop runs in numba.

    Parameters
    ----------
    dim : 2 or 3
    units : "game" (G = 1), "si" (G = 6.6743e-11), "au-msun-yr" (G = 39.4769...)
    G : float >= 0, overrides the units' G [length^3 / (mass time^2)]
    integrator : a name of spacephys.INTEGRATORS
    dt : float > 0, the step [time]
    softening : float >= 0, Plummer softening length [length]
    gravity : "direct" (mutual, bodies of mass 0 or passive feel but do not pull),
              "uniform" (a constant field g), "central" (a fixed body central_mass at
              central_pos; bodies ignore each other), "none"
    g : (dim,) uniform field [length / time^2], with gravity="uniform"
    central_mass, central_pos : the fixed body, with gravity="central" (pos defaults to 0)
    max_substeps : int >= 1, most steps one advance() call may take (against the spiral of death)
    capacity : int, initial room for bodies (grows by doubling)
    """

    def __init__(self, dim=2, *, units="game", G=None, integrator="leapfrog", dt=1 / 240,
                 softening=0.0, gravity="direct", g=None, central_mass=None, central_pos=None,
                 max_substeps=16, capacity=64):
        if dim not in (2, 3) or isinstance(dim, bool):
            raise ValueError(f"dim = {dim!r}: must be 2 or 3")
        unit_system = get_units(units)
        G = unit_system.G if G is None else check.scalar("G", G, minimum=0.0)
        spec = get_integrator(integrator)
        dt = check.scalar("dt", dt, positive=True)
        softening = check.scalar("softening", softening, minimum=0.0)
        if gravity not in GRAVITY_MODELS:
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
        self.max_substeps = check.count("max_substeps", max_substeps, minimum=1)
        capacity = check.count("capacity", capacity, minimum=1)

        self._dim = dim
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
        self._sources = None            # (src, passive) index arrays, rebuilt when stale
        self._dt = dt
        self._t_base = 0.0              # t = t_base + steps * dt: no rounding build-up in t
        self._steps = 0
        self._accumulator = 0.0
        self.dropped_time = 0.0         # frame time advance() dropped to stay real-time

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

    @property
    def integrator_spec(self):
        return self._spec

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
        if name not in self._kinds:
            if len(self._kinds) >= np.iinfo(np.int16).max:
                raise ValueError(f"kind {name!r}: too many kinds ({len(self._kinds)})")
            self._kinds.append(name)
        return self._kinds.index(name)

    def kind_code(self, name):
        """The code of a declared kind name."""
        return int(self._kind_codes(name, 1, "kind")[0])

    def _kind_codes(self, kind, k, field):
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
        """(n,) bool: True where a massive body pulls others (passive bodies only feel)."""
        return _readonly(self._b.active[:self._b.n])

    def add_body(self, mass, pos, vel=None, *, radius=0.0, kind="body", active=None):
        """Add one body; returns its id.

        mass [mass] >= 0 (0: a test particle); pos, vel : (dim,); radius [length] >= 0;
        kind : a declared kind name or code; active : pulls others (default: mass > 0).
        """
        pos = check.floats("pos", pos, (self._dim,))
        vel = np.zeros(self._dim) if vel is None else check.floats("vel", vel, (self._dim,))
        mass = check.scalar("mass", mass, minimum=0.0)
        radius = check.scalar("radius", radius, minimum=0.0)
        if active is not None and not isinstance(active, (bool, np.bool_)):
            raise ValueError(f"active = {active!r}: must be True, False or None")
        return int(self.add_bodies(mass, pos[None], vel[None], radius=radius, kind=kind,
                                   active=active)[0])

    def add_bodies(self, mass, pos, vel=None, *, radius=0.0, kind="body", active=None):
        """Add k bodies at once; returns their (k,) int64 ids.

        mass : number or (k,); pos, vel : (k, dim); radius : number or (k,);
        kind : one name/code or k of them; active : None (mass > 0), a bool or (k,) bools.
        Everything is checked before anything is added.
        """
        pos = check.floats("pos", pos, (None, self._dim))
        k = pos.shape[0]
        vel = np.zeros((k, self._dim)) if vel is None else check.floats("vel", vel, (k, self._dim))
        mass = check.per_body("mass", mass, k, minimum=0.0)
        radius = check.per_body("radius", radius, k, minimum=0.0)
        codes = self._kind_codes(kind, k, "kind")
        if active is None:
            act = mass > 0
        else:
            act = np.asarray(active)
            if act.dtype != np.bool_ or act.shape not in ((), (k,)):
                raise ValueError(f"active = {active!r}: must be None, a bool or {k} bools")
            act = np.broadcast_to(act, (k,))
        p3 = np.zeros((k, 3))
        v3 = np.zeros((k, 3))
        p3[:, :self._dim] = pos
        v3[:, :self._dim] = vel
        ids = self._b.add({"pos": p3, "vel": v3, "mass": mass, "radius": radius,
                           "kind": codes, "active": act})
        self._sources = None
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
        return np.ndim(body_id) == 0 and int(self._b.lookup([body_id])[0]) >= 0

    def get(self, body_id):
        """A copy of one body's state as a Body namedtuple."""
        i = self.index_of(body_id)
        b = self._b
        return Body(int(b.ids[i]), b.pos[i, :self._dim].copy(), b.vel[i, :self._dim].copy(),
                    float(b.mass[i]), float(b.radius[i]), self._kinds[b.kind[i]],
                    bool(b.active[i]))

    def set_body(self, body_id, *, pos=None, vel=None, mass=None, radius=None, kind=None,
                 active=None):
        """Change one body between steps; everything is checked before anything changes.

        A new pos also resets the body's render interpolation (a teleport, not a smear).
        """
        i = self.index_of(body_id)
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
        if active is not None:
            if not isinstance(active, (bool, np.bool_)):
                raise ValueError(f"active = {active!r}: must be True or False")
            new["active"] = active
        b = self._b
        for name, value in new.items():
            col = getattr(b, name)
            if name in ("pos", "vel"):
                col[i, :self._dim] = value
            else:
                col[i] = value
        if "pos" in new:
            b.prev[i] = b.pos[i]
        if "mass" in new or "active" in new:
            self._sources = None

    def remove(self, ids):
        """Remove one id or an array of ids (all must be live; duplicates count once)."""
        rows = np.unique(np.atleast_1d(self.index_of(ids)))
        self._b.remove(rows)
        self._sources = None

    def copy(self):
        """An independent deep copy (same ids, state, time and settings)."""
        # the integrator spec is immutable and shared: a copied (writeable) table would make
        # numba compile the kernels a second time for a different array type
        return copy.deepcopy(self, memo={id(self._spec): self._spec})

    # ---------------------------------------------------------------- stepping
    def _source_lists(self):
        if self._sources is None:
            b = self._b
            pulls = b.active[:b.n] & (b.mass[:b.n] > 0)
            self._sources = (np.flatnonzero(pulls).astype(np.int64),
                             np.flatnonzero(~pulls).astype(np.int64))
        return self._sources

    def _gravity_args(self):
        """The gravity arguments of the kernels, after pos (see kernels/gravity.py)."""
        b = self._b
        src, passive = self._source_lists()
        return (self._model, b.mass[:b.n], src, passive, self._G, self._softening ** 2,
                self._field, self._field_mass)

    def _run(self, nsteps):
        b = self._b
        spec = self._spec
        if spec.family == "splitting":
            splitting_steps(b.pos[:b.n], b.vel[:b.n], *self._gravity_args(), spec.drift,
                            spec.kick, self._dt, nsteps)
        else:
            rk_steps(b.pos[:b.n], b.vel[:b.n], *self._gravity_args(), spec.a, spec.b,
                     self._dt, nsteps)

    def step(self, n=1):
        """Advance n steps of dt, the loop inside numba; returns the new time."""
        n = check.count("n", n)
        b = self._b
        if n and b.n:
            if n > 1:
                self._run(n - 1)
            b.prev[:b.n] = b.pos[:b.n]
            self._run(1)
        self._steps += n
        return self.t

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
        n = int(np.floor(acc / self._dt * (1.0 + 1e-12)))
        if n > self.max_substeps:
            self.dropped_time += (n - self.max_substeps) * self._dt
            acc -= (n - self.max_substeps) * self._dt
            n = self.max_substeps
        self.step(n)
        self._accumulator = max(acc - n * self._dt, 0.0)
        return min(self._accumulator / self._dt, np.nextafter(1.0, 0.0))

    def interpolate(self, alpha):
        """(n, dim) positions for rendering: prev + alpha (pos - prev), alpha in [0, 1]."""
        alpha = check.scalar("alpha", alpha, minimum=0.0)
        if alpha > 1.0:
            raise ValueError(f"alpha = {alpha}: must be <= 1")
        b = self._b
        prev = b.prev[:b.n, :self._dim]
        return prev + alpha * (b.pos[:b.n, :self._dim] - prev)

    # ---------------------------------------------------------------- diagnostics
    def kinetic_energy(self):
        b = self._b
        return diagnostics.kinetic_energy(b.vel[:b.n], b.mass[:b.n])

    def potential_energy(self):
        """Potential energy in the gravity model (passive bodies in the active ones' field)."""
        return diagnostics.potential_energy(self._b.pos[:self._b.n], *self._gravity_args())

    def energy(self):
        """Kinetic + potential energy [mass length^2 / time^2]."""
        return self.kinetic_energy() + self.potential_energy()

    def momentum(self):
        """(dim,) total linear momentum sum m v [mass length / time]."""
        b = self._b
        return (b.mass[:b.n, None] * b.vel[:b.n]).sum(axis=0)[:self._dim]

    def angular_momentum(self):
        """sum m r x v about the origin: (3,) in 3D, the scalar z component in 2D."""
        b = self._b
        L = (b.mass[:b.n, None] * np.cross(b.pos[:b.n], b.vel[:b.n])).sum(axis=0)
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

    def __repr__(self):
        return (f"World(dim={self._dim}, n={self.n}, gravity={self._gravity!r}, "
                f"integrator={self.integrator!r}, dt={self._dt!r}, t={self.t!r})")
