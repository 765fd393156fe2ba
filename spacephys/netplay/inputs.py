"""One player's input for one frame: the control() and launch() calls it makes, in order,
encoded in a few bytes each (what peers send each other), and applied to a World.

Numbers go as float64 (as given: the peer applies the very same bits); a launch names its
MissileSpec by its index in the session's `specs`, which both peers hold.
"""
import math
import struct

import numpy as np

_OPS = {b"C"[0]: "control", b"L"[0]: "launch"}
_C = struct.Struct("<Bq6d")             # op, body, throttle, turn x3, strafe x2
_L = struct.Struct("<BqBq3d")           # op, parent, spec, target (-1: none), heading x3
_COUNT = struct.Struct("<H")
NONE = math.nan                         # a field not given (None) travels as NaN
MAX_CALLS = 64                          # calls one input may hold


class Inputs:
    """The calls of one player in one frame (see the module). Build with control() and
    launch(); `encode()` -> bytes, `Inputs.decode(bytes, specs)`; `apply(world)` makes the
    calls. Equal inputs encode to equal bytes."""

    __slots__ = ("specs", "calls")

    def __init__(self, specs=()):
        self.specs = tuple(specs)
        self.calls = []

    def control(self, body, *, throttle=None, turn=None, strafe=None):
        """World.control(body, throttle=, turn=, strafe=), checked when applied; turn and
        strafe: a number (2D) or (3,) / (2,) (3D)."""
        turn3 = _floats("turn", turn, 3)
        strafe2 = _floats("strafe", strafe, 2)
        thr = NONE if throttle is None else float(throttle)
        self._add(_C.pack(b"C"[0], _id("body", body), thr, *turn3, *strafe2))

    def launch(self, parent, spec, target=None, heading=None):
        """World.launch(parent, specs[spec], target, heading): spec is a MissileSpec of the
        session's specs, or its index."""
        if isinstance(spec, (int, np.integer)) and not isinstance(spec, bool):
            k = int(spec)
        else:
            k = self.specs.index(spec) if spec in self.specs else -1
        if not 0 <= k < len(self.specs):
            raise ValueError(f"spec = {spec!r}: not one of the session's {len(self.specs)} "
                             f"missile specs")
        heading3 = _floats("heading", heading, 3)
        self._add(_L.pack(b"L"[0], _id("parent", parent), k,
                          -1 if target is None else _id("target", target), *heading3))

    def _add(self, packed):
        if len(self.calls) >= MAX_CALLS:
            raise ValueError(f"an input holds at most {MAX_CALLS} calls")
        self.calls.append(packed)

    def held(self):
        """The same controls without the launches: what a peer guesses for a frame whose
        input has not arrived (controls are held; a launch happens once)."""
        guess = Inputs(self.specs)
        guess.calls = [c for c in self.calls if c[0] == b"C"[0]]
        return guess

    def encode(self):
        return _COUNT.pack(len(self.calls)) + b"".join(self.calls)

    @classmethod
    def decode(cls, data, specs=()):
        """Inputs from encode()'s bytes; ValueError for anything malformed."""
        data = bytes(data)
        if len(data) < 2:
            raise ValueError("input: shorter than its count")
        (count,), at = _COUNT.unpack_from(data), 2
        if count > MAX_CALLS:
            raise ValueError(f"input: {count} calls, more than {MAX_CALLS}")
        out = cls(specs)
        for _ in range(count):
            op = data[at] if at < len(data) else None
            size = _C.size if op == b"C"[0] else _L.size if op == b"L"[0] else None
            if size is None or at + size > len(data):
                raise ValueError(f"input: call {len(out.calls)} is malformed")
            if op == b"L"[0] and data[at + 9] >= len(specs):
                raise ValueError(f"input: launch of spec {data[at + 9]}, the session has "
                                 f"{len(specs)}")
            out.calls.append(data[at:at + size])
            at += size
        if at != len(data):
            raise ValueError(f"input: {len(data) - at} bytes past its calls")
        return out

    def apply(self, world):
        """Make the calls on world, in order. A call the World refuses (a ship that died
        meanwhile, a value out of range) is skipped on every peer alike; returns how many
        were refused."""
        refused = 0
        for c in self.calls:
            try:
                if c[0] == b"C"[0]:
                    _, body, thr, t0, t1, t2, s0, s1 = _C.unpack(c)
                    world.control(body, throttle=_back(thr),
                                  turn=_vector(world.dim, (t0, t1, t2), 3),
                                  strafe=_vector(world.dim, (s0, s1), 2))
                else:
                    _, parent, k, target, h0, h1, h2 = _L.unpack(c)
                    heading = None if math.isnan(h0) else (h0, h1, h2)[:world.dim]
                    world.launch(parent, self.specs[k], None if target < 0 else target,
                                 heading)
            except ValueError:
                refused += 1
        return refused

    def __eq__(self, other):
        return isinstance(other, Inputs) and self.calls == other.calls

    def __repr__(self):
        return f"Inputs({len(self.calls)} calls: {', '.join(_OPS[c[0]] for c in self.calls)})"


def _id(field, value):
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < 0:
        raise ValueError(f"{field} = {value!r}: must be a body id")
    return int(value)


def _floats(field, value, k):
    """value (None, a number or up to k numbers) as k floats, NaN-padded."""
    if value is None:
        return (NONE,) * k
    v = np.atleast_1d(np.asarray(value, np.float64)).reshape(-1)
    if v.size > k or not np.all(np.isfinite(v)):
        raise ValueError(f"{field} = {value!r}: a number or up to {k} finite numbers")
    return tuple(v.tolist()) + (NONE,) * (k - v.size)


def _back(x):
    return None if math.isnan(x) else x


def _vector(dim, values, k):
    """A control's turn/strafe back: None, a number (2D) or dim-1 / 3 numbers (3D)."""
    if math.isnan(values[0]):
        return None
    given = [v for v in values if not math.isnan(v)]
    return given[0] if dim == 2 and len(given) == 1 else tuple(given)
