"""The journal: every call that changes a World, recorded by its run log and fed back by
replay. A recorded World's changing methods are wrapped by `attach`, its settable properties
by `journaled_setter`; a call's arguments are encoded as JSON (floats exact: json writes repr).
"""
import dataclasses
import functools

import numpy as np
from numba.core.registry import CPUDispatcher

from .entities import Circles, ExplosionSpec, MissileSpec, ShipSpec
from .plans import Burn

_SPECS = {"ShipSpec": ShipSpec, "MissileSpec": MissileSpec, "ExplosionSpec": ExplosionSpec,
          "Burn": Burn, "Circles": Circles}


def encode(value):
    """A call argument as JSON-able data."""
    if isinstance(value, np.ndarray):
        return {"__array__": value.tolist(), "dtype": value.dtype.str}
    if isinstance(value, np.generic):
        return value.item()
    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        return {"__spec__": type(value).__name__,
                "fields": {f.name: encode(getattr(value, f.name))
                           for f in dataclasses.fields(value)}}
    if type(value).__name__ == "Ephemeris":       # its polynomials, whole
        return {"__ephemeris__": {"ids": encode(value.ids), "start": value.start,
                                  "length": value.length, "coef": encode(value.coef),
                                  "dim": value.dim}}
    if isinstance(value, CPUDispatcher):          # a user force: by module and name
        return {"__function__": f"{value.py_func.__module__}:{value.py_func.__qualname__}"}
    if isinstance(value, (list, tuple)):
        return [encode(v) for v in value]
    if isinstance(value, dict):
        return {str(k): encode(v) for k, v in value.items()}
    return value


def decode(value):
    if isinstance(value, list):
        return [decode(v) for v in value]
    if isinstance(value, dict):
        if "__array__" in value:
            return np.array(value["__array__"], dtype=np.dtype(value["dtype"]))
        if "__spec__" in value:
            return _SPECS[value["__spec__"]](**{k: decode(v)
                                               for k, v in value["fields"].items()})
        if "__ephemeris__" in value:
            from .ephemeris import Ephemeris
            e = value["__ephemeris__"]
            return Ephemeris(decode(e["ids"]), e["start"], e["length"], decode(e["coef"]),
                             e["dim"])
        if "__function__" in value:
            from .forces import importable
            return importable(value["__function__"])
        return {k: decode(v) for k, v in value.items()}
    return value


def attach(world, log, names):
    """Record the calls `names` of `world` into `log` (None: stop recording). Each becomes
    an instance attribute shadowing the class's plain method, so a World that nothing
    records pays nothing per call; a recorded one records the outermost call only
    (advance() calling step() is one input)."""
    for name in names:
        world.__dict__.pop(name, None)
    if log is not None:
        for name in names:
            world.__dict__[name] = _recorded(world, log, name, getattr(type(world), name))


def _recorded(world, log, name, method):
    @functools.wraps(method)
    def call(*args, **kwargs):
        if log.depth:
            return method(world, *args, **kwargs)
        return log.call(world, name, method, args, kwargs)
    return call


def journaled_setter(name):
    """Wrap a property setter: an assignment (w.dt = 0.01) is journaled as the call
    "setattr" with the arguments [name, value]."""
    def wrap(fset):
        @functools.wraps(fset)
        def setter(self, value):
            log = self._log
            if log is None or log.depth:
                return fset(self, value)
            return log.call(self, "setattr", lambda w, _, v: fset(w, v), (name, value), {})
        return setter
    return wrap
