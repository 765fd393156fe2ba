"""Input checks shared by the public API: each error names the field and the offending value."""
import math
import numbers

import numpy as np


def _first_bad(name, arr, bad):
    idx = tuple(int(i) for i in np.argwhere(bad)[0])
    where = name + "".join(f"[{i}]" for i in idx)
    return where, arr[idx]


def floats(name, value, shape=None, *, minimum=None, positive=False):
    """value as a float64 array of the given shape (None entries match any length).

    Raises ValueError naming `name` for non-numbers, wrong shapes, NaN/inf, values below
    `minimum` or, with positive=True, values <= 0.
    """
    if type(value) is np.ndarray and value.dtype == np.float64:
        arr = value.copy()                  # the common case, checked below
    else:
        arr = _real(name, value)
    if shape is not None:
        ok = arr.ndim == len(shape) and all(s is None or s == a for s, a in zip(shape, arr.shape))
        if not ok:
            want = "(" + ", ".join("n" if s is None else str(s) for s in shape) + ("," if len(shape) == 1 else "") + ")"
            raise ValueError(f"{name} has shape {arr.shape}, expected {want}")
    if not np.isfinite(arr).all():
        where, v = _first_bad(name, arr, ~np.isfinite(arr))
        raise ValueError(f"{where} = {v}: must be finite (no NaN or inf)")
    if minimum is not None:
        bad = arr < minimum
        if bad.any():
            where, v = _first_bad(name, arr, bad)
            raise ValueError(f"{where} = {v}: must be >= {minimum}")
    if positive:
        bad = arr <= 0
        if bad.any():
            where, v = _first_bad(name, arr, bad)
            raise ValueError(f"{where} = {v}: must be > 0")
    return arr


def _real(name, value):
    """value as a new float64 array; ValueError for text, bools, complex numbers, objects
    (numpy would convert them silently)."""
    if isinstance(value, (str, bytes)):
        raise ValueError(f"{name} = {value!r}: expected a number, not text")
    try:
        raw = np.asarray(value)
        if raw.dtype.kind not in "iuf":
            raise TypeError
        return np.array(raw, dtype=np.float64)
    except (TypeError, ValueError, OverflowError):
        raise ValueError(f"{name} = {value!r}: expected real numbers") from None


def _plain(value, minimum, positive=False):
    """Whether value is a float that passes floats' checks as it is (the common case,
    checked without numpy)."""
    return type(value) is float and math.isfinite(value) and \
        (minimum is None or value >= minimum) and (not positive or value > 0.0)


def scalar(name, value, *, minimum=None, positive=False):
    """A finite float (see floats)."""
    if _plain(value, minimum, positive):
        return value
    if isinstance(value, np.ndarray) and value.ndim == 0:
        value = value[()]
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (numbers.Real, np.floating,
                                                                    np.integer)):
        raise ValueError(f"{name} = {value!r}: expected a real number")
    return float(floats(name, value, (), minimum=minimum, positive=positive))


_INT64_MAX = np.iinfo(np.int64).max


def count(name, value, *, minimum=0):
    """An integer >= minimum (bools refused)."""
    if isinstance(value, np.ndarray) and value.ndim == 0:
        value = value[()]
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (numbers.Integral, np.integer)):
        raise ValueError(f"{name} = {value!r}: expected an integer")
    if value < minimum:
        raise ValueError(f"{name} = {value}: must be >= {minimum}")
    if value > _INT64_MAX:              # kernels and files hold counts as int64
        raise ValueError(f"{name} = {value}: must be < 2**63")
    return int(value)


def per_body(name, value, k, *, minimum=None):
    """A scalar broadcast to k bodies or a (k,) array, checked as in floats."""
    if _plain(value, minimum):
        arr = np.empty(k)                   # (np.full's Python wrapper: 2 us of a query)
        arr.fill(value)
        return arr
    arr = floats(name, value, minimum=minimum)
    if arr.ndim == 0:
        return np.full(k, float(arr))
    if arr.shape != (k,):
        raise ValueError(f"{name} has shape {arr.shape}, expected a number or ({k},)")
    return arr
