"""ShipSpec, MissileSpec, ExplosionSpec: validated definitions of what World.add_ship,
World.launch and explosions create. Units are the World's (mass, length, time)."""
import math
from dataclasses import dataclass

import numpy as np

from . import _validate as check
from .kernels.codes import GUIDANCE

# what `import spacephys` re-exports: a new spec is public once it is listed here
__all__ = ["ShipSpec", "MissileSpec", "ExplosionSpec", "Circles", "GUIDANCE"]

G0_SI = 9.80665           # standard gravity [m/s^2]: exhaust speed = isp * G0 (SI units only)


def _positive(name, value):
    return check.scalar(name, value, positive=True)


def _nonneg(name, value):
    return check.scalar(name, value, minimum=0.0)


def _curve(value):
    """None, or a (k, 2) table of (speed, factor) rows with rising speeds and factors >= 0."""
    if value is None:
        return None
    table = check.floats("thrust_curve", value, (None, 2))
    if len(table) == 0:
        raise ValueError("thrust_curve is empty: give rows of (speed, factor), or None")
    if np.any(np.diff(table[:, 0]) <= 0):
        raise ValueError(f"thrust_curve speeds {table[:, 0].tolist()} must rise strictly")
    if np.any(table[:, 0] < 0) or np.any(table[:, 1] < 0):
        raise ValueError(f"thrust_curve = {table.tolist()}: speeds and factors must be >= 0")
    table.flags.writeable = False
    return table


def _exhaust(spec_name, exhaust_speed, isp):
    if (exhaust_speed is None) == (isp is None):
        raise ValueError(f"{spec_name}: give exactly one of exhaust_speed and isp "
                         f"(exhaust_speed={exhaust_speed!r}, isp={isp!r})")
    if exhaust_speed is not None:
        return _positive("exhaust_speed", exhaust_speed)
    return None      # from isp, in World units: resolved by World (needs units="si")


@dataclass(frozen=True)
class Circles:
    """A compound hitbox: circles (spheres in 3D) fixed in a body's frame, turning with its
    heading (World.add_body(..., shape=), ShipSpec(shape=)).

    offsets : (k, dim) the circles' centres in the body's frame [length] (x along the
    heading); radii : (k,) [length] > 0. Held as tuples (a Circles is immutable and
    hashable); `bounding` is the radius of the circle about the body's centre that holds them
    all (the body's radius, which the broad phase and the drawing of a round body use).
    """
    offsets: tuple
    radii: tuple

    def __post_init__(self):
        radii = check.floats("radii", self.radii).reshape(-1) if np.ndim(self.radii) < 2 \
            else check.floats("radii", self.radii, (None,))
        k = radii.size
        if k == 0:
            raise ValueError("radii = []: a compound shape needs at least one circle")
        bad = np.flatnonzero(~(radii > 0.0))
        if bad.size:
            raise ValueError(f"radii[{bad[0]}] = {radii[bad[0]]}: must be > 0")
        offsets = check.floats("offsets", self.offsets)
        if offsets.ndim != 2 or offsets.shape[0] != k or offsets.shape[1] not in (2, 3):
            raise ValueError(f"offsets has shape {offsets.shape}: expected ({k}, 2) or "
                             f"({k}, 3), a centre per radius")
        object.__setattr__(self, "offsets", tuple(tuple(float(x) for x in o) for o in offsets))
        object.__setattr__(self, "radii", tuple(float(r) for r in radii))

    @property
    def dim(self):
        """2 or 3: the number of coordinates of each offset."""
        return len(self.offsets[0])

    @property
    def bounding(self):
        """The radius of the circle about the body's centre that holds every circle [length]
        (the body's radius)."""
        o = np.array(self.offsets)
        return float(np.max(np.sqrt((o * o).sum(axis=1)) + np.array(self.radii)))

    def rows(self):
        """(k, 4) float64: x, y, z offsets and radius of each circle (z 0 in 2D)."""
        out = np.zeros((len(self.radii), 4))
        out[:, :self.dim] = self.offsets
        out[:, 3] = self.radii
        return out

    def gyration(self):
        """k^2 [length^2]: the moment of inertia per unit mass about the body's centre, the
        mass spread evenly over the circles' areas (2D: discs, r^2/2 each) or volumes
        (3D: balls, 2 r^2/5), with the parallel-axis term of each offset."""
        rows = self.rows()
        r = rows[:, 3]
        weight = r * r if self.dim == 2 else r * r * r
        own = 0.5 * r * r if self.dim == 2 else 0.4 * r * r
        arm = (rows[:, :3] ** 2).sum(axis=1)
        return float((weight * (own + arm)).sum() / weight.sum())


@dataclass(frozen=True)
class ExplosionSpec:
    """Debris thrown out when a body explodes (the particle system of Laird & Jamin, *Basic Game
    Physics*).

    count : particles; speed : largest speed relative to the exploding body [length/time]
    (directions uniform, speeds filling a disc in 2D, a ball in 3D); lifetime [time], each
    particle's lifetime spread uniformly by +-lifetime_spread of it; radius [length] and mass
    [mass] of each particle (mass 0: test particles that feel gravity and pull nothing);
    kind : the kind of the particles (collide them with set_collision, e.g. "destroy_a"
    against planets to remove them on impact); fade : intensity = (1 - age/lifetime)^fade.
    """
    count: int = 64
    speed: float = 1.0
    lifetime: float = 1.0
    lifetime_spread: float = 0.0
    radius: float = 0.0
    mass: float = 0.0
    kind: str = "debris"
    fade: float = 1.0

    def __post_init__(self):
        object.__setattr__(self, "count", check.count("count", self.count))
        for name in ("speed", "radius", "mass", "fade"):
            object.__setattr__(self, name, _nonneg(name, getattr(self, name)))
        object.__setattr__(self, "lifetime", _positive("lifetime", self.lifetime))
        spread = _nonneg("lifetime_spread", self.lifetime_spread)
        if spread >= 1.0:
            raise ValueError(f"lifetime_spread = {spread}: must be < 1 (a fraction of lifetime)")
        object.__setattr__(self, "lifetime_spread", spread)
        if not isinstance(self.kind, str) or not self.kind:
            raise ValueError(f"kind = {self.kind!r}: must be a kind name")


@dataclass(frozen=True)
class ShipSpec:
    """A controllable ship.

    dry_mass [mass] > 0, fuel_mass [mass] >= 0 (the ship's mass is dry + fuel left);
    max_thrust [mass length/time^2] of the main engine, along the heading; exhaust_speed
    [length/time] or isp [s] (SI units only): mass flow = thrust / exhaust speed;
    side_thrust: the strafing thrusters (same exhaust speed); rotation either arcade,
    turn_rate [rad/time] at full command, or physical, moment_of_inertia [mass length^2] > 0
    and torque [mass length^2/time^2] (turn commands then set the angular acceleration);
    thrust_curve: rows (speed, factor), the acceleration_value(speed) of Laird & Jamin,
    *Basic Game Physics*: thrust = max_thrust * factor(|v|) * throttle, linear between rows,
    flat beyond;
    radius [length]; kind; active: pulls other bodies (default False: it feels gravity only);
    explosion: an ExplosionSpec thrown out when the ship is destroyed, or None; category,
    mask, group: its collision filter (World.add_body's); shape: an sp.Circles, its compound
    hitbox (radius then left out: the shape's bounding radius).
    """
    dry_mass: float = 1.0
    fuel_mass: float = 0.0
    max_thrust: float = 0.0
    exhaust_speed: float = None
    isp: float = None
    side_thrust: float = 0.0
    turn_rate: float = math.pi
    moment_of_inertia: float = None
    torque: float = 0.0
    thrust_curve: object = None
    radius: float = 0.0
    kind: str = "ship"
    active: bool = False
    explosion: ExplosionSpec = None
    category: int = 1
    mask: int = -1
    group: int = 0
    shape: Circles = None

    def __post_init__(self):
        _check_filter(self)
        if self.shape is not None:
            if not isinstance(self.shape, Circles):
                raise ValueError(f"shape = {self.shape!r}: expected an sp.Circles")
            if self.radius:
                raise ValueError(f"radius = {self.radius} with a shape: the ship's radius is "
                                 f"its shape's bounding radius; leave radius out")
        exhaust_given = self.exhaust_speed is not None or self.isp is not None
        _set_engine(self, "ShipSpec")
        object.__setattr__(self, "side_thrust", _nonneg("side_thrust", self.side_thrust))
        object.__setattr__(self, "turn_rate", _nonneg("turn_rate", self.turn_rate))
        if self.moment_of_inertia is not None:
            object.__setattr__(self, "moment_of_inertia",
                               _positive("moment_of_inertia", self.moment_of_inertia))
        object.__setattr__(self, "torque", _nonneg("torque", self.torque))
        if not isinstance(self.active, (bool, np.bool_)):
            raise ValueError(f"active = {self.active!r}: must be True or False")
        # an empty tank with an engine described is a ship to refuel (set_fuel)
        _refuse_dead_engine(self, "max_thrust" if self.max_thrust else "side_thrust",
                            self.max_thrust + self.side_thrust, empty_tank_ok=exhaust_given)
        if self.moment_of_inertia is not None and self.torque == 0.0:
            raise ValueError(f"moment_of_inertia = {self.moment_of_inertia} with torque = 0: "
                             f"the ship could never turn (physical rotation turns by torque); "
                             f"give torque > 0, or leave moment_of_inertia out to turn at "
                             f"turn_rate")


@dataclass(frozen=True)
class MissileSpec:
    """A missile, launched with World.launch from any moving body.

    mass (dry) [mass] > 0, fuel_mass, thrust, exhaust_speed or isp, thrust_curve: as for a
    ship (a missile burns at full throttle unless controlled); burn_time [time]: the motor
    stops after it (inf: when the fuel is gone); lifetime [time]: removed after it (an expiry
    event; inf: never); arming_delay [time]: until then it cannot hit its launcher and its
    fuse is off (never armed in the step it is launched in, where it touches its launcher); launch_speed [length/time] along the heading, added to the launcher's
    velocity; recoil: the launcher gives up the missile's mass and takes the opposite
    momentum (total momentum conserved), else it is unaffected; guidance "none", "pursuit"
    (turn toward the target) or "pn" (proportional navigation with nav_constant N);
    turn_rate [rad/time]; fuse_radius [length]: detonates when the closest approach to the
    target within a step comes this near (0: contact only, through the collision matrix);
    kill_target: a detonation destroys the target too; radius; kind; explosion; category,
    mask, group: its collision filter (World.add_body's; World.launch may set them per
    launch); hits_launcher: False (the default), it never meets the body that launched it,
    armed or not; True, it can once armed.
    """
    mass: float = 1.0
    fuel_mass: float = 0.0
    thrust: float = 0.0
    exhaust_speed: float = None
    isp: float = None
    burn_time: float = math.inf
    lifetime: float = math.inf
    arming_delay: float = 0.0
    launch_speed: float = 0.0
    recoil: bool = False
    guidance: str = "none"
    nav_constant: float = 4.0
    turn_rate: float = math.pi
    fuse_radius: float = 0.0
    kill_target: bool = True
    thrust_curve: object = None
    radius: float = 0.0
    kind: str = "missile"
    explosion: ExplosionSpec = None
    category: int = 1
    mask: int = -1
    group: int = 0
    hits_launcher: bool = False

    def __post_init__(self):
        _check_filter(self)
        object.__setattr__(self, "dry_mass", _positive("mass", self.mass))
        object.__setattr__(self, "max_thrust", self.thrust)
        _set_engine(self, "MissileSpec")
        for name in ("burn_time", "lifetime"):
            value = self.__dict__[name]
            if value != math.inf:
                value = _positive(name, value)
            object.__setattr__(self, name, float(value))
        for name in ("arming_delay", "launch_speed", "turn_rate", "fuse_radius"):
            object.__setattr__(self, name, _nonneg(name, getattr(self, name)))
        if not isinstance(self.guidance, str) or self.guidance not in GUIDANCE:
            raise ValueError(f"guidance={self.guidance!r} is not known; valid: "
                             f"{', '.join(GUIDANCE)}")
        nav = _positive("nav_constant", self.nav_constant)
        object.__setattr__(self, "nav_constant", nav)
        for name in ("recoil", "kill_target", "hits_launcher"):
            if not isinstance(getattr(self, name), (bool, np.bool_)):
                raise ValueError(f"{name} = {getattr(self, name)!r}: must be True or False")
        _refuse_dead_engine(self, "thrust", self.max_thrust, empty_tank_ok=False)
        if self.guidance != "none" and self.turn_rate == 0.0:
            raise ValueError(f"guidance = {self.guidance!r} with turn_rate = 0: the missile "
                             f"could never turn toward its target; give turn_rate > 0")
        if self.arming_delay > 0.0 and self.lifetime <= self.arming_delay:
            raise ValueError(f"lifetime = {self.lifetime} <= arming_delay = "
                             f"{self.arming_delay}: the missile would expire before it arms")


def filter_value(where, name, v):
    """category or mask (an integer of int64 bits) or group (an integer >= 0) as an int;
    ValueError naming `where` (a spec's class, a call) and the field."""
    if isinstance(v, (bool, np.bool_)) or not isinstance(v, (int, np.integer)) or \
            not (0 if name == "group" else -2 ** 63) <= v < 2 ** 63:
        what = "an integer >= 0 (0: none)" if name == "group" else \
            "an integer of collision bits (int64)"
        raise ValueError(f"{where} {name} = {v!r}: must be {what}")
    return int(v)


def _check_filter(spec):
    """A spec's category and mask (integers of int64 bits) and group (an integer >= 0)."""
    for name in ("category", "mask", "group"):
        object.__setattr__(spec, name, filter_value(type(spec).__name__, name,
                                                    getattr(spec, name)))


def _refuse_dead_engine(spec, name, thrust, empty_tank_ok):
    """An engine that could never push: thrust without fuel (unless empty_tank_ok), or a
    thrust curve that is 0 everywhere."""
    if thrust > 0.0 and spec.fuel_mass == 0.0 and not empty_tank_ok:
        raise ValueError(f"{name} = {getattr(spec, name)} with fuel_mass = 0: the engine burns "
                         f"fuel to push and would never fire; give fuel_mass > 0 and "
                         f"exhaust_speed (or isp)")
    if thrust > 0.0 and spec.thrust_curve is not None and not spec.thrust_curve[:, 1].any():
        raise ValueError(f"thrust_curve factors are all 0: the engine would never push "
                         f"({name} = {getattr(spec, name)})")


def _set_engine(spec, spec_name):
    """Check the fields ShipSpec and MissileSpec share: masses, engine, curve, size, kind."""
    dry = spec.dry_mass if spec_name == "ShipSpec" else spec.mass
    object.__setattr__(spec, "dry_mass", _positive("mass" if spec_name == "MissileSpec"
                                                   else "dry_mass", dry))
    object.__setattr__(spec, "fuel_mass", _nonneg("fuel_mass", spec.fuel_mass))
    name = "max_thrust" if spec_name == "ShipSpec" else "thrust"
    object.__setattr__(spec, "max_thrust", _nonneg(name, spec.max_thrust))
    if spec.isp is not None:
        object.__setattr__(spec, "isp", _positive("isp", spec.isp))
    if spec.exhaust_speed is None and spec.isp is None and spec.fuel_mass == 0.0:
        object.__setattr__(spec, "exhaust_speed", 1.0)  # no fuel: never burns, any value does
    _exhaust(spec_name, spec.exhaust_speed, spec.isp)
    if spec.exhaust_speed is not None:
        object.__setattr__(spec, "exhaust_speed", _positive("exhaust_speed", spec.exhaust_speed))
    object.__setattr__(spec, "thrust_curve", _curve(spec.thrust_curve))
    object.__setattr__(spec, "radius", _nonneg("radius", spec.radius))
    if not isinstance(spec.kind, str) or not spec.kind:
        raise ValueError(f"kind = {spec.kind!r}: must be a kind name")
    if spec.explosion is not None and not isinstance(spec.explosion, ExplosionSpec):
        raise ValueError(f"explosion = {spec.explosion!r}: must be an ExplosionSpec or None")
