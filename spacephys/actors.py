"""Ships, missiles, explosions and lifetimes, one component of World: what makes a space game.

An actor is a body with an engine: a ship (World.add_ship) or a missile (World.launch). Its
engine, controls and orientation live in extra per-body columns, created with the first actor,
so scenes without actors carry none of them. The kernels (kernels/control.py) turn, thrust,
burn fuel, guide and fuse every actor inside the step loop; this component validates, keeps
the specs, thrust curves and launch events waiting for the next step, and builds the kernels'
table (kernels/control.Actors). World's methods of the same names delegate here. Adding an
entity kind with behaviour of its own touches this file, kernels/control.py and entities.py.
"""
import dataclasses
import math
import operator

import numpy as np

from . import _validate as check
from . import editing, plans
from .entities import G0_SI, ExplosionSpec, MissileSpec, ShipSpec, filter_value
from .kernels.codes import GUIDANCE
from .events import EVENT_DTYPE, upgrade
from .kernels import control, libm, seeds
from .kernels.codes import EV_DESTROY, EV_DETONATION, EV_LAUNCH, EV_MERGE
from . import portable

# per-body actor columns: name -> (shape, dtype, default)
ACTOR_COLUMNS = {
    "actor": ((), np.bool_, False),
    "quat": ((4,), np.float64, 0.0),
    "omega": ((3,), np.float64, 0.0),
    "throttle": ((), np.float64, 0.0),
    "turn": ((3,), np.float64, 0.0),
    "strafe": ((3,), np.float64, 0.0),
    "dry": ((), np.float64, 0.0),
    "fuel": ((), np.float64, 0.0),
    "thrust": ((), np.float64, 0.0),
    "side": ((), np.float64, 0.0),
    "exhaust": ((), np.float64, 1.0),
    "turn_rate": ((), np.float64, 0.0),
    "inertia": ((), np.float64, 0.0),
    "torque": ((), np.float64, 0.0),
    "curve": ((2,), np.int64, 0),
    "guidance": ((), np.int64, 0),
    "nav": ((), np.float64, 0.0),
    "target": ((), np.int64, -1),         # an id
    "launcher": ((), np.int64, -1),       # an id
    "burn_end": ((), np.float64, np.inf),
    "armed_at": ((), np.float64, -np.inf),
    "fuse": ((), np.float64, 0.0),
    "kill": ((), np.bool_, False),
    "flags": ((), np.int64, 0),
    "explosion": ((), np.int64, -1),      # index into World._explosion_specs
}
LIFETIME_COLUMNS = {
    "born": ((), np.float64, 0.0),
    "expires": ((), np.float64, np.inf),
    "fade": ((), np.float64, 1.0),
}
_EMPTY = {name: np.zeros((0,) + shape, dtype) for name, (shape, dtype, _) in
          {**ACTOR_COLUMNS, **LIFETIME_COLUMNS}.items()}


def _heading(dim, heading):
    """(unit (3,) direction, unit quaternion turning body x onto it) from an angle [rad] (2D)
    or a vector (2D or 3D; the shortest turn from x); None is +x."""
    if heading is None:
        return np.array([1.0, 0.0, 0.0]), np.array([1.0, 0.0, 0.0, 0.0])
    if dim == 2 and np.ndim(heading) == 0:
        angle = check.scalar("heading", heading)
        h = np.array([libm.py.cos(angle), libm.py.sin(angle), 0.0])
        return h, np.array([libm.py.cos(angle / 2), 0.0, 0.0, libm.py.sin(angle / 2)])
    v = check.floats("heading", heading, (dim,))
    norm = portable.norm(v)
    if norm == 0.0:
        raise ValueError(f"heading = {v.tolist()}: a direction cannot be zero")
    h = np.concatenate([v, np.zeros(3 - dim)])
    if norm != 1.0:
        h /= norm
    if dim == 2:
        angle = libm.py.atan2(h[1], h[0])
        return h, np.array([libm.py.cos(angle / 2), 0.0, 0.0, libm.py.sin(angle / 2)])
    if h[0] < -1.0 + 1e-15:
        return h, np.array([0.0, 0.0, 0.0, 1.0])            # straight back: half a turn about z
    q = np.array([1.0 + h[0], 0.0, -h[2], h[1]])           # half-way quaternion from x to h
    return h, q / portable.norm(q)


def _rotate(q, v):
    """R(q) v for a unit quaternion q (w, x, y, z): v + w t + u x t, t = 2 u x v, in plain
    floats (numpy's cross on 3-vectors costs more than the arithmetic)."""
    w, x, y, z = (float(c) for c in q)
    vx, vy, vz = (float(c) for c in v)
    tx, ty, tz = 2.0 * (y * vz - z * vy), 2.0 * (z * vx - x * vz), 2.0 * (x * vy - y * vx)
    return np.array([vx + w * tx + (y * tz - z * ty), vy + w * ty + (z * tx - x * tz),
                     vz + w * tz + (x * ty - y * tx)])


class Actors:
    """Ships, missiles, explosions and lifetimes of one World (see the module).

    world : the World (for its bodies, kinds, time and units); seed : seeds the explosions.
    """

    def __init__(self, world, seed):
        self.w = world
        self.seed = seed
        self.specs = []                       # ExplosionSpecs, indexed by the explosion column
        self._specs_hash = (None, 0, None, b"")  # (specs, count, curves, their bytes): digest()
        self.curves = np.zeros((0, 2))        # thrust curve rows (speed, factor)
        self.queued = []                      # launch events waiting for the next step
        self.plans = {}                       # ship id -> plan rows (k, plans.PLAN_WIDTH)
        self.clock = np.zeros(2)              # [time base, steps]: World sets it per call

    @property
    def b(self):
        return self.w._b

    # ------------------------------------------------------------ columns
    def _actor_columns(self):
        self.b.ensure_columns(ACTOR_COLUMNS)

    def _lifetime_columns(self):
        self.b.ensure_columns(LIFETIME_COLUMNS)

    def _actor_row(self, body, field="id"):
        """The row of a ship or missile (ValueError naming field for any other body)."""
        i = self.w.index_of(body, field)
        b = self.b                              # is_actor(i), inline: a game's every-frame call
        if not ("actor" in b.columns and b.actor.item(i)
                and not b.flags.item(i) & control.FLAG_ROTOR):
            raise ValueError(f"{field} = {body}: body is a {self.w.kinds[b.kind[i]]!r}, "
                             f"not a ship or missile")
        return i

    def _oriented_row(self, body):
        """The row of a body with an orientation (an actor or a rotor), -1 for any other."""
        i = self.w.index_of(body, "body")
        b = self.b
        return i if "actor" in b.columns and b.actor.item(i) else -1

    def _rotor(self, i):
        """Give the body at row i an orientation of its own (a rotor: identity, at rest)
        unless it has one; returns its row (the columns may have been laid out anew)."""
        b = self.b
        if "actor" in b.columns and b.actor.item(i):
            return i
        body = int(b.ids[i])
        self._actor_columns()
        i = self.w.index_of(body)
        b = self.b
        b.actor[i] = True
        b.quat[i] = (1.0, 0.0, 0.0, 0.0)
        b.inertia[i] = np.inf                # no torque acts on a rotor: it keeps its spin
        b.flags[i] = control.FLAG_ROTOR
        self.w._invalidate()
        return i

    def orient(self, i):
        """Make sure the body at row i has an orientation (a rotor, at rest, unless it has
        one); returns its row (the columns may have been laid out anew)."""
        return self._rotor(i)

    def _engines(self, rows):
        """The ships and missiles among these rows of actors (rotors left out)."""
        if not rows.size:
            return rows
        return rows[self.b.flags[rows] & control.FLAG_ROTOR == 0]

    def _exhaust_speed(self, spec):
        if spec.exhaust_speed is not None:
            return spec.exhaust_speed
        if self.w.units.name != "si":
            raise ValueError(f"isp = {spec.isp} needs units='si' (standard gravity is "
                             f"{G0_SI} m/s^2); in units={self.w.units.name!r} give exhaust_speed")
        return spec.isp * G0_SI

    def _curve_rows(self, table):
        if table is None:
            return (0, 0)
        first = len(self.curves)
        self.curves = np.vstack([self.curves, table])
        return (first, len(table))

    def _explosion_index(self, spec):
        if spec is None:
            return -1
        for k, known in enumerate(self.specs):
            if known == spec:
                return k
        self.specs.append(spec)
        return len(self.specs) - 1

    # ------------------------------------------------------------ ships
    def add_ship(self, spec, pos, vel=None, heading=None):
        """World.add_ship (the docstring is there)."""
        if not isinstance(spec, ShipSpec):
            raise ValueError(f"spec = {spec!r}: must be a ShipSpec")
        _, q = _heading(self.w.dim, heading)
        ve = self._exhaust_speed(spec)
        self.w.add_kind(spec.kind)
        physical = spec.moment_of_inertia is not None
        return self._add_actor(spec, pos, vel, q, {
            "dry": spec.dry_mass, "fuel": spec.fuel_mass, "thrust": spec.max_thrust,
            "side": spec.side_thrust, "exhaust": ve,
            "turn_rate": 0.0 if physical else spec.turn_rate,
            "inertia": spec.moment_of_inertia if physical else 0.0,
            "torque": spec.torque}, active=spec.active)

    def _add_actor(self, spec, pos, vel, q, values, active, lifetime=None):
        """Validate pos/vel, then add the body (with the spec's collision filter) and set its
        actor columns (all or nothing)."""
        pos = check.floats("pos", pos, (self.w.dim,))
        vel = np.zeros(self.w.dim) if vel is None else check.floats("vel", vel, (self.w.dim,))
        curve = self._curve_rows(spec.thrust_curve)       # only grows a table: harmless
        explosion = self._explosion_index(spec.explosion)
        shape = editing.check_shape(self.w, getattr(spec, "shape", None))
        self._actor_columns()
        if lifetime is not None:
            self._lifetime_columns()
        body = self.w.add_body(spec.dry_mass + spec.fuel_mass, pos, vel, radius=spec.radius,
                               kind=spec.kind, active=active, category=spec.category,
                               mask=spec.mask, group=spec.group)
        b = self.b
        i = self.w.index_of(body)
        b.actor[i] = True                     # before its shape: a ship, not a rotor
        if shape is not None:
            editing.give_shapes(self.w, [body], [shape])
            b = self.b
            i = self.w.index_of(body)
        b.actor[i] = True
        b.quat[i] = q
        b.curve[i] = curve
        b.explosion[i] = explosion
        for name, value in values.items():
            getattr(b, name)[i] = value
        if lifetime is not None:
            b.born[i] = self.w.t
            b.expires[i] = self.w.t + lifetime
        return body

    def control(self, body, throttle=None, turn=None, strafe=None):
        """World.control (the docstring is there)."""
        i = self._actor_row(body, "body")
        # checked first, written after: all or nothing. Plain floats in range (a game's
        # every-frame call) skip numpy
        if throttle is not None and not (type(throttle) is float and 0.0 <= throttle <= 1.0):
            throttle = check.scalar("throttle", throttle, minimum=0.0)
            if throttle > 1.0:
                raise ValueError(f"throttle = {throttle}: must be in [0, 1]")
        turn = None if turn is None else self._command("turn", turn, (0, 1, 2))
        strafe = None if strafe is None else self._command("strafe", strafe, (1, 2))
        b = self.b
        if throttle is not None:
            rails = self.w._forces.rails
            if rails.active:
                was = b.throttle.item(i)
                if throttle > 0.0 and was == 0.0:
                    self.w._coasting.release(int(b.ids[i]))   # a thrusting ship: integrated
                elif throttle == 0.0 and was > 0.0:
                    rails.touch()                             # it may coast (coast="auto")
            b.throttle[i] = throttle
        if turn is not None:
            if self.w.dim == 2:
                b.turn[i, 2] = turn                  # 2D turns about z only
            else:
                b.turn[i] = turn
        if strafe is not None:
            if self.w.dim == 2:
                b.strafe[i, 1] = strafe              # 2D strafes along y only
            else:
                b.strafe[i] = strafe

    def controls(self, body):
        """World.controls (the docstring is there)."""
        i = self._actor_row(body, "body")
        b = self.b
        if self.w.dim == 2:
            return float(b.throttle[i]), float(b.turn[i, 2]), float(b.strafe[i, 1])
        return float(b.throttle[i]), b.turn[i].copy(), b.strafe[i, 1:].copy()

    def _command(self, name, value, axes):
        """A turn or strafe command in [-1, 1]: in 2D the number, in 3D the body-frame (3,)
        row of its len(axes) numbers."""
        if self.w.dim == 2:
            if not (type(value) is float and -1.0 <= value <= 1.0):
                value = check.scalar(name, value)
                if abs(value) > 1.0:
                    raise ValueError(f"{name} = {value!r}: must be in [-1, 1]")
            return value
        row = [0.0, 0.0, 0.0]
        v = check.floats(name, value, (len(axes),))
        if np.any(np.abs(v) > 1.0):
            raise ValueError(f"{name} = {value!r}: every component must be in [-1, 1]")
        for k, axis in enumerate(axes):
            row[axis] = float(v[k])
        return row

    def heading(self, body):
        """World.heading (the docstring is there)."""
        h = _rotate(self.orientation(body), np.array([1.0, 0.0, 0.0]))
        return float(math.atan2(h[1], h[0])) if self.w.dim == 2 else h

    def orientation(self, body):
        """World.orientation (the docstring is there)."""
        i = self._oriented_row(body)
        return np.array([1.0, 0.0, 0.0, 0.0]) if i < 0 else self.b.quat[i].copy()

    def set_heading(self, body, heading):
        """World.set_heading (the docstring is there)."""
        i = self.w.index_of(body, "body")
        _, q = _heading(self.w.dim, heading)
        i = self._rotor(i)
        self.b.quat[i] = q
        self.b.omega[i] = 0.0

    def angular_velocity(self, body):
        """World.angular_velocity (the docstring is there)."""
        i = self._oriented_row(body)
        if i < 0:
            return 0.0 if self.w.dim == 2 else np.zeros(3)
        w = self.b.omega[i]
        return float(w[2]) if self.w.dim == 2 else w.copy()

    def headings(self):
        """World.headings (the docstring is there)."""
        b, n, dim = self.b, self.b.n, self.w.dim
        out = np.full((n,) if dim == 2 else (n, 3), np.nan)
        if "actor" not in b.columns:
            return out
        rows = np.flatnonzero(b.actor[:n])
        w, x, y, z = b.quat[rows].T
        # R(q) (1, 0, 0): the first column of the rotation matrix
        hx, hy, hz = 1.0 - 2.0 * (y * y + z * z), 2.0 * (x * y + w * z), 2.0 * (x * z - w * y)
        if dim == 2:
            out[rows] = np.arctan2(hy, hx)
        else:
            out[rows] = np.stack([hx, hy, hz], axis=1)
        return out

    def spin_value(self, body, omega):
        """A checked angular velocity for set_body: body-frame (3,) (2D: about z); ValueError
        for an actor that turns arcade-style (its rate comes from its commands)."""
        if self.w.dim == 2:
            w = np.array([0.0, 0.0, check.scalar("angular_velocity", omega)])
        else:
            w = check.floats("angular_velocity", omega, (3,))
        i = self._oriented_row(body)
        if i >= 0 and not self.b.inertia.item(i) > 0.0:
            raise ValueError(f"angular_velocity of {body}: it turns at its turn_rate as "
                             f"commanded (arcade); give its spec a moment_of_inertia for "
                             f"physical rotation")
        return w

    def set_spin(self, i, omega):
        """Set the body-frame angular velocity (3,) of the body at row i (a rotor made if it
        has no orientation); returns its row."""
        i = self._rotor(i)
        self.b.omega[i] = omega
        return i

    def fuel(self, body):
        """World.fuel (the docstring is there)."""
        return float(self.b.fuel[self._actor_row(body, "body")])

    def set_fuel(self, body, fuel):
        """World.set_fuel (the docstring is there)."""
        i = self._actor_row(body, "body")
        fuel = check.scalar("fuel", fuel, minimum=0.0)
        b = self.b
        b.fuel[i] = fuel
        b.mass[i] = b.dry[i] + fuel
        b.flags[i] &= ~1
        self.w._invalidate()

    def delta_v(self, body):
        """World.delta_v (the docstring is there)."""
        i = self._actor_row(body, "body")
        b = self.b
        return float(b.exhaust[i] * math.log1p(b.fuel[i] / b.dry[i]))

    def engine(self, body):
        """World.engine (the docstring is there)."""
        i = self._actor_row(body, "body")
        return float(self.b.thrust[i]), float(self.b.exhaust[i])

    def is_ship(self, body):
        i = self.w.index_of(body, "id")
        return self.is_actor(i) and self.b.launcher.item(i) < 0

    def is_actor(self, i):
        """Whether the body at row i is a ship or missile."""
        b = self.b
        return "actor" in b.columns and b.actor.item(i) and \
            not b.flags.item(i) & control.FLAG_ROTOR

    def release(self):
        """Every ship's controls released (throttle, turn and strafe 0) and its plan cleared,
        missiles left as they are: what World.predict(coast=True) flies."""
        b = self.b
        if "actor" in b.columns:
            n = b.n
            ships = self._engines(np.flatnonzero(b.actor[:n] & (b.launcher[:n] < 0)))
            b.throttle[ships] = 0.0
            b.turn[ships] = 0.0
            b.strafe[ships] = 0.0
        if self.plans:
            self.plans = {}
            self.w._invalidate()

    # ------------------------------------------------------------ plans
    def plan(self, ship, burns):
        """World.plan (the docstring is there)."""
        new = plans.rows(self.w, ship, burns)
        self.w._forces.rails.touch()             # a coasting ship's burns end its coasting
        if new.shape[0]:
            self.plans[int(ship)] = new
        else:
            self.plans.pop(int(ship), None)
        self.w._invalidate()

    def check_step(self, step, field):
        """Refuse a step longer than the shortest gap between two burns of a plan (a step
        flies one burn)."""
        gap, ship = plans.min_gap(self.plans)
        if step > gap and ship in self.w:
            raise ValueError(f"{field} = {step}: longer than the {gap:g} between two burns of "
                             f"ship {ship}'s plan (a step flies one burn)")

    def planned(self, ship):
        """World.planned (the docstring is there)."""
        if not self.is_ship(ship):
            raise ValueError(f"ship = {ship}: not a ship")
        rows = self.plans.get(int(ship))
        return [] if rows is None else plans.burns_of(rows, self.w.dim)

    # ------------------------------------------------------------ missiles
    def launch(self, parent, spec, target=None, heading=None, category=None, mask=None,
               group=None):
        """World.launch (the docstring is there)."""
        if not isinstance(spec, MissileSpec):
            raise ValueError(f"spec = {spec!r}: must be a MissileSpec")
        given = {k: filter_value("launch:", k, v) for k, v in
                 (("category", category), ("mask", mask), ("group", group)) if v is not None}
        if given:
            spec = dataclasses.replace(spec, **given)
        p = self.w.index_of(parent, "parent")
        b = self.b
        if target is not None:
            self.w.index_of(target, "target")
        if spec.guidance != "none" and target is None:
            raise ValueError(f"guidance={spec.guidance!r} needs a target")
        if heading is None:
            if "actor" not in b.columns or not b.actor[p]:
                raise ValueError(f"parent = {parent} has no heading of its own: give heading "
                                 f"(or set_heading the parent)")
            q = b.quat[p].copy()
            h = _rotate(q, np.array([1.0, 0.0, 0.0]))
        else:
            h, q = _heading(self.w.dim, heading)
        h = h[:self.w.dim]
        ve = self._exhaust_speed(spec)
        m = spec.dry_mass + spec.fuel_mass
        is_ship = self.is_actor(p)
        if spec.recoil:
            room = (b.dry[p] if is_ship else b.mass[p]) - m
            if not room > 0.0:
                raise ValueError(f"recoil: the parent {parent} ({'dry ' if is_ship else ''}"
                                 f"mass {b.dry[p] if is_ship else b.mass[p]}) is not heavier "
                                 f"than the missile ({m})")
            if b.fixed[p]:
                raise ValueError(f"recoil: the parent {parent} is fixed and cannot recoil")
        self.w.add_kind(spec.kind)
        v_parent = b.vel[p, :self.w.dim].copy()
        pos = b.pos[p, :self.w.dim] + h * (b.radius[p] + spec.radius)
        vel = v_parent + spec.launch_speed * h
        t = self.w.t
        lifetime = spec.lifetime if math.isfinite(spec.lifetime) else None
        body = self._add_actor(spec, pos, vel, q, {
            "dry": spec.dry_mass, "fuel": spec.fuel_mass, "thrust": spec.max_thrust,
            "exhaust": ve, "turn_rate": spec.turn_rate, "throttle": 1.0,
            "guidance": GUIDANCE[spec.guidance], "nav": spec.nav_constant,
            "target": -1 if target is None else target, "launcher": parent,
            # never armed in the step it is launched in: it starts touching its launcher
            "burn_end": t + spec.burn_time,
            "armed_at": max(t + spec.arming_delay, np.nextafter(t, np.inf)),
            "fuse": spec.fuse_radius, "kill": spec.kill_target,
            "flags": 0 if spec.hits_launcher else control.FLAG_SPARES}, active=False,
            lifetime=lifetime)
        if spec.recoil:
            p = self.w.index_of(parent)
            M = b.mass[p] - m
            b.vel[p, :self.w.dim] = v_parent - (m / M) * spec.launch_speed * h
            if is_ship:
                b.dry[p] -= m
            b.mass[p] = M
            self.w._invalidate()
        ev = np.zeros(1, EVENT_DTYPE)[0]
        ev["kind"], ev["a"], ev["b"], ev["time"] = EV_LAUNCH, body, parent, t
        ev["x"], ev["y"] = pos[0], pos[1]
        if self.w.dim == 3:
            ev["z"] = pos[2]
        ev["speed"] = spec.launch_speed
        self.queued.append(ev)
        return body

    # ------------------------------------------------------------ lifetimes, explosions
    def set_lifetimes(self, ids, lifetime):
        if lifetime is None:
            return
        self._lifetime_columns()
        rows = self.w.index_of(ids)
        self.b.born[rows] = self.w.t
        self.b.expires[rows] = self.w.t + lifetime

    def set_explosions(self, rows, spec):
        """The bodies at rows throw out spec's debris when a collision or a detonation
        destroys them (False: they no longer do); returns whether the columns were laid out
        anew (the World's tables then go)."""
        b = self.b
        if spec is False:
            if "explosion" in b.columns:
                b.explosion[rows] = -1
            return False
        new = "explosion" not in b.columns
        shape, dtype, default = ACTOR_COLUMNS["explosion"]
        b.ensure_column("explosion", shape, dtype, default)
        b.explosion[rows] = self._explosion_index(spec)
        return new

    def engines_lit(self):
        """World.engines_lit (the docstring is there)."""
        b = self.b
        lit = np.zeros(b.n, bool)
        rows = self.engines()
        if rows.size:                      # (a World that never had one has no such columns)
            lit[rows] = (b.throttle[rows] > 0.0) & (b.fuel[rows] > 0.0)
        return lit

    def intensity(self):
        """World.intensity (the docstring is there)."""
        b = self.b
        if "expires" not in b.columns:
            return np.ones(b.n)
        born, expires = b.born[:b.n], b.expires[:b.n]
        with np.errstate(invalid="ignore", divide="ignore"):
            left = np.where(np.isinf(expires), 1.0, (expires - self.w.t) / (expires - born))
        return np.clip(left, 0.0, 1.0) ** b.fade[:b.n]

    def explode(self, body, spec=None):
        """World.explode (the docstring is there)."""
        i = self.w.index_of(body, "body")
        if spec is None:
            k = self.b.explosion[i] if "explosion" in self.b.columns else -1
            if k < 0:
                raise ValueError(f"body = {body} has no explosion: give an ExplosionSpec")
            spec = self.specs[k]
        elif not isinstance(spec, ExplosionSpec):
            raise ValueError(f"spec = {spec!r}: must be an ExplosionSpec")
        b = self.b
        blast = (spec, int(b.ids[i]), b.pos[i].copy(), b.vel[i].copy(), float(b.radius[i]))
        self.w.add_kind(spec.kind)
        self.w.remove(body)
        return self.spawn_debris([blast])[0]

    def spawn_debris(self, blasts):
        """Throw out the debris of every blast (spec, body id, pos (3,), vel (3,), radius) in
        one addition; each blast draws from an RNG seeded by the World's seed and the body's
        id, so an explosion is the same every run. Returns the debris ids, blast by blast."""
        if not blasts:
            return []
        d = self.w.dim
        direction, u = [], []
        rngs = seeds.blast_generators(self.seed, [blast[1] for blast in blasts])
        for (spec, _, _, _, _), rng in zip(blasts, rngs):   # each blast's own draws, in order
            direction.append(rng.normal(size=(spec.count, d)))
            u.append(rng.random((3, spec.count)))        # speed, offset, lifetime
        # then the arithmetic of every blast at once, element by element as for one
        specs = [blast[0] for blast in blasts]
        counts = np.array([spec.count for spec in specs])
        per = lambda values: np.repeat(np.asarray(values, float), counts)   # (K,) by blast
        direction, u = np.concatenate(direction), np.concatenate(u, axis=1)
        norm = np.linalg.norm(direction, axis=1)
        norm[norm == 0] = 1.0
        direction /= norm[:, None]
        root = np.sqrt if d == 2 else lambda x: libm.each("cbrt", x)
        speed = per([spec.speed for spec in specs]) * root(u[0])   # uniform over a disc
        offset = per([blast[4] for blast in blasts]) * root(u[1])  # / ball
        life = per([spec.lifetime for spec in specs]) * \
            (1.0 + per([spec.lifetime_spread for spec in specs]) * (2.0 * u[2] - 1.0))
        p3 = np.repeat(np.array([blast[2] for blast in blasts]), counts, axis=0)
        v3 = np.repeat(np.array([blast[3] for blast in blasts]), counts, axis=0)
        p3[:, :d] += offset[:, None] * direction
        v3[:, :d] += speed[:, None] * direction
        kind = np.repeat(np.array([self.w.add_kind(spec.kind) for spec in specs], np.int16),
                         counts)
        mass, radius, fade = (per([getattr(spec, a) for spec in specs])
                              for a in ("mass", "radius", "fade"))
        self._lifetime_columns()
        ids = self.b.add({"pos": p3, "vel": v3, "mass": mass, "radius": radius, "kind": kind,
                           "active": False, "fixed": False, "category": 1, "mask": -1,
                           "born": self.w.t, "expires": self.w.t + life, "fade": fade})
        self.w._invalidate()
        return np.split(ids, np.cumsum(counts)[:-1])

    def explode_dead(self, dead, events):
        """After a kernel call: the bodies destroyed (by a collision or a detonation) at rows
        `dead` that carry an ExplosionSpec, as (spec, id, pos, vel, radius) blasts, read
        before removal; events : that call's events."""
        b = self.b
        if "explosion" not in b.columns:
            return []
        died = set(events["a"][(events["kind"] == EV_DESTROY) |
                               (events["kind"] == EV_DETONATION)].tolist())
        died.update(events["b"][events["kind"] == EV_DETONATION].tolist())
        blasts = []
        for i in dead:
            if b.explosion[i] >= 0 and int(b.ids[i]) in died:
                blasts.append((self.specs[b.explosion[i]], int(b.ids[i]), b.pos[i].copy(),
                               b.vel[i].copy(), float(b.radius[i])))
        return blasts

    def merged(self, events):
        """A ship or missile that survived a merge carries the other body's mass as dry mass
        (the kernels keep its mass at dry + fuel)."""
        b = self.b
        merges = events["kind"] == EV_MERGE
        if "actor" not in b.columns or not merges.any():
            return
        survivors = b.lookup(events["a"][merges])
        for i in survivors[survivors >= 0]:
            if b.actor[i]:
                b.dry[i] = b.mass[i] - b.fuel[i]

    def owners(self):
        """(n,) int64: the launcher's row of each missile that ignores it in collisions (one
        not yet armed, or one that spares its launcher: MissileSpec.hits_launcher False), -1
        elsewhere (and for a launcher gone)."""
        b = self.b
        n = b.n
        owner = np.full(n, -1, np.int64)
        if "actor" in b.columns:
            actors = np.flatnonzero(b.actor[:n])
            ignores = (b.armed_at[actors] > self.w.t) | \
                (b.flags[actors] & control.FLAG_SPARES != 0)
            missiles = actors[(b.launcher[actors] >= 0) & ignores]
            owner[missiles] = b.lookup(b.launcher[missiles])
        return owner

    def rows(self):
        """(A,) int64 rows of the bodies with an orientation now alive: ships, missiles and
        rotors (the kernels turn them all)."""
        b = self.b
        if "actor" not in b.columns:
            return np.zeros(0, np.int64)
        return np.flatnonzero(b.actor[:b.n]).astype(np.int64)

    def engines(self):
        """(k,) int64 rows of the ships and missiles now alive."""
        return self._engines(self.rows())

    def any_of(self, rows):
        """Whether any of these rows is a ship or missile."""
        b = self.b
        return "actor" in b.columns and self._engines(np.asarray(rows)[b.actor[rows]]).size > 0

    def table(self, actors):
        """The kernels' Actors table for the bodies now alive (columns shared), or None when
        there are no actors and no lifetimes; actors = rows()."""
        b = self.b
        n = b.n
        has_actors = "actor" in b.columns
        has_life = "expires" in b.columns
        if not (has_actors or has_life):
            return None
        if has_actors:
            target = np.full(n, -1, np.int64)
            target[actors] = b.lookup(b.target[actors])
            cols = {name: getattr(b, name)[:n] for name in ACTOR_COLUMNS}
        else:
            target = np.zeros(0, np.int64)             # actors is empty too
            cols = _EMPTY
        expires = b.expires[:n] if has_life else _EMPTY["expires"]
        plan, planned = plans.table(self.plans, b.lookup, b.ids[actors])
        return control.make(cols, actors, target, self.curves, expires, self.w.dim, plan,
                            self.clock, planned)

    def write_queued(self, events, count):
        """Launches made since the last step open this step's events: written into events
        (E,) from row 0, count set; returns False when they do not fit (the caller grows
        the buffer and calls again)."""
        queued = self.queued
        if len(queued) > len(events):
            return False
        self.queued = []
        if queued:
            events[:len(queued)] = queued
        count[0] = len(queued)
        return True

    def shift(self, delta):
        """The origin moved by delta (dim,): launches not yet reported and the fixed points
        planned burns are taken about move with it."""
        for ev in self.queued:
            for c, name in enumerate("xyz"[:len(delta)]):
                ev[name] -= delta[c]
        for rows in self.plans.values():
            rows[:, 9:9 + len(delta)] -= delta

    # ------------------------------------------------------------ state
    def motion(self):
        """What moves with the tables kept (worldstate.Motion): the launches waiting for the
        next step."""
        return list(self.queued)

    def set_motion(self, queued):
        self.queued = list(queued)

    def snapshot(self):
        """What World.snapshot keeps of the actors: launches waiting, plans, explosion specs
        and thrust curves (copies where they are changed in place)."""
        queued = np.array(self.queued, EVENT_DTYPE).reshape(-1) if self.queued else None
        plans_ = {ship: rows.copy() for ship, rows in self.plans.items()} if self.plans \
            else None
        return queued, plans_, list(self.specs), self.curves

    def digest(self, h):
        """Feed what snapshot() keeps into hashlib's h (the bytes of the explosion specs and
        thrust curves are kept while they are the same)."""
        if self.queued:
            h.update(np.array(self.queued, EVENT_DTYPE).tobytes())
        if self.plans:
            for ship in sorted(self.plans):
                h.update(b"%d" % ship + self.plans[ship].tobytes())
        specs, count, curves, text = self._specs_hash
        # the list only grows; the curves are replaced, never changed in place
        if specs is not self.specs or count != len(specs) or curves is not self.curves:
            text = repr(self.specs).encode() + self.curves.tobytes()
            self._specs_hash = (self.specs, len(self.specs), self.curves, text)
        h.update(text)

    def restore(self, snap):
        queued, plans_, specs, self.curves = snap
        self.queued = [] if queued is None else list(queued.copy())
        self.plans = {} if plans_ is None else {k: v.copy() for k, v in plans_.items()}
        # the same specs keep their list, and so digest()'s hash of it (a rollback restores
        # and digests every frame)
        if len(specs) != len(self.specs) or any(map(operator.is_not, specs, self.specs)):
            self.specs = list(specs)

    def state(self):
        live = [rows for ship, rows in sorted(self.plans.items()) if ship in self.w]
        return {"seed": self.seed, "explosions": list(self.specs),
                "curves": self.curves.copy(),
                "queued": np.array(self.queued, EVENT_DTYPE).reshape(-1),
                "plans": np.concatenate(live) if live else np.zeros((0, plans.PLAN_WIDTH))}

    def load(self, s):
        self.seed = int(s["seed"])
        self.specs = list(s["explosions"])
        self.curves = np.array(s["curves"], np.float64).reshape(-1, 2)
        self.queued = list(upgrade(s["queued"]))
        rows = np.array(s.get("plans", np.zeros((0, plans.PLAN_WIDTH))), np.float64)
        rows = rows.reshape(-1, plans.PLAN_WIDTH)
        self.plans = {int(ship): rows[rows[:, 0] == ship] for ship in np.unique(rows[:, 0])}
