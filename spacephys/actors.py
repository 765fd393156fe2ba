"""Ships, missiles, explosions and lifetimes: the World methods that make a space game.

Mixed into World (world.py). An actor is a body with an engine: a ship (add_ship) or a missile
(launch). Its engine, controls and orientation live in extra per-body columns, created with the
first actor, so scenes without actors carry none of them. The kernels (kernels/control.py)
turn, thrust, burn fuel, guide and fuse every actor inside the step loop.
"""
import math

import numpy as np

from . import _validate as check
from .entities import G0_SI, GUIDANCE, ExplosionSpec, MissileSpec, ShipSpec
from .events import DESTROY, DETONATION, EVENT_DTYPE, LAUNCH, MERGE
from .kernels import control

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
        h = np.array([math.cos(angle), math.sin(angle), 0.0])
        return h, np.array([math.cos(angle / 2), 0.0, 0.0, math.sin(angle / 2)])
    v = check.floats("heading", heading, (dim,))
    norm = float(np.linalg.norm(v))
    if norm == 0.0:
        raise ValueError(f"heading = {v.tolist()}: a direction cannot be zero")
    h = np.concatenate([v, np.zeros(3 - dim)])
    if norm != 1.0:
        h /= norm
    if dim == 2:
        angle = math.atan2(h[1], h[0])
        return h, np.array([math.cos(angle / 2), 0.0, 0.0, math.sin(angle / 2)])
    if h[0] < -1.0 + 1e-15:
        return h, np.array([0.0, 0.0, 0.0, 1.0])            # straight back: half a turn about z
    q = np.array([1.0 + h[0], 0.0, -h[2], h[1]])           # half-way quaternion from x to h
    return h, q / np.linalg.norm(q)


def _rotate(q, v):
    w, x, y, z = q
    u = np.array([x, y, z])
    t = 2.0 * np.cross(u, v)
    return v + w * t + np.cross(u, t)


class Actors:
    """World methods for ships, missiles, explosions and lifetimes (see World)."""

    # ------------------------------------------------------------ columns
    def _actor_columns(self):
        for name, (shape, dtype, default) in ACTOR_COLUMNS.items():
            self._b.ensure_column(name, shape, dtype, default)

    def _lifetime_columns(self):
        for name, (shape, dtype, default) in LIFETIME_COLUMNS.items():
            self._b.ensure_column(name, shape, dtype, default)

    def _actor_row(self, body, field="id"):
        i = self.index_of(body, field)
        if "actor" not in self._b.columns or not self._b.actor[i]:
            raise ValueError(f"{field} = {body}: body is a {self._kinds[self._b.kind[i]]!r}, "
                             f"not a ship or missile")
        return i

    def _exhaust_speed(self, spec):
        if spec.exhaust_speed is not None:
            return spec.exhaust_speed
        if self.units.name != "si":
            raise ValueError(f"isp = {spec.isp} needs units='si' (standard gravity is "
                             f"{G0_SI} m/s^2); in units={self.units.name!r} give exhaust_speed")
        return spec.isp * G0_SI

    def _curve_rows(self, table):
        if table is None:
            return (0, 0)
        first = len(self._curves)
        self._curves = np.vstack([self._curves, table])
        return (first, len(table))

    def _explosion_index(self, spec):
        if spec is None:
            return -1
        for k, known in enumerate(self._explosion_specs):
            if known == spec:
                return k
        self._explosion_specs.append(spec)
        return len(self._explosion_specs) - 1

    # ------------------------------------------------------------ ships
    def add_ship(self, spec, pos, vel=None, heading=None):
        """Add a ship; returns its id.

        spec : ShipSpec; pos, vel : (dim,); heading : the direction the main engine pushes,
        an angle [rad] from +x (2D) or a vector (2D or 3D); default +x. It starts with full fuel, throttle
        0 and no turning."""
        if not isinstance(spec, ShipSpec):
            raise ValueError(f"spec = {spec!r}: must be a ShipSpec")
        _, q = _heading(self._dim, heading)
        ve = self._exhaust_speed(spec)
        self.add_kind(spec.kind)
        physical = spec.moment_of_inertia is not None
        return self._add_actor(spec, pos, vel, q, {
            "dry": spec.dry_mass, "fuel": spec.fuel_mass, "thrust": spec.max_thrust,
            "side": spec.side_thrust, "exhaust": ve,
            "turn_rate": 0.0 if physical else spec.turn_rate,
            "inertia": spec.moment_of_inertia if physical else 0.0,
            "torque": spec.torque}, active=spec.active)

    def _add_actor(self, spec, pos, vel, q, values, active, lifetime=None):
        """Validate pos/vel, then add the body and set its actor columns (all or nothing)."""
        pos = check.floats("pos", pos, (self._dim,))
        vel = np.zeros(self._dim) if vel is None else check.floats("vel", vel, (self._dim,))
        curve = self._curve_rows(spec.thrust_curve)       # only grows a table: harmless
        explosion = self._explosion_index(spec.explosion)
        self._actor_columns()
        if lifetime is not None:
            self._lifetime_columns()
        body = self.add_body(spec.dry_mass + spec.fuel_mass, pos, vel, radius=spec.radius,
                             kind=spec.kind, active=active)
        b = self._b
        i = self.index_of(body)
        b.actor[i] = True
        b.quat[i] = q
        b.curve[i] = curve
        b.explosion[i] = explosion
        for name, value in values.items():
            getattr(b, name)[i] = value
        if lifetime is not None:
            b.born[i] = self.t
            b.expires[i] = self.t + lifetime
        return body

    def control(self, body, *, throttle=None, turn=None, strafe=None):
        """Set a ship's (or missile's) controls, held until changed.

        throttle in [0, 1] of max_thrust; turn in [-1, 1]: 2D a number (+ counter-clockwise),
        3D (roll, pitch, yaw) about the body axes (x forward, y left, z up), fractions of
        turn_rate (arcade) or of torque (physical rotation); strafe in [-1, 1]: 2D a number
        (+ to the left of the heading), 3D (left, up), fractions of side_thrust. Guided
        missiles steer themselves and ignore turn."""
        i = self._actor_row(body, "body")
        new = {}
        if throttle is not None:
            t = check.scalar("throttle", throttle, minimum=0.0)
            if t > 1.0:
                raise ValueError(f"throttle = {t}: must be in [0, 1]")
            new["throttle"] = t
        for name, value, axes in (("turn", turn, (0, 1, 2)), ("strafe", strafe, (1, 2))):
            if value is None:
                continue
            if self._dim == 2:
                v = check.scalar(name, value)
                arr = np.zeros(3)
                arr[2 if name == "turn" else 1] = v
            else:
                v = check.floats(name, value, (len(axes),))
                arr = np.zeros(3)
                arr[list(axes)] = v
            bad = np.flatnonzero(np.abs(arr) > 1.0)
            if bad.size:
                raise ValueError(f"{name} = {value!r}: every component must be in [-1, 1]")
            new[name] = arr
        for name, value in new.items():
            getattr(self._b, name)[i] = value

    def heading(self, body):
        """Where the main engine points: an angle [rad] in (-pi, pi] in 2D, a unit (3,)
        vector in 3D."""
        q = self._b.quat[self._actor_row(body, "body")]
        h = _rotate(q, np.array([1.0, 0.0, 0.0]))
        return float(math.atan2(h[1], h[0])) if self._dim == 2 else h

    def orientation(self, body):
        """The unit quaternion (w, x, y, z) turning body axes (x forward, y left, z up) into
        world axes."""
        return self._b.quat[self._actor_row(body, "body")].copy()

    def set_heading(self, body, heading):
        """Point an actor: an angle [rad] (2D) or a vector; stops physical rotation."""
        i = self._actor_row(body, "body")
        _, q = _heading(self._dim, heading)
        self._b.quat[i] = q
        self._b.omega[i] = 0.0

    def angular_velocity(self, body):
        """Body-frame angular velocity [rad/time]: the z rate in 2D, (3,) in 3D (physical
        rotation; arcade turning has none between steps)."""
        w = self._b.omega[self._actor_row(body, "body")]
        return float(w[2]) if self._dim == 2 else w.copy()

    def fuel(self, body):
        """Fuel left [mass]."""
        return float(self._b.fuel[self._actor_row(body, "body")])

    def set_fuel(self, body, fuel):
        """Refuel (or drain) an actor; its mass becomes dry + fuel."""
        i = self._actor_row(body, "body")
        fuel = check.scalar("fuel", fuel, minimum=0.0)
        b = self._b
        b.fuel[i] = fuel
        b.mass[i] = b.dry[i] + fuel
        b.flags[i] &= ~1
        self._invalidate()

    def delta_v(self, body):
        """Speed change the fuel left can still give, ve ln((dry + fuel) / dry)
        (Tsiolkovsky) [length/time]."""
        i = self._actor_row(body, "body")
        b = self._b
        return float(b.exhaust[i] * math.log1p(b.fuel[i] / b.dry[i]))

    # ------------------------------------------------------------ missiles
    def launch(self, parent, spec, target=None, heading=None):
        """Launch a missile from any live body; returns its id.

        It appears just outside the parent (centres r_parent + r_missile apart) along the
        heading (default: the parent's own, if it is a ship), with the parent's velocity plus
        spec.launch_speed along the heading; with spec.recoil the parent gives up the
        missile's mass and takes the opposite momentum. target : an id to guide toward and
        fuse against. A launch event is reported with the next step's events."""
        if not isinstance(spec, MissileSpec):
            raise ValueError(f"spec = {spec!r}: must be a MissileSpec")
        p = self.index_of(parent, "parent")
        b = self._b
        if target is not None:
            self.index_of(target, "target")
        if spec.guidance != "none" and target is None:
            raise ValueError(f"guidance={spec.guidance!r} needs a target")
        if heading is None:
            if "actor" not in b.columns or not b.actor[p]:
                raise ValueError(f"parent = {parent} has no heading of its own: give heading")
            q = b.quat[p].copy()
            h = _rotate(q, np.array([1.0, 0.0, 0.0]))
        else:
            h, q = _heading(self._dim, heading)
        h = h[:self._dim]
        ve = self._exhaust_speed(spec)
        m = spec.dry_mass + spec.fuel_mass
        is_ship = "actor" in b.columns and b.actor[p]
        if spec.recoil:
            room = (b.dry[p] if is_ship else b.mass[p]) - m
            if not room > 0.0:
                raise ValueError(f"recoil: the parent {parent} ({'dry ' if is_ship else ''}"
                                 f"mass {b.dry[p] if is_ship else b.mass[p]}) is not heavier "
                                 f"than the missile ({m})")
            if b.fixed[p]:
                raise ValueError(f"recoil: the parent {parent} is fixed and cannot recoil")
        self.add_kind(spec.kind)
        v_parent = b.vel[p, :self._dim].copy()
        pos = b.pos[p, :self._dim] + h * (b.radius[p] + spec.radius)
        vel = v_parent + spec.launch_speed * h
        t = self.t
        lifetime = spec.lifetime if math.isfinite(spec.lifetime) else None
        body = self._add_actor(spec, pos, vel, q, {
            "dry": spec.dry_mass, "fuel": spec.fuel_mass, "thrust": spec.max_thrust,
            "exhaust": ve, "turn_rate": spec.turn_rate, "throttle": 1.0,
            "guidance": GUIDANCE[spec.guidance], "nav": spec.nav_constant,
            "target": -1 if target is None else target, "launcher": parent,
            # never armed in the step it is launched in: it starts touching its launcher
            "burn_end": t + spec.burn_time,
            "armed_at": max(t + spec.arming_delay, np.nextafter(t, np.inf)),
            "fuse": spec.fuse_radius, "kill": spec.kill_target}, active=False,
            lifetime=lifetime)
        if spec.recoil:
            p = self.index_of(parent)
            M = b.mass[p] - m
            b.vel[p, :self._dim] = v_parent - (m / M) * spec.launch_speed * h
            if is_ship:
                b.dry[p] -= m
            b.mass[p] = M
            self._invalidate()
        ev = np.zeros(1, EVENT_DTYPE)[0]
        ev["kind"], ev["a"], ev["b"], ev["time"] = LAUNCH, body, parent, t
        ev["x"], ev["y"] = pos[0], pos[1]
        if self._dim == 3:
            ev["z"] = pos[2]
        ev["speed"] = spec.launch_speed
        self._queued_events.append(ev)
        return body

    # ------------------------------------------------------------ lifetimes, explosions
    def _set_lifetimes(self, ids, lifetime):
        if lifetime is None:
            return
        self._lifetime_columns()
        rows = self.index_of(ids)
        self._b.born[rows] = self.t
        self._b.expires[rows] = self.t + lifetime

    @property
    def intensity(self):
        """(n,) float in [0, 1] for renderers: (1 - age/lifetime)^fade for bodies with a
        lifetime (debris fade out), 1 for the others."""
        b = self._b
        if "expires" not in b.columns:
            return np.ones(b.n)
        born, expires = b.born[:b.n], b.expires[:b.n]
        with np.errstate(invalid="ignore", divide="ignore"):
            left = np.where(np.isinf(expires), 1.0, (expires - self.t) / (expires - born))
        return np.clip(left, 0.0, 1.0) ** b.fade[:b.n]

    def explode(self, body, spec=None):
        """Remove a body and throw out its debris: spec, or the ExplosionSpec it was made
        with. Returns the (count,) ids of the debris."""
        i = self.index_of(body, "body")
        if spec is None:
            k = self._b.explosion[i] if "explosion" in self._b.columns else -1
            if k < 0:
                raise ValueError(f"body = {body} has no explosion: give an ExplosionSpec")
            spec = self._explosion_specs[k]
        elif not isinstance(spec, ExplosionSpec):
            raise ValueError(f"spec = {spec!r}: must be an ExplosionSpec")
        b = self._b
        blast = (spec, int(b.ids[i]), b.pos[i].copy(), b.vel[i].copy(), float(b.radius[i]))
        self.add_kind(spec.kind)
        self.remove(body)
        return self._spawn_debris([blast])[0]

    def _spawn_debris(self, blasts):
        """Throw out the debris of every blast (spec, body id, pos (3,), vel (3,), radius) in
        one addition; each blast draws from an RNG seeded by the World's seed and the body's
        id, so an explosion is the same every run. Returns the debris ids, blast by blast."""
        parts = []
        d = self._dim
        for spec, body_id, pos, vel, radius in blasts:
            k = spec.count
            rng = np.random.default_rng([self._seed, body_id & 0xFFFFFFFF, body_id >> 32])
            direction = rng.normal(size=(k, d))
            norm = np.linalg.norm(direction, axis=1)
            norm[norm == 0] = 1.0
            direction /= norm[:, None]
            speed = spec.speed * rng.random(k) ** (1.0 / d)      # uniform over a disc / ball
            offset = radius * rng.random(k) ** (1.0 / d)
            life = spec.lifetime * (1.0 + spec.lifetime_spread * (2.0 * rng.random(k) - 1.0))
            p3 = np.repeat(pos[None], k, axis=0)
            v3 = np.repeat(vel[None], k, axis=0)
            p3[:, :d] += offset[:, None] * direction
            v3[:, :d] += speed[:, None] * direction
            per = np.ones(k)
            parts.append((p3, v3, spec.mass * per, spec.radius * per,
                          np.full(k, self.add_kind(spec.kind), np.int16), life, spec.fade * per))
        if not parts:
            return []
        self._lifetime_columns()
        p3, v3, mass, radius, kind, life, fade = (np.concatenate(x) for x in zip(*parts))
        ids = self._b.add({"pos": p3, "vel": v3, "mass": mass, "radius": radius, "kind": kind,
                           "active": False, "fixed": False, "category": 1, "mask": -1,
                           "born": self.t, "expires": self.t + life, "fade": fade})
        self._invalidate()
        return np.split(ids, np.cumsum([len(x[0]) for x in parts])[:-1])

    def _explode_dead(self, setup, first_event):
        """After a kernel call: the bodies destroyed (by a collision or a detonation) that
        carry an ExplosionSpec, as (spec, id, pos, vel, radius) rows, read before removal."""
        b = self._b
        if "explosion" not in b.columns:
            return []
        events = self._event_box[0][first_event:self._event_count[0]]
        died = set(events["a"][(events["kind"] == DESTROY) |
                               (events["kind"] == DETONATION)].tolist())
        killed = events["b"][events["kind"] == DETONATION]
        died.update(killed.tolist())
        blasts = []
        dead = np.flatnonzero(~setup.alive)
        for i in dead:
            if b.explosion[i] >= 0 and int(b.ids[i]) in died:
                blasts.append((self._explosion_specs[b.explosion[i]], int(b.ids[i]),
                               b.pos[i].copy(), b.vel[i].copy(), float(b.radius[i])))
        return blasts

    def _merged_actors(self, first_event):
        """A ship or missile that survived a merge carries the other body's mass as dry mass
        (the kernels keep its mass at dry + fuel)."""
        b = self._b
        if "actor" not in b.columns:
            return
        events = self._event_box[0][first_event:self._event_count[0]]
        survivors = self._b.lookup(events["a"][events["kind"] == MERGE])
        for i in survivors[survivors >= 0]:
            if b.actor[i]:
                b.dry[i] = b.mass[i] - b.fuel[i]

    def _control_setup(self, setup):
        """The kernels' control.Control for the bodies now alive; sets setup.owner."""
        b = self._b
        n = b.n
        has_actors = "actor" in b.columns
        has_life = "expires" in b.columns
        if not (has_actors or has_life):
            return self._no_control()
        actors = np.flatnonzero(b.actor[:n]).astype(np.int64) if has_actors \
            else np.zeros(0, np.int64)
        if has_actors:
            target = np.full(n, -1, np.int64)
            target[actors] = self._b.lookup(b.target[actors])
            # a missile not yet armed ignores its launcher in collisions
            unarmed = actors[(b.launcher[actors] >= 0) & (b.armed_at[actors] > self.t)]
            setup.owner[unarmed] = self._b.lookup(b.launcher[unarmed])
            cols = {name: getattr(b, name)[:n] for name in ACTOR_COLUMNS}
        else:
            target = np.zeros(0, np.int64)
            cols = {name: _EMPTY[name] for name in ACTOR_COLUMNS}
        expires = b.expires[:n] if has_life else _EMPTY["expires"]
        return control.Control(
            actors.size > 0 or has_life, actors, cols["quat"], cols["omega"],
            cols["throttle"], cols["turn"], cols["strafe"], cols["dry"], cols["fuel"],
            cols["thrust"], cols["side"], cols["exhaust"], cols["turn_rate"], cols["inertia"],
            cols["torque"], cols["curve"], self._curves, cols["guidance"], cols["nav"], target,
            cols["burn_end"], cols["armed_at"], cols["fuse"], cols["kill"], cols["flags"],
            expires, self._dim)

    def _no_control(self):
        e = _EMPTY
        return control.Control(False, np.zeros(0, np.int64), e["quat"], e["omega"],
                               e["throttle"], e["turn"], e["strafe"], e["dry"], e["fuel"],
                               e["thrust"], e["side"], e["exhaust"], e["turn_rate"],
                               e["inertia"], e["torque"], e["curve"], self._curves,
                               e["guidance"], e["nav"], np.zeros(0, np.int64), e["burn_end"],
                               e["armed_at"], e["fuse"], e["kill"], e["flags"], e["expires"],
                               self._dim)
