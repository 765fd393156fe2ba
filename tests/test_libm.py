"""kernels/libm.py: elementary functions from + - * / and sqrt, the same bits on every CPU:
accurate against the C library, the Python twins bit for bit the kernels, the edge values
as math's."""
import math

import numpy as np
import pytest

from spacephys.kernels import libm

RNG = np.random.default_rng(20261205)
N = 4000


def _spread(lo, hi):
    """Arguments of both signs across magnitudes 10^lo .. 10^hi."""
    return (10.0 ** RNG.uniform(lo, hi, N) * RNG.choice([-1.0, 1.0], N)).tolist()


ANGLES = RNG.uniform(-7.0, 7.0, N).tolist() + _spread(-12, 5)
POSITIVE = (10.0 ** RNG.uniform(-300, 300, N)).tolist() + RNG.uniform(0.5, 2.0, N).tolist()
UNIT = RNG.uniform(-1.0, 1.0, N).tolist()

# name: (arguments, the most units in the last place measured off the C library's value)
CASES = {
    "sin": (ANGLES, 2), "cos": (ANGLES, 2), "tan": (ANGLES, 3),
    "exp": (RNG.uniform(-745.0, 709.0, N).tolist() + _spread(-12, 1), 1),
    "log": (POSITIVE, 1),
    "log1p": (RNG.uniform(-0.999, 3.0, N).tolist() + _spread(-15, -1), 1),
    "atan": (_spread(-12, 12), 2),
    "asin": (UNIT, 3), "acos": (UNIT, 3),
    "sinh": (RNG.uniform(-700.0, 700.0, N).tolist() + _spread(-12, 0), 2),
    "cosh": (RNG.uniform(-700.0, 700.0, N).tolist(), 2),
    "atanh": (RNG.uniform(-0.9999, 0.9999, N).tolist() + _spread(-12, -1), 3),
    "asinh": (_spread(-12, 12), 2),
    "cbrt": (POSITIVE + _spread(-12, 12), 3),
}


def _ulps(got, want):
    if got == want:
        return 0.0
    return abs(got - want) / math.ulp(want)


@pytest.mark.parametrize("name", CASES)
def test_within_a_few_ulps_of_the_c_library(name):
    args, most = CASES[name]
    fn, ref = getattr(libm, name), getattr(math, name)
    worst = max(_ulps(fn(x), ref(x)) for x in args)
    assert worst <= most, (name, worst)


def test_atan2_and_pow():
    y = (RNG.normal(size=N) * 10.0 ** RNG.uniform(-5, 5, N)).tolist()
    x = (RNG.normal(size=N) * 10.0 ** RNG.uniform(-5, 5, N)).tolist()
    assert max(_ulps(libm.atan2(a, b), math.atan2(a, b)) for a, b in zip(y, x)) <= 3
    base = RNG.uniform(1e-3, 1e3, N).tolist() + (10.0 ** RNG.uniform(-300, 300, N)).tolist()
    for p in (-2.0 / 3.0, 0.5, 1.0 / 7.0, 3.0, -7.5, 40.0):
        finite = [b for b in base if -690 < p * math.log(b) < 690]
        worst = max(_ulps(libm.pow(b, p), math.pow(b, p)) for b in finite)
        assert worst <= 2 + abs(p) / 2, (p, worst)


def test_large_angles_keep_accuracy_up_to_two_to_the_twenty_quarter_turns():
    x = RNG.uniform(1e5, 2.0 ** 20 * math.pi / 2, N).tolist()
    assert max(_ulps(libm.sin(v), math.sin(v)) for v in x) <= 2
    assert max(_ulps(libm.cos(v), math.cos(v)) for v in x) <= 2


@pytest.mark.parametrize("name", sorted(CASES) + ["atan2", "pow"])
def test_the_python_twin_gives_the_kernels_bits(name):
    """libm.py.<name> runs the kernel's source in Python: the same bits, huge, tiny and
    special arguments included (no compiling for Python callers)."""
    fn, twin = getattr(libm, name), getattr(libm.py, name)
    special = [0.0, -0.0, math.inf, -math.inf, math.nan, 1e300, -1e300, 5e-324, 1e22, 3e17]
    if name in ("atan2", "pow"):
        pairs = list(zip(POSITIVE[::9], ANGLES[::9])) + [(a, b) for a in special[:6]
                                                           for b in special[:6]]
        got = [(fn(a, b), twin(a, b)) for a, b in pairs]
    else:
        got = [(fn(v), twin(v)) for v in CASES[name][0][::5] + special]
    assert all(a.hex() == b.hex() or (a != a and b != b) for a, b in got), name


@pytest.mark.parametrize("name", ["sin", "cos", "tan", "exp", "log", "log1p", "atan", "asin",
                                  "acos", "sinh", "cosh", "atanh", "asinh", "cbrt"])
def test_edge_values_are_maths(name):
    fn, ref = getattr(libm, name), getattr(math, name)
    for v in (0.0, -0.0, 1.0, -1.0, math.inf, -math.inf, math.nan, 0.5, -0.5, 1e-310):
        try:
            want = ref(v)
        except (ValueError, OverflowError):
            want = {("log", -1.0): math.nan, ("log", -math.inf): math.nan,
                    ("log", 0.0): -math.inf, ("log", -0.0): -math.inf,
                    ("log1p", -1.0): -math.inf, ("log1p", -math.inf): math.nan,
                    ("atanh", 1.0): math.inf, ("atanh", -1.0): -math.inf,
                    ("asin", math.inf): math.nan, ("asin", -math.inf): math.nan,
                    ("acos", math.inf): math.nan, ("acos", -math.inf): math.nan,
                    ("atanh", math.inf): math.nan, ("atanh", -math.inf): math.nan,
                    }.get((name, v), math.nan)
        got = fn(v)
        if want != want:
            assert got != got, (name, v, got)
        else:
            assert _ulps(got, want) <= 3 and math.copysign(1, got) == math.copysign(1, want), \
                (name, v, got, want)


def test_arrays_give_each_elements_bits():
    x = np.array(ANGLES[:500]).reshape(20, 25)
    for name in libm.ARRAY:
        arg = np.abs(x) if name == "log" else (np.clip(x / 7, -1, 1) if name == "acos" else x)
        got = libm.each(name, arg)
        assert got.shape == x.shape
        fn = getattr(libm.py, name)
        assert [v.hex() for v in got.ravel().tolist()] == \
               [fn(v).hex() for v in arg.ravel().tolist()], name
