"""Manoeuvre plans: `Burn`, what `World.plan` checks, the kernel's plan table, `hohmann`.

A ship with a plan is flown by the autopilot inside the step kernel (kernels/control.py):
while a burn covers a step it holds the heading along the burn's direction in the burn's
frame and thrusts at the burn's throttle from its start to its stop, to the exact time.
"""
import math
import warnings
from dataclasses import dataclass

import numpy as np

from . import _validate as check
from .forces import MUTUAL
from .kernels import libm
from .kernels.codes import BURN_DIRECTIONS, BURN_NORMAL, BURN_ANTINORMAL, BURN_VECTOR
from . import portable

# a plan row kept by World (Actors.plans) and in World.state(): ship id, start, stop, direction
# code, frame id (-1: the fixed point), throttle, vector (3,), fixed point (3,)
PLAN_WIDTH = 12


@dataclass(frozen=True)
class Burn:
    """A planned burn: from `start` [time, the World's clock] for `duration` [time], thrust at
    `throttle` (0, 1] of the ship's engine along `direction`: "prograde" | "retrograde" |
    "normal" | "antinormal" (3D) | "radial_in" | "radial_out", relative to the body `frame`
    (an id; None: the body pulling on the ship hardest when the plan is set, or the field's
    centre with gravity="central"), or a fixed vector (dim,) in the World's axes."""
    start: float
    duration: float
    direction: object = "prograde"
    frame: object = None
    throttle: float = 1.0

    def __post_init__(self):
        object.__setattr__(self, "start", check.scalar("start", self.start))
        object.__setattr__(self, "duration", check.scalar("duration", self.duration,
                                                          positive=True))
        if not math.isfinite(self.duration):
            raise ValueError(f"duration = {self.duration}: must be finite")
        throttle = check.scalar("throttle", self.throttle, positive=True)
        if throttle > 1.0:
            raise ValueError(f"throttle = {throttle}: must be in (0, 1]")
        object.__setattr__(self, "throttle", throttle)
        d = self.direction
        if isinstance(d, str):
            if d not in BURN_DIRECTIONS or d == "vector":
                names = ", ".join(k for k in BURN_DIRECTIONS if k != "vector")
                raise ValueError(f"direction = {d!r} is not known; valid: {names}, or a vector")
        else:
            v = check.floats("direction", d, (None,))
            if v.size not in (2, 3) or not np.any(v):
                raise ValueError(f"direction = {d!r}: a vector of 2 or 3 components, not zero")
            object.__setattr__(self, "direction", tuple(float(x) for x in v))
        f = self.frame
        if f is not None and (isinstance(f, bool) or not isinstance(f, (int, np.integer))):
            raise ValueError(f"frame = {f!r}: must be a body id or None")
        if f is not None:
            object.__setattr__(self, "frame", int(f))

    @property
    def stop(self):
        """start + duration [time]: when the burn ends."""
        return self.start + self.duration


def rows(world, ship, burns):
    """The checked plan rows (k, PLAN_WIDTH) of burns (a list of Burn) for `ship`; raises
    ValueError naming the burn and its field, nothing changed."""
    i = world.index_of(ship, "ship")
    if not world.is_ship(ship):
        raise ValueError(f"ship = {ship}: body {ship} ({world.kinds[world.kind[i]]}) is not a "
                         f"ship: only ships (add_ship) fly plans")
    if isinstance(burns, Burn) or not isinstance(burns, (list, tuple)):
        raise ValueError(f"burns = {burns!r}: must be a list of sp.Burn")
    out = np.zeros((len(burns), PLAN_WIDTH))
    dim = world.dim
    for k, burn in enumerate(burns):
        name = f"burns[{k}]"
        if not isinstance(burn, Burn):
            raise ValueError(f"{name} = {burn!r}: must be an sp.Burn")
        if burn.start < world.t:
            raise ValueError(f"{name}.start = {burn.start}: before now (t = {world.t})")
        row = out[k]
        row[0], row[1], row[2], row[5] = ship, burn.start, burn.stop, burn.throttle
        if isinstance(burn.direction, str):
            code = BURN_DIRECTIONS[burn.direction]
            if dim == 2 and code in (BURN_NORMAL, BURN_ANTINORMAL):
                raise ValueError(f"{name}.direction = {burn.direction!r}: out of the plane of "
                                 f"a 2D World")
            row[3] = code
            row[4:5], row[9:12] = _frame(world, ship, burn.frame, f"{name}.frame")
        else:
            v = np.asarray(burn.direction)
            if burn.frame is not None:
                raise ValueError(f"{name}.frame = {burn.frame}: a vector direction is in the "
                                 f"World's axes; a frame is for the named directions")
            if v.size != dim:
                raise ValueError(f"{name}.direction = {burn.direction}: {dim} components in "
                                 f"a {dim}D World")
            row[3], row[4] = BURN_VECTOR, -1
            row[6:6 + dim] = v / portable.norm(v)
        if k and burn.start < out[k - 1, 2] + world.dt:
            raise ValueError(f"{name}.start = {burn.start}: before burns[{k - 1}] has stopped "
                             f"(at {out[k - 1, 2]}) and one step (dt = {world.dt}) has "
                             f"passed: burns must be in order, a step apart (a step flies "
                             f"one burn)")
    return out


def _frame(world, ship, frame, field):
    """(frame id or -1, fixed point (3,)) of a burn's frame."""
    point = np.zeros(3)
    if frame is None:
        if world.gravity == "central":
            point[:world.dim] = world.central_pos
            return -1, point
        if world.gravity not in MUTUAL:
            return -1, point                     # at rest at the origin
        from .orbits import _parent
        try:
            frame = _parent(world, ship, None)[4]
        except ValueError:
            raise ValueError(f"{field} = None: no body pulls on ship {ship} to take the "
                             f"direction about; give a frame") from None
    j = world.index_of(frame, field)
    if world.ids[j] == ship:
        raise ValueError(f"{field} = {frame}: a ship does not burn relative to itself")
    return int(frame), point


def min_gap(plans):
    """(the shortest time between one burn's stop and the next one's start over every plan,
    ship id); (inf, None) with no two burns in a plan."""
    best, ship = math.inf, None
    for s, rows in plans.items():
        if rows.shape[0] > 1:
            gap = float(np.min(rows[1:, 1] - rows[:-1, 2]))
            if gap < best:
                best, ship = gap, s
    return best, ship


def table(plans, ids_to_rows, actor_ids):
    """(plan (P, 11), planned (A, 2)) for the kernel from plans {ship id: rows (k,
    PLAN_WIDTH)}: each actor's rows in turn, frame ids as rows now (ids_to_rows: -1 for a
    body gone, whose burns then take the fixed point, the origin, at rest); actor_ids (A,)
    int64. (None, None) when no actor has a plan: the kernels then compile no autopilot."""
    if not plans:             # (no Python loop over thousands of missiles: rebuilt each step)
        return None, None
    actor_ids = actor_ids.tolist()
    order = [plans[s] for s in actor_ids if s in plans]
    if not order:
        return None, None
    planned = np.zeros((len(actor_ids), 2), np.int64)
    allrows = np.concatenate(order)
    plan = np.empty((allrows.shape[0], 11))
    plan[:, :3] = allrows[:, 1:4]
    frames = allrows[:, 4].astype(np.int64)
    plan[:, 3] = np.where(frames >= 0, ids_to_rows(frames), -1)
    gone = (frames >= 0) & (plan[:, 3] < 0) & (allrows[:, 2] > 0)
    if gone.any():
        k = int(np.flatnonzero(gone)[0])
        warnings.warn(f"ship {int(allrows[k, 0])}: the frame of its burn at t = "
                      f"{allrows[k, 1]:g}, body {frames[k]}, is gone; the burn is now taken "
                      f"about the origin at rest", RuntimeWarning, stacklevel=4)
    plan[:, 4:] = allrows[:, 5:]
    first = 0
    for q, s in enumerate(actor_ids):
        if s in plans:
            planned[q] = first, plans[s].shape[0]
            first += plans[s].shape[0]
    return plan, planned


def burns_of(plan_rows, dim):
    """The Burns of plan rows (k, PLAN_WIDTH), frames as ids, vectors of dim components."""
    out = []
    for r in plan_rows:
        direction = next(k for k, v in BURN_DIRECTIONS.items() if v == int(r[3]))
        if direction == "vector":
            direction = tuple(r[6:6 + dim])
        out.append(Burn(float(r[1]), float(r[2] - r[1]), direction,
                        None if r[4] < 0 else int(r[4]), float(r[5])))
    return out


def hohmann(world, ship, radius, about=None, start=None):
    """The two burns (a list of Burn) of a Hohmann transfer of `ship` from its near-circular
    orbit about `about` (default: as World.elements) to a circular orbit of `radius`
    [length]: prograde going up, retrograde going down; finite burns sized by the ship's
    engine and mass (Tsiolkovsky; the second by the mass the first leaves), each centred on
    its impulse's time, half a transfer orbit apart. start: when the first burn starts
    [time], default now."""
    radius = check.scalar("radius", radius, positive=True)
    el = world.elements(ship, about)
    if el.e >= 1.0:
        raise ValueError(f"ship = {ship}: on an open orbit (e = {el.e:.3g}): no Hohmann "
                         f"transfer")
    mu, frame = el.mu, el.about
    i = world.index_of(ship, "ship")
    centre = world.central_pos if frame is None else world.pos[world.index_of(frame)]
    r1 = portable.norm(world.pos[i] - centre)
    if abs(radius - r1) <= 1e-9 * r1:
        raise ValueError(f"radius = {radius}: the ship is already there (r = {r1:.12g})")
    a_t = 0.5 * (r1 + radius)
    dv1 = abs(math.sqrt(mu * (2.0 / r1 - 1.0 / a_t)) - math.sqrt(mu / r1))
    dv2 = abs(math.sqrt(mu / radius) - math.sqrt(mu * (2.0 / radius - 1.0 / a_t)))
    transfer = math.pi * math.sqrt(a_t * a_t * a_t / mu)
    thrust, exhaust = world.engine(ship)
    if thrust <= 0.0:
        raise ValueError(f"ship = {ship}: its engine has no thrust")
    direction = "prograde" if radius > r1 else "retrograde"
    m = float(world.mass[i])
    durations = []
    for dv in (dv1, dv2):
        m_after = m * libm.py.exp(-dv / exhaust)
        durations.append((m - m_after) * exhaust / thrust)     # at full throttle
        m = m_after
    fuel = world.fuel(ship)
    if float(world.mass[i]) - m > fuel * (1.0 + 1e-12):
        raise ValueError(f"radius = {radius}: the transfer takes {float(world.mass[i]) - m:.6g} "
                         f"of fuel (delta-v {dv1 + dv2:.6g}); ship {ship} has {fuel:.6g}")
    t1 = world.t if start is None else check.scalar("start", start)
    centre2 = t1 + 0.5 * durations[0] + transfer
    return [Burn(t1, durations[0], direction, frame),
            Burn(centre2 - 0.5 * durations[1], durations[1], direction, frame)]
