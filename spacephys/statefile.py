"""A World's state (World.state(): named fields) as an HDF5 group, and back.

The layout is the state's own: a dict is a group, an array a dataset, a number, text or a
bool an attribute (native HDF5 types: float64 attributes keep every bit), a list a group with
the attribute `__list__` (its length) and items named 0, 1, ..., an ExplosionSpec a group
with the attribute `__spec__`. docs/runlog.md lists every field. Nothing here knows what a
World is: world.py writes and reads the fields.
"""
import dataclasses
import hashlib

import numpy as np

from .entities import ExplosionSpec

_SPECS = {"ExplosionSpec": ExplosionSpec}


def write(group, state):
    """Write the dict `state` into the (empty) h5py group, with its digest (the attribute
    __digest__: a damaged file is found when it is read, not run)."""
    for key, value in state.items():
        _put(group, key, value)
    group.attrs["__digest__"] = digest(state)


def digest(state):
    """SHA-256 (hex) of a state as stored: arrays by dtype, shape and bytes, numbers as
    int64 / float64, dict keys sorted; the same for the state written and the state read."""
    h = hashlib.sha256()
    _feed(h, state)
    return h.hexdigest()


def _feed(h, value):
    if isinstance(value, np.ndarray):
        a = np.ascontiguousarray(value)
        h.update(f"a{a.dtype.str}{a.shape}".encode())
        h.update(a.tobytes())
    elif isinstance(value, dict):
        h.update(f"d{len(value)}".encode())
        for key in sorted(value):
            h.update(f"k{key}".encode())
            _feed(h, value[key])
    elif isinstance(value, (list, tuple)):
        h.update(f"l{len(value)}".encode())
        for item in value:
            _feed(h, item)
    elif dataclasses.is_dataclass(value):
        _feed(h, {f.name: getattr(value, f.name) for f in dataclasses.fields(value)})
    elif isinstance(value, (bool, np.bool_)):
        h.update(b"b1" if value else b"b0")
    elif isinstance(value, (int, np.integer)):
        h.update(f"i{int(value)}".encode())
    elif isinstance(value, (float, np.floating)):
        h.update(f"f{float(value).hex()}".encode())
    elif value is None:
        h.update(b"n")
    else:
        h.update(f"s{value}".encode())


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
    """The dict write() wrote into group; ValueError if it does not match its digest."""
    out = _read(group)
    stored = group.attrs.get("__digest__")
    if stored is not None and _scalar(stored) != digest(out):
        raise ValueError(f"its contents do not match their digest (stored "
                         f"{_scalar(stored)[:12]}..., read {digest(out)[:12]}...)")
    return out


def _read(group):
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
    if not hasattr(node, "keys"):                          # a dataset (0-d ones too)
        return node[()] if node.shape != () else np.array(node[()])
    if "__list__" in node.attrs:
        items = _read(node)
        return [items[str(k)] for k in range(int(node.attrs["__list__"]))]
    if "__spec__" in node.attrs:
        kind = _scalar(node.attrs["__spec__"])
        return _SPECS[kind](**_read(node))
    return _read(node)
