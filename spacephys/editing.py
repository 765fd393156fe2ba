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
from .entities import Circles, ExplosionSpec
from .rails import elements as rails_elements
from .steppers import INEXTENSIBLE
from . import portable

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


# int64 columns that exist once a body gets a value other than 0 (a World without them pays
# nothing): the collision group (> 0: never meet each other) and the game's own tag
GROUP, TAG = "group", "tag"
OPTIONAL = {GROUP: 0, TAG: np.iinfo(np.int64).min}      # name -> the smallest value allowed
_NONE = np.zeros(0, np.int64)


def optional(w, name):
    """An optional column's live rows, shared, or (0,) while no body has a value (for the
    kernels: the collision pass's groups, the events' tags)."""
    b = w._b
    return getattr(b, name)[:b.n] if name in b.columns else _NONE


def column(w, name):
    """An optional column's live rows (zeros while no body has a value)."""
    b = w._b
    return getattr(b, name)[:b.n] if name in b.columns else np.zeros(b.n, np.int64)


def _optional(name, value, k):
    """A group or tag, or (k,) of them, as a (k,) int64 array."""
    arr = np.asarray(value)
    what = "an integer >= 0 (0: none)" if name == GROUP else "an integer (int64)"
    if arr.dtype.kind not in "iu" or arr.shape not in ((), (k,)):
        raise ValueError(f"{name} = {value!r}: must be {what} or {k} of them")
    low, high = OPTIONAL[name], np.iinfo(np.int64).max
    if arr.size and (arr.min() < low or arr.max() > high):
        bad = arr.min() if arr.min() < low else arr.max()
        raise ValueError(f"{name} = {int(bad)}: must be {what}")
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
             lifetime, explosion=None, tag=0, shape=None):
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
                            explosion=explosion, tag=tag, shape=shape)[0])


def _explosion(value, allow_false=False):
    """An ExplosionSpec, None (none given) or, where it clears one, False."""
    if value is None or isinstance(value, ExplosionSpec) or (allow_false and value is False):
        return value
    raise ValueError(f"explosion = {value!r}: expected an sp.ExplosionSpec"
                     + (", or False for none" if allow_false else ""))


# ---------------------------------------------------------------- compound shapes
SHAPE = "shape"               # the column: each body's shape in CollisionRules.shapes, -1 round


def check_shape(w, value, field="shape"):
    """A Circles for this World's dimension, or None."""
    if value is None:
        return None
    if not isinstance(value, Circles):
        raise ValueError(f"{field} = {value!r}: expected an sp.Circles(offsets, radii)")
    if value.dim != w._dim:
        raise ValueError(f"{field}: its offsets have {value.dim} coordinates in a "
                         f"{w._dim}D World")
    return value


def _shapes(w, value, k):
    """(k,) list of Circles or None from one Circles (every body) or k of them, or None."""
    if value is None:
        return None
    if isinstance(value, Circles):
        return [check_shape(w, value)] * k
    if not isinstance(value, (list, tuple)) or len(value) != k:
        raise ValueError(f"shape = {value!r}: expected an sp.Circles, or a list of {k} "
                         f"(Circles or None)")
    return [check_shape(w, v, f"shape[{q}]") for q, v in enumerate(value)]


def _shaped_radius(radius, shapes):
    """The radii with each compound body's the bounding radius of its shape (a radius given
    beside a shape is refused)."""
    radius = radius.copy()
    for q, c in enumerate(shapes):
        if c is not None:
            if radius[q] != 0.0:
                raise ValueError(f"radius[{q}] = {radius[q]} with a shape: a compound body's "
                                 f"radius is its shape's bounding radius ({c.bounding}); "
                                 f"leave radius out")
            radius[q] = c.bounding
    return radius


def give_shapes(w, ids, shapes):
    """Set checked shapes (Circles, or None for round) of bodies `ids`: the shape column,
    the radius (bounding) and an orientation for each compound body (a rotor unless it is an
    actor)."""
    if all(c is None for c in shapes) and SHAPE not in w._b.columns:
        return
    w._b.ensure_column(SHAPE, (), np.int64, -1)
    known = len(w._collisions.shapes)
    for body, c in zip(ids, shapes):
        i = w.index_of(int(body))
        w._b.shape[i] = -1 if c is None else w._collisions.shape_code(c)
        if c is not None:
            w._b.radius[i] = c.bounding
            w._actors.orient(i)
    if len(w._collisions.shapes) != known:
        # the shape table is part of the setup snapshots share (worldstate.Setup): a new
        # shape makes the next snapshot take it again, or a restore would put back a table
        # without it under bodies whose shape column names it
        w._set_up()
    w._invalidate()


def shape_of(w, body):
    """World.shape."""
    i = w.index_of(body, "body")
    b = w._b
    if SHAPE not in b.columns or b.shape[i] < 0:
        return None
    return w._collisions.shapes[b.shape[i]]


def circles(w, body):
    """World.circles."""
    b, n, dim = w._b, w._b.n, w._dim
    quat = b.quat[:n] if "quat" in b.columns else np.zeros((n, 4))
    shape = b.shape[:n] if SHAPE in b.columns else np.full(n, -1, np.int64)
    if body is None:
        rows, k, centres, radii = w._collisions.world_circles(shape, b.pos[:n], quat)
        return b.ids[rows].copy(), k, centres[:, :dim], radii
    i = w.index_of(body, "body")
    if shape[i] < 0:
        return b.pos[i, :dim][None].copy(), np.array([b.radius[i]])
    _, _, centres, radii = w._collisions.world_circles(shape, b.pos[:n], quat, [i])
    return centres[:, :dim], radii


def add_bodies(w, mass, pos, vel, radius, kind, active, fixed, category, mask, group,
               lifetime, explosion=None, tag=0, shape=None):
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
    optional = {GROUP: _optional(GROUP, group, k), TAG: _optional(TAG, tag, k)}
    explosion = _explosion(explosion)
    shapes = _shapes(w, shape, k)
    if shapes is not None:
        radius = _shaped_radius(radius, shapes)
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
    for name, values in optional.items():
        if values.any():
            w._b.ensure_column(name, (), np.int64, 0)
        if name in w._b.columns:
            columns[name] = values
    ids = w._b.add(columns)
    w._actors.set_lifetimes(ids, lifetime)
    if explosion is not None:
        w._actors.set_explosions(w.index_of(ids), explosion)
    if shapes is not None:
        give_shapes(w, ids, shapes)
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
             group=None, explosion=None, tag=None, angular_velocity=None, shape=None):
    """World.set_body (None: unchanged)."""
    i = w.index_of(body_id)
    if shape is not None and shape is not False:
        shape = check_shape(w, shape)
    if radius is not None and (shape not in (None, False) or (
            shape is None and shape_of(w, body_id) is not None)):
        raise ValueError(f"radius of {body_id}: a compound body's radius is its shape's "
                         f"bounding radius; set its shape (or shape=False, round)")
    rails = w._forces.rails
    entry = rails.entry(int(w._b.ids[i])) if pos is not None or vel is not None else None
    if entry is not None and not rails.coast[entry]:
        raise ValueError(f"pos/vel of {body_id}: it is on rails (its orbit places it); "
                         f"take it off with set_rails({body_id}, None) first")
    if mass is not None and w._actors.is_actor(i):
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
    for name, value in ((GROUP, group), (TAG, tag)):
        if value is not None:
            new[name] = _optional(name, value, 1)[0]
    explosion = _explosion(explosion, allow_false=True)
    if angular_velocity is not None:
        angular_velocity = w._actors.spin_value(body_id, angular_velocity)
    if entry is not None:                      # coasting: integrated from its new state
        w._coasting.release(int(w._b.ids[i]))
    b = w._b
    laid_out = False
    if explosion is not None:                  # checked above: it cannot fail now
        laid_out = w._actors.set_explosions(i, explosion)
        i = w.index_of(body_id)
    if angular_velocity is not None:
        i = w._actors.set_spin(i, angular_velocity)
        b = w._b
    if shape is not None:
        give_shapes(w, [body_id], [None if shape is False else shape])
        i = w.index_of(body_id)
        b = w._b
    for name in OPTIONAL:
        if name in new and name not in b.columns:
            if new[name]:
                b.ensure_column(name, (), np.int64, 0)
                laid_out = True                      # every column moved: new tables
            else:
                del new[name]                        # 0, as every body's is
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
    if laid_out or new.keys() - {"pos", "vel", "category", "mask", GROUP, TAG}:
        w._invalidate()          # the tables hold copies derived from these
    else:
        measures.rewatch(w)


def remove(w, ids):
    """World.remove."""
    rows = np.unique(np.atleast_1d(w.index_of(ids)))
    w._b.remove(rows)
    w._invalidate()


# ---------------------------------------------------------------- tethers
TETHER_DTYPE = np.dtype([("id", np.int64), ("a", np.int64), ("b", np.int64),
                         ("length", np.float64), ("stiffness", np.float64),
                         ("rigid", np.bool_), ("break_force", np.float64)])


def tether(w, a, b, length, stiffness, rigid, break_force):
    """World.tether: checked, then added; its id."""
    ia, ib = w.index_of(a, "a"), w.index_of(b, "b")
    if ia == ib:
        raise ValueError(f"a = b = {a}: a tether joins two bodies")
    stiffness = 0.0 if stiffness is None else \
        check.scalar("stiffness", stiffness, positive=True)
    if stiffness == 0.0 and w.integrator.startswith("wisdom_holman"):
        raise ValueError(f"stiffness = None with integrator {w.integrator!r}: {INEXTENSIBLE}")
    if not isinstance(rigid, (bool, np.bool_)):
        raise ValueError(f"rigid = {rigid!r}: must be True (a rod) or False (a rope)")
    b_ = w._b
    if length is None:
        length = portable.norm(b_.pos[ib] - b_.pos[ia])
    else:
        length = check.scalar("length", length, minimum=0.0)
    break_force = np.inf if break_force is None else \
        check.scalar("break_force", break_force, positive=True)
    for name, body, i in (("a", a, ia), ("b", b, ib)):
        if b_.mass[i] <= 0.0 and not b_.fixed[i]:
            raise ValueError(f"{name} = {body}: has mass 0, which a tether's force cannot "
                             f"move; give it mass, or fix it in place")
    k = w._forces.tether(int(b_.ids[ia]), int(b_.ids[ib]), length, stiffness, bool(rigid),
                         break_force)
    w._set_up()
    return k


def untether(w, k):
    """World.untether."""
    k = check.count("tether", k)
    keep = w._forces.tether_ids[:, 0] != k
    if keep.all():
        raise ValueError(f"tether = {k}: no such tether (live: "
                         f"{w._forces.tether_ids[:, 0].tolist()})")
    w._forces.untether(keep)
    w._set_up()


def tethers(w):
    """World.tethers: (T,) TETHER_DTYPE."""
    tether_rows(w)                              # the broken and the orphaned ones gone
    f = w._forces
    out = np.zeros(len(f.tether_ids), TETHER_DTYPE)
    for c, name in enumerate(("id", "a", "b")):
        out[name] = f.tether_ids[:, c]
    for c, name in enumerate(("length", "stiffness", "rigid", "break_force")):
        out[name] = f.tether_params[:, c]
    out["stiffness"][out["stiffness"] == 0.0] = np.inf       # inextensible
    return out


def tether_rows(w):
    """(T, 2) rows of the tethers' ends, the tethers of removed bodies and the broken ones
    dropped first (a change of the setup); None without tethers."""
    f = w._forces
    if not len(f.tether_ids):
        return None
    rows = w._b.lookup(f.tether_ids[:, 1:].ravel()).reshape(-1, 2)
    keep = (rows >= 0).all(axis=1) & ~f.broken()
    if not keep.all():
        f.untether(keep)
        f.built = None
        w._set_up()
        rows = rows[keep]
    return rows if len(rows) else None


# ---------------------------------------------------------------- rails
def set_rails(w, body, about, why_not=None, ephemeris=None, entry=None):
    """World.set_rails: checked, then done; nothing changes on refusal."""
    i = w.index_of(body, "id")
    rails = w._forces.rails
    if ephemeris is not None:
        _on_ephemeris(w, i, about, why_not, ephemeris, entry)
        return
    if about is None:
        rails.drop(int(w._b.ids[i]))
        w._set_up()              # (the rails are part of the setup snapshots share)
        w._invalidate()
        return
    p = w.index_of(about, "about")
    if p == i:
        raise ValueError(f"about = {about}: a body cannot be on rails about itself")
    body, about = int(w._b.ids[i]), int(w._b.ids[p])
    k = rails.entry(about)
    if k is not None and rails.coast[k]:
        raise ValueError(f"about = {about}: it coasts (World.coast), and no body is put on "
                         f"rails about a coasting body")
    up = about
    while up is not None:
        if up == body:
            raise ValueError(f"about = {about}: its rails lead back to {body} (a cycle)")
        up = rails.parent_of(up)
    if why_not:
        raise ValueError(f"id = {body}: {why_not}")
    b = w._b
    if w._actors.is_actor(i):
        raise ValueError(f"id = {body} is a ship or missile: it flies on its engines, not on "
                         f"rails")
    if b.fixed[i]:
        raise ValueError(f"id = {body} is fixed: it does not move, on rails or off them")
    mu = pair_mu(w, i, p)
    if not mu > 0.0:
        raise ValueError(f"about = {about}: it and the body have no mass (G m = {mu}): no "
                         f"orbit to put it on")
    r = b.pos[i] - b.pos[p]
    v = b.vel[i] - b.vel[p]
    try:
        orbit = rails_elements(r, v, mu, w.t)
    except ValueError as e:
        raise ValueError(f"id = {body} about {about}: {e}") from None
    rails.put(body, about, orbit)
    w._set_up()
    w._invalidate()


def pair_mu(w, i, p):
    """G m of the Kepler orbit of the body at row i about the body at row p: two free bodies'
    separation has G (m_p + m_i); about a fixed p, which no pull moves, G m_p."""
    b = w._b
    return w.G * (float(b.mass[p]) + (0.0 if b.fixed[p] else float(b.mass[i])))


def _on_ephemeris(w, i, about, why_not, ephemeris, entry):
    """set_rails(body, ephemeris=...): checked, then done."""
    from .ephemeris import Ephemeris
    body = int(w._b.ids[i])
    if not isinstance(ephemeris, Ephemeris):
        raise ValueError(f"ephemeris = {ephemeris!r}: expected an sp.Ephemeris")
    if about is not None:
        raise ValueError(f"about = {about} with an ephemeris: the ephemeris places the body")
    if why_not:
        raise ValueError(f"id = {body}: {why_not}")
    if w._actors.is_actor(i) or w._b.fixed[i]:
        raise ValueError(f"id = {body}: a ship, a missile or a fixed body cannot fly an "
                         f"ephemeris")
    row, coef = ephemeris.row(body if entry is None else entry)
    if not ephemeris.covers(w.t):
        raise ValueError(f"ephemeris: it covers {ephemeris.start} to {ephemeris.end}, not "
                         f"the World's time {w.t}")
    w._forces.rails.put_ephemeris(body, row, coef)
    w._set_up()
    w._invalidate()
