"""Editing a World's bodies: adding them (add_body, add_bodies), changing one (set_body),
removing them, finding them by id (index_of, contains, get), and the checks of their fields
(kind names or codes, flags, collision bits).

A part of World: World's methods of the same names delegate here, each function taking the
World first (World holds the defaults and the docstrings). It reads World's private attributes.
"""
from collections import namedtuple

import numpy as np

from . import _validate as check
from . import measures
from .entities import ExplosionSpec

# kinds whose bodies feel gravity but do not pull unless told to (active=True): their mass is
# for thrust and collisions, and their pull on planets would only cost time
PASSIVE_KINDS = ("ship", "missile", "debris")

Body = namedtuple("Body", "id pos vel mass radius kind active pulls")
Body.__doc__ = ("A copy of one body's state: id, pos/vel (dim,), mass, radius, kind name, "
                "active (may pull) and pulls (active and massive).")


def _bools(name, value, k):
    """None-free bool or (k,) bools as a (k,) array (no 0/1 ints: a typo guard)."""
    arr = np.asarray(value)
    if arr.dtype != np.bool_ or arr.shape not in ((), (k,)):
        raise ValueError(f"{name} = {value!r}: must be a bool or {k} bools")
    return np.broadcast_to(arr, (k,))


GROUP = "group"                       # the collision group column, there once a body has one
_NO_GROUP = np.zeros(0, np.int64)


def groups(w):
    """The collision pass's group column: (n,) int64 shared, or (0,) while no body has one."""
    b = w._b
    return b.group[:b.n] if GROUP in b.columns else _NO_GROUP


def _group(value, k):
    """A collision group or (k,) of them: ints >= 0, as a (k,) int64 array."""
    arr = np.asarray(value)
    if arr.dtype.kind not in "iu" or arr.shape not in ((), (k,)):
        raise ValueError(f"group = {value!r}: must be an integer >= 0 or {k} of them")
    if arr.size and (arr.min() < 0 or arr.max() > np.iinfo(np.int64).max):
        bad = arr.min() if arr.min() < 0 else arr.max()
        raise ValueError(f"group = {int(bad)}: a group is an integer >= 0 (0: none)")
    return np.broadcast_to(arr.astype(np.int64), (k,))


def _bits(name, value, k):
    """An int or (k,) ints fitting int64, as a (k,) int64 array."""
    arr = np.asarray(value)
    if arr.dtype.kind not in "iu" or arr.shape not in ((), (k,)):
        raise ValueError(f"{name} = {value!r}: must be an integer or {k} integers (bits)")
    if arr.dtype.kind == "u" and arr.size and arr.max() > np.iinfo(np.int64).max:
        raise ValueError(f"{name} = {value!r}: bits beyond 63 do not fit")
    return np.broadcast_to(arr.astype(np.int64), (k,))


def kind_codes(w, kind, k, field):
    """(k,) int16 codes of `kind`: one declared name or code for all k, or k of them;
    ValueError naming `field` (and the entry) otherwise."""
    if isinstance(kind, np.ndarray) and kind.ndim == 0:
        kind = kind.item()
    names = [kind] * k if isinstance(kind, (str, int, np.integer)) else list(kind)
    if len(names) != k:
        raise ValueError(f"{field} has {len(names)} entries, expected {k}")
    codes = np.empty(k, dtype=np.int16)
    for i, name in enumerate(names):
        label = field if isinstance(kind, (str, int, np.integer)) else f"{field}[{i}]"
        if isinstance(name, str):
            if name not in w._kinds:
                raise ValueError(f"{label} = {name!r} is not a declared kind; declared: "
                                 f"{', '.join(w._kinds)} (declare with add_kind)")
            codes[i] = w._kinds.index(name)
        elif isinstance(name, (int, np.integer)) and not isinstance(name, bool) \
                and 0 <= name < len(w._kinds):
            codes[i] = name
        else:
            raise ValueError(f"{label} = {name!r} is not a kind name or code")
    return codes


def add_body(w, mass, pos, vel, radius, kind, active, fixed, category, mask, group,
             lifetime, explosion=None):
    """World.add_body: the new body's int id."""
    pos = check.floats("pos", pos, (w._dim,))
    vel = np.zeros(w._dim) if vel is None else check.floats("vel", vel, (w._dim,))
    mass = check.scalar("mass", mass, minimum=0.0)
    radius = check.scalar("radius", radius, minimum=0.0)
    if active is not None and not isinstance(active, (bool, np.bool_)):
        raise ValueError(f"active = {active!r}: must be True, False or None")
    return int(w.add_bodies(mass, pos[None], vel[None], radius=radius, kind=kind,
                            active=active, fixed=fixed, category=category,
                            mask=mask, group=group, lifetime=lifetime,
                            explosion=explosion)[0])


def _explosion(value, allow_false=False):
    """An ExplosionSpec, None (none given) or, where it clears one, False."""
    if value is None or isinstance(value, ExplosionSpec) or (allow_false and value is False):
        return value
    raise ValueError(f"explosion = {value!r}: expected an sp.ExplosionSpec"
                     + (", or False for none" if allow_false else ""))


def add_bodies(w, mass, pos, vel, radius, kind, active, fixed, category, mask, group,
               lifetime, explosion=None):
    """World.add_bodies: the new bodies' (k,) int64 ids."""
    pos = check.floats("pos", pos, (None, w._dim))
    k = pos.shape[0]
    vel = np.zeros((k, w._dim)) if vel is None else check.floats("vel", vel, (k, w._dim))
    mass = check.per_body("mass", mass, k, minimum=0.0)
    radius = check.per_body("radius", radius, k, minimum=0.0)
    codes = kind_codes(w, kind, k, "kind")
    if active is None:
        passive_codes = [w._kinds.index(k) for k in PASSIVE_KINDS if k in w._kinds]
        act = ~np.isin(codes, passive_codes)
    else:
        act = _bools("active", active, k)
    still = _bools("fixed", fixed, k)
    category = _bits("category", category, k)
    mask = _bits("mask", mask, k)
    group = _group(group, k)
    explosion = _explosion(explosion)
    if lifetime is not None:
        lifetime = check.per_body("lifetime", lifetime, k, minimum=0.0)
        if np.any(lifetime == 0):
            raise ValueError(f"lifetime[{int(np.argmin(lifetime))}] = 0: must be > 0")
    p3 = np.zeros((k, 3))
    v3 = np.zeros((k, 3))
    p3[:, :w._dim] = pos
    v3[:, :w._dim] = np.where(still[:, None], 0.0, vel)    # a fixed body never moves
    columns = {"pos": p3, "vel": v3, "mass": mass, "radius": radius, "kind": codes,
               "active": act, "fixed": still, "category": category, "mask": mask}
    if group.any():
        w._b.ensure_column(GROUP, (), np.int64, 0)
    if GROUP in w._b.columns:
        columns[GROUP] = group
    ids = w._b.add(columns)
    w._actors.set_lifetimes(ids, lifetime)
    if explosion is not None:
        w._actors.set_explosions(w.index_of(ids), explosion)
    w._invalidate()
    return ids


def index_of(w, ids, field="id"):
    """Rows of live bodies in the views: int for an id, (k,) int64 for an array of ids."""
    if type(ids) is int:                          # the common case, without numpy
        row = w._b.row(ids)
        if row < 0:
            raise ValueError(f"{field} = {ids} names no live body (removed, or never "
                             f"created)")
        return row
    scalar = np.ndim(ids) == 0
    arr = np.atleast_1d(np.asarray(ids))
    if arr.size and arr.dtype.kind not in "iu":
        raise ValueError(f"{field} = {ids!r}: ids are integers")
    rows = w._b.lookup(arr.astype(np.int64))
    bad = np.flatnonzero(rows < 0)
    if bad.size:
        raise ValueError(f"{field} = {int(arr[bad[0]])} names no live body "
                         f"(removed, or never created)")
    return int(rows[0]) if scalar else rows


def contains(w, body_id):
    """Whether body_id is the id of a live body (False for anything not an id)."""
    if type(body_id) is int:
        return w._b.row(body_id) >= 0
    if isinstance(body_id, bool) or not isinstance(body_id, (int, np.integer)):
        return False
    if not 0 <= body_id <= np.iinfo(np.int64).max:
        return False
    return int(w._b.lookup([body_id])[0]) >= 0


def get(w, body_id):
    """World.get: a Body, copies of the body's state."""
    i = w.index_of(body_id)
    b = w._b
    return Body(int(b.ids[i]), b.pos[i, :w._dim].copy(), b.vel[i, :w._dim].copy(),
                float(b.mass[i]), float(b.radius[i]), w._kinds[b.kind[i]],
                bool(b.active[i]), bool(b.active[i] and b.mass[i] > 0))


def set_body(w, body_id, pos, vel, mass, radius, kind, active, fixed, category, mask,
             group=None, explosion=None):
    """World.set_body (None: unchanged)."""
    i = w.index_of(body_id)
    if mass is not None and "actor" in w._b.columns and w._b.actor[i]:
        raise ValueError(f"mass of {body_id}: a ship's or missile's mass is dry + fuel; "
                         f"use set_fuel")
    new = {}
    if pos is not None:
        new["pos"] = check.floats("pos", pos, (w._dim,))
    if vel is not None:
        new["vel"] = check.floats("vel", vel, (w._dim,))
    if mass is not None:
        new["mass"] = check.scalar("mass", mass, minimum=0.0)
    if radius is not None:
        new["radius"] = check.scalar("radius", radius, minimum=0.0)
    if kind is not None:
        new["kind"] = kind_codes(w, kind, 1, "kind")[0]
    for name, value in (("active", active), ("fixed", fixed)):
        if value is not None:
            if not isinstance(value, (bool, np.bool_)):
                raise ValueError(f"{name} = {value!r}: must be True or False")
            new[name] = value
    for name, value in (("category", category), ("mask", mask)):
        if value is not None:
            new[name] = _bits(name, value, 1)[0]
    if group is not None:
        new[GROUP] = _group(group, 1)[0]
    explosion = _explosion(explosion, allow_false=True)
    b = w._b
    laid_out = False
    if explosion is not None:                  # checked above: it cannot fail now
        laid_out = w._actors.set_explosions(i, explosion)
        i = w.index_of(body_id)
    if GROUP in new and GROUP not in b.columns:
        if new[GROUP]:
            b.ensure_column(GROUP, (), np.int64, 0)
            laid_out = True                          # every column moved: new tables
        else:
            del new[GROUP]                           # 0, as every body's is
    if new.get("fixed", b.fixed[i]):
        new["vel"] = np.zeros(w._dim)          # a fixed body never moves
    for name, value in new.items():
        col = getattr(b, name)
        if name in ("pos", "vel"):
            col[i, :w._dim] = value
        else:
            col[i] = value
    if "pos" in new:
        b.prev[i] = b.pos[i]
    # a jump in the state voids its rounding compensation
    for name, key in (("csx", "pos"), ("csv", "vel")):
        if key in new and name in b.columns:
            getattr(b, name)[i] = 0.0
    if laid_out or new.keys() - {"pos", "vel", "category", "mask", GROUP}:
        w._invalidate()          # the tables hold copies derived from these
    else:
        measures.rewatch(w)


def remove(w, ids):
    """World.remove."""
    rows = np.unique(np.atleast_1d(w.index_of(ids)))
    w._b.remove(rows)
    w._invalidate()
