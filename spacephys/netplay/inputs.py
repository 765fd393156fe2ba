"""One player's input for one frame: the control() and launch() calls it makes, in order,
encoded in a few bytes each (what peers send each other), and applied to a World.

A call is a header (its op, the body, and a bit per optional number saying it is given)
followed by the given numbers as float64: as given, so the peer applies the very same bits
(a control of throttle and a 2D turn: 26 bytes). A launch names its MissileSpec by its index
in the session's `specs`, which both peers hold.
"""
import struct

import numpy as np

_C = struct.Struct("<BqB")              # op, body, which of throttle, turn x3, strafe x2
_L = struct.Struct("<BqBqB")            # op, parent, spec, target (-1: none), which of heading x3
_F = struct.Struct("<d")
_OPS = {b"C"[0]: ("control", _C, 6), b"L"[0]: ("launch", _L, 3)}
_COUNT = struct.Struct("<H")
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
        values = [None if throttle is None else _floats("throttle", throttle, 1)[0]]
        values += _floats("turn", turn, 3) + _floats("strafe", strafe, 2)
        mask, numbers = _packed(values)
        self._add(_C.pack(b"C"[0], _id("body", body), mask) + numbers)

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
        mask, numbers = _packed(_floats("heading", heading, 3))
        self._add(_L.pack(b"L"[0], _id("parent", parent), k,
                          -1 if target is None else _id("target", target), mask) + numbers)

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
            if op not in _OPS:
                raise ValueError(f"input: call {len(out.calls)} is malformed")
            _, head, most = _OPS[op]
            if at + head.size > len(data):
                raise ValueError(f"input: call {len(out.calls)} is malformed")
            mask = data[at + head.size - 1]
            if mask >> most:
                raise ValueError(f"input: call {len(out.calls)} is malformed")
            size = head.size + 8 * bin(mask).count("1")
            if at + size > len(data):
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
            name, head, most = _OPS[c[0]]
            fields = head.unpack_from(c)
            values = _unpacked(fields[-1], c[head.size:], most)
            try:
                if name == "control":
                    world.control(fields[1], throttle=values[0],
                                  turn=_vector(world.dim, values[1:4]),
                                  strafe=_vector(world.dim, values[4:6]))
                else:
                    heading = None if values[0] is None else \
                        tuple(v for v in values if v is not None)
                    world.launch(fields[1], self.specs[fields[2]],
                                 None if fields[3] < 0 else fields[3], heading)
            except ValueError:
                refused += 1
        return refused

    def __eq__(self, other):
        return isinstance(other, Inputs) and self.calls == other.calls

    def __repr__(self):
        return f"Inputs({len(self.calls)} calls: {', '.join(_OPS[c[0]][0] for c in self.calls)})"


def _id(field, value):
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < 0:
        raise ValueError(f"{field} = {value!r}: must be a body id")
    return int(value)


def _floats(field, value, k):
    """value (None, a number or up to k numbers) as a list of k floats or None."""
    if value is None:
        return [None] * k
    v = np.atleast_1d(np.asarray(value, np.float64)).reshape(-1)
    if v.size > k or not np.all(np.isfinite(v)):
        raise ValueError(f"{field} = {value!r}: a number or up to {k} finite numbers")
    return v.tolist() + [None] * (k - v.size)


def _packed(values):
    """(a bit per value given, the given ones as float64 bytes)."""
    mask = sum(1 << i for i, v in enumerate(values) if v is not None)
    return mask, b"".join(_F.pack(v) for v in values if v is not None)


def _unpacked(mask, data, k):
    """The k values _packed gave (None where not given)."""
    out, at = [], 0
    for i in range(k):
        if mask >> i & 1:
            out.append(_F.unpack_from(data, at)[0])
            at += 8
        else:
            out.append(None)
    return out


def _vector(dim, values):
    """A control's turn/strafe back: None, a number (2D) or a tuple (3D)."""
    given = [v for v in values if v is not None]
    if not given:
        return None
    return given[0] if dim == 2 and len(given) == 1 else tuple(given)
