"""A World's whole state as an HDF5 group, and back: checkpoints for bit-exact restarts.

Everything the World holds is written (bodies with every per-body column at full capacity,
the integrator's carried state such as Gauss-Radau's predictor, the collision matrix, the id
generations, time, counters, specs), nothing derived (cached index lists, scratch). The tree
is generic: a dict or object is a group whose attribute ``__type__`` says what it was, an
array a dataset, a scalar a JSON attribute (floats written with repr, so they round-trip
exactly). Any HDF5 tool can read it; see docs/runlog.md for the layout.
"""
import dataclasses
import json

import numpy as np

from .entities import ExplosionSpec
from .integrators import INTEGRATORS, Integrator
from .units import UnitSystem

_DATACLASSES = {"ExplosionSpec": ExplosionSpec, "UnitSystem": UnitSystem}
# derived caches and scratch: rebuilt on demand, never saved
_SKIP = {"_sources", "_jacobi", "_work", "_log"}


def _scalar(value):
    """A JSON text for a scalar leaf, tagged with its numpy type where it had one."""
    if isinstance(value, np.generic):
        return json.dumps({"np": value.dtype.str, "v": value.item()})
    if isinstance(value, type) and issubclass(value, np.generic):
        return json.dumps({"dtype": np.dtype(value).str})
    return json.dumps(value)


def _unscalar(text):
    value = json.loads(text)
    if isinstance(value, dict) and "np" in value:
        return np.dtype(value["np"]).type(value["v"])
    if isinstance(value, dict) and "dtype" in value:
        return np.dtype(value["dtype"]).type
    return value


def put(group, name, value):
    """Write value under group[name] (see the module)."""
    if isinstance(value, np.ndarray):
        big = value.size >= 4096
        group.create_dataset(name, data=value, compression="gzip" if big else None,
                             compression_opts=1 if big else None, shuffle=big)
        return
    if isinstance(value, Integrator):
        group.attrs[name] = json.dumps({"integrator": value.name})
        return
    if isinstance(value, np.void):                       # one record of a structured array
        sub = group.create_group(name)
        sub.attrs["__type__"] = "record"
        put(sub, "row", np.array([value], dtype=value.dtype))
        return
    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        sub = group.create_group(name)
        sub.attrs["__type__"] = "dataclass:" + type(value).__name__
        for field in dataclasses.fields(value):
            put(sub, field.name, getattr(value, field.name))
        return
    if isinstance(value, (list, tuple)):
        sub = group.create_group(name)
        sub.attrs["__type__"] = type(value).__name__
        sub.attrs["__len__"] = len(value)
        for k, item in enumerate(value):
            put(sub, str(k), item)
        return
    if isinstance(value, dict) or hasattr(value, "__dict__") and not isinstance(value, type):
        items = value if isinstance(value, dict) else value.__dict__
        sub = group.create_group(name)
        sub.attrs["__type__"] = "dict" if isinstance(value, dict) else "object:" + \
            type(value).__name__
        for key, item in items.items():
            if not isinstance(key, str):
                raise TypeError(f"cannot save a dict key {key!r} (not text)")
            if key not in _SKIP:
                put(sub, key, item)
        return
    try:
        group.attrs[name] = _scalar(value)
    except TypeError:
        raise TypeError(f"cannot save {name} = {value!r} ({type(value).__name__})") from None


def get(node, classes):
    """Read back what put wrote at node (a group or dataset); classes maps the names of
    plain objects (World, Bodies) to their classes."""
    if not hasattr(node, "attrs") or not hasattr(node, "keys"):    # a dataset
        return node[()]
    kind = node.attrs["__type__"]
    if isinstance(kind, bytes):
        kind = kind.decode()
    children = {key: get(node[key], classes) for key in node.keys()}
    children.update({key: _leaf(text) for key, text in node.attrs.items()
                     if not key.startswith("__")})
    if kind in ("list", "tuple"):
        items = [children[str(k)] for k in range(int(node.attrs["__len__"]))]
        return items if kind == "list" else tuple(items)
    if kind == "dict":
        return children
    if kind == "record":
        return children["row"][0]
    if kind.startswith("dataclass:"):
        return _DATACLASSES[kind.split(":", 1)[1]](**children)
    cls = classes[kind.split(":", 1)[1]]
    obj = cls.__new__(cls)
    obj.__dict__.update(children)
    return obj


def _leaf(text):
    value = _unscalar(text)
    if isinstance(value, dict) and "integrator" in value:
        return INTEGRATORS[value["integrator"]]
    return value


def save_world(group, world):
    """Write world's state into the (empty) h5py group."""
    state = world.__getstate__()
    group.attrs["__type__"] = "object:World"
    for key, value in state.items():
        if key not in _SKIP:
            put(group, key, value)


def load_world(group):
    """The World saved in group, ready to step on exactly as the saved one would."""
    from .state import Bodies
    from .world import World
    state = get(group, {"World": World, "Bodies": Bodies}).__dict__
    world = World.__new__(World)
    for key in _SKIP:
        state[key] = None
    world.__setstate__(state)
    return world
