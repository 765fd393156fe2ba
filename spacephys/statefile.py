"""A World's state (World.state(): named fields) as an HDF5 group, and back.

The layout is the state's own: a dict is a group, an array a dataset, a number, text or a
bool an attribute (native HDF5 types: float64 attributes keep every bit), a list a group with
the attribute `__list__` (its length) and items named 0, 1, ..., an ExplosionSpec a group
with the attribute `__spec__`. docs/runlog.md lists every field. Nothing here knows what a
World is: world.py writes and reads the fields.
"""
import dataclasses

import numpy as np

from .entities import ExplosionSpec

_SPECS = {"ExplosionSpec": ExplosionSpec}


def write(group, state):
    """Write the dict `state` into the (empty) h5py group."""
    for key, value in state.items():
        _put(group, key, value)


def _put(group, name, value):
    if isinstance(value, np.ndarray):
        big = value.size >= 4096 and value.dtype.kind in "fiub"
        group.create_dataset(name, data=value, compression="gzip" if big else None,
                             compression_opts=1 if big else None, shuffle=big)
    elif isinstance(value, dict):
        sub = group.create_group(name)
        for key, item in value.items():
            _put(sub, key, item)
    elif isinstance(value, (list, tuple)):
        sub = group.create_group(name)
        sub.attrs["__list__"] = len(value)
        for k, item in enumerate(value):
            _put(sub, str(k), item)
    elif dataclasses.is_dataclass(value) and type(value).__name__ in _SPECS:
        sub = group.create_group(name)
        sub.attrs["__spec__"] = type(value).__name__
        for field in dataclasses.fields(value):
            _put(sub, field.name, getattr(value, field.name))
    elif isinstance(value, (bool, np.bool_)):
        group.attrs[name] = np.bool_(value)
    elif isinstance(value, (int, np.integer)):
        group.attrs[name] = np.int64(value)
    elif isinstance(value, (float, np.floating)):
        group.attrs[name] = np.float64(value)
    elif isinstance(value, str):
        group.attrs[name] = value
    elif value is None:
        group.attrs[name] = "__none__"
    else:
        raise TypeError(f"state field {name!r}: cannot store {type(value).__name__}")


def read(group):
    """The dict write() wrote into group."""
    out = {}
    for key, node in group.items():
        out[key] = _get(node)
    for key, value in group.attrs.items():
        if not key.startswith("__"):
            out[key] = _scalar(value)
    return out


def _scalar(value):
    if isinstance(value, bytes):
        value = value.decode()
    if isinstance(value, str):
        return None if value == "__none__" else value
    if isinstance(value, np.bool_):
        return bool(value)
    if isinstance(value, np.integer):
        return int(value)
    if isinstance(value, np.floating):
        return float(value)
    return value


def _get(node):
    if not hasattr(node, "keys"):                          # a dataset
        return node[()]
    if "__list__" in node.attrs:
        items = read(node)
        return [items[str(k)] for k in range(int(node.attrs["__list__"]))]
    if "__spec__" in node.attrs:
        kind = _scalar(node.attrs["__spec__"])
        return _SPECS[kind](**read(node))
    return read(node)
