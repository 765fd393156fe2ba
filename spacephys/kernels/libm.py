"""Elementary functions written with + - * /, sqrt and exact scaling alone, so that they give
the same bits on every CPU: the kernels and the code that builds a state call these, not
libm's or numpy's. (numpy picks its SIMD sin, cos, exp, log and power by the CPU's vector
width, AVX-512 or not; a C library picks variants with fused multiply-add by the CPU. Both
are accurate, neither is the same everywhere.) Kernels call the functions below; Python
code calls `py.sin` etc., the same source run by Python (the same operations in the same
order on the same doubles: the same bits, without compiling), and `each` on arrays.

Each is an argument reduction to a small interval, then a polynomial: Taylor's, to more
terms than a minimax polynomial would need, for coefficients anyone can check (1/k!,
1/(2k+1)). Measured against the C library (tests/test_libm.py): within 3 units in the last
place (pow: 2 + |y| / 2).
Accuracy holds for |x| < 2^20 pi/2 in sin, cos and tan (a three-part Cody-Waite
reduction); beyond, the results keep the same bits everywhere but lose accuracy.
"""
import math
import types

import numpy as np

from .._jit import kernel

# pi/2 as P1 + P2 + P3, P1 and P2 with 33 significant bits: n * P1 and n * P2 are exact
# for |n| < 2^20 (computed in 100-digit decimals)
_P1 = 1.5707963267341256
_P2 = 6.077100506303966e-11
_P3 = 2.0222662487959506e-21
_TWO_OVER_PI = 0.6366197723675814
_PI = 3.141592653589793
_PI_LO = 1.2246467991473532e-16       # pi - _PI
_PI_2 = 1.5707963267948966
_PI_2_LO = 6.123233995736766e-17      # pi/2 - _PI_2
_PI_4 = 0.7853981633974483
_PI_4_LO = 3.061616997868383e-17
# ln 2 as LN2_HI + LN2_LO, LN2_HI with 32 significant bits: n * LN2_HI exact for |n| < 2^21
_LN2_HI = 0.6931471803691238
_LN2_LO = 1.9082149292705877e-10
_INV_LN2 = 1.4426950408889634
_SQRT_HALF = 0.7071067811865476


# Taylor coefficients, highest power first (Horner's order): sin's -1/19!, 1/17!, ... -1/3!;
# cos's 1/20!, ... 1/4!; exp's 1/14!, ... 1/2!; atanh's 2/23, 2/21, ... 2/3; atan's -1/39,
# 1/37, ... -1/3 (each the double nearest the fraction, as the literal would be)
_SIN = (-1.0 / 121645100408832000.0, 1.0 / 355687428096000.0, -1.0 / 1307674368000.0,
        1.0 / 6227020800.0, -1.0 / 39916800.0, 1.0 / 362880.0, -1.0 / 5040.0, 1.0 / 120.0,
        -1.0 / 6.0)
_COS = (1.0 / 2432902008176640000.0, -1.0 / 6402373705728000.0, 1.0 / 20922789888000.0,
        -1.0 / 87178291200.0, 1.0 / 479001600.0, -1.0 / 3628800.0, 1.0 / 40320.0,
        -1.0 / 720.0, 1.0 / 24.0)
_EXP = (1.0 / 87178291200.0, 1.0 / 6227020800.0, 1.0 / 479001600.0, 1.0 / 39916800.0,
        1.0 / 3628800.0, 1.0 / 362880.0, 1.0 / 40320.0, 1.0 / 5040.0, 1.0 / 720.0,
        1.0 / 120.0, 1.0 / 24.0, 1.0 / 6.0, 0.5)
_ATANH = tuple(2.0 / k for k in range(23, 1, -2))
_ATAN = tuple((1.0 if k % 4 == 1 else -1.0) / k for k in range(39, 1, -2))


@kernel
def _horner(p, z, c):
    """p carried on through Horner's rule with the coefficients c (a tuple): p <- p z + c[i]
    for each in turn, the operations of the written-out chain in its order. (LLVM unrolls a
    run of 13 or fewer into that chain; atan's 18 go in two runs.)"""
    for i in range(len(c)):
        p = p * z + c[i]
    return p


@kernel
def _sin_poly(r):
    """sin r for |r| <= pi/4: r - r^3/3! + ... - r^19/19! (truncation below 1e-19 of r)."""
    z = r * r
    p = _horner(_SIN[0], z, _SIN[1:])
    return r + r * z * p


@kernel
def _cos_poly(r):
    """cos r for |r| <= pi/4: 1 - r^2/2 + ... + r^20/20!, the leading 1 - r^2/2 summed last
    so that its rounding is the result's only large one."""
    z = r * r
    p = _horner(_COS[0], z, _COS[1:])
    hz = 0.5 * z
    w = 1.0 - hz
    # 1 - hz rounds; its error (1 - w) - hz is added back with the tail
    return w + (((1.0 - w) - hz) + z * z * p)


@kernel
def _floor(t):
    """floor t as a double (t itself from 2^52 on, where every double is an integer: an
    int64 would overflow in a kernel and not in Python)."""
    if not abs(t) < 4503599627370496.0:
        return t
    return float(math.floor(t))


@kernel
def _reduce(x):
    """(n mod 4, r): x = n pi/2 + r, |r| <= pi/4 (a little more where n rounds)."""
    n = _floor(x * _TWO_OVER_PI + 0.5)
    r = ((x - n * _P1) - n * _P2) - n * _P3
    q = n - 4.0 * _floor(n * 0.25)
    return int(q), r


@kernel
def sin(x):
    """sin x [x in radians]."""
    if not math.isfinite(x):
        return x - x                          # nan for inf and nan
    if abs(x) < 1e-8:
        return x                              # x^3/6 is below half an ulp of x
    q, r = _reduce(x)
    if q == 0:
        return _sin_poly(r)
    if q == 1:
        return _cos_poly(r)
    if q == 2:
        return -_sin_poly(r)
    return -_cos_poly(r)


@kernel
def cos(x):
    """cos x [x in radians]."""
    if not math.isfinite(x):
        return x - x
    q, r = _reduce(x)
    if q == 0:
        return _cos_poly(r)
    if q == 1:
        return -_sin_poly(r)
    if q == 2:
        return -_cos_poly(r)
    return _sin_poly(r)


@kernel
def tan(x):
    """tan x [x in radians]: sin x / cos x from one reduction."""
    if not math.isfinite(x):
        return x - x
    if abs(x) < 1e-8:
        return x
    q, r = _reduce(x)
    s = _sin_poly(r)
    c = _cos_poly(r)
    return s / c if q % 2 == 0 else -c / s


@kernel
def exp(x):
    """e^x: x = n ln 2 + r, |r| <= ln 2 / 2; e^r by its series to r^14/14!; times 2^n."""
    if x != x:
        return x
    if x > 709.782712893384:
        return math.inf
    if x < -745.1332191019412:
        return 0.0
    n = math.floor(x * _INV_LN2 + 0.5)
    r = (x - n * _LN2_HI) - n * _LN2_LO
    p = _horner(_EXP[0], r, _EXP[1:])
    er = 1.0 + (r + r * r * p)
    return _scale(er, int(n))


@kernel
def _scale(y, n):
    """y 2^n, exactly (one rounding where the result is subnormal), in two steps so that
    no factor overflows."""
    if n > 1000:
        y *= 2.0 ** 1000
        n -= 1000
    elif n < -1000:
        y *= 2.0 ** -1000
        n += 1000
    return y * _pow2(n)


@kernel
def _pow2(n):
    """2^n for -1022 <= n <= 1023 (exactly; a power of two is a product of exact squares)."""
    r = 1.0
    b = 2.0 if n >= 0 else 0.5
    k = abs(n)
    while k:
        if k & 1:
            r *= b
        b *= b
        k >>= 1
    return r


@kernel
def _log1p_reduced(f):
    """log(1 + f) for sqrt(1/2) - 1 <= f <= sqrt(2) - 1: with s = f / (2 + f), log(1+f) =
    2 atanh s = f - (f^2/2 - s (f^2/2 + R)), R = 2 s^2/3 + 2 s^4/5 + ... (|s| < 0.172, to
    s^22)."""
    s = f / (2.0 + f)
    z = s * s
    R = _horner(_ATANH[0], z, _ATANH[1:]) * z
    hfsq = 0.5 * f * f
    return f - (hfsq - s * (hfsq + R))


@kernel
def log(x):
    """Natural logarithm: x = m 2^e, sqrt(1/2) <= m < sqrt(2), log x = e ln 2 + log m."""
    if x != x or x == math.inf:
        return x
    if x < 0.0:
        return math.nan
    if x == 0.0:
        return -math.inf
    m, e = math.frexp(x)
    if m < _SQRT_HALF:
        m *= 2.0
        e -= 1
    k = float(e)
    return k * _LN2_HI + (k * _LN2_LO + _log1p_reduced(m - 1.0))


@kernel
def log1p(x):
    """log(1 + x), accurate for small x."""
    if x != x or x == math.inf:
        return x
    if x < -1.0:
        return math.nan
    if x == -1.0:
        return -math.inf
    if -0.2928932188134524 <= x <= 0.41421356237309503:
        return _log1p_reduced(x)
    u = 1.0 + x
    # the rounding of 1 + x, put back to first order
    return log(u) + (x - (u - 1.0)) / u


@kernel
def _atan_small(x):
    """atan x for |x| <= tan(pi/8) ~ 0.414: x - x^3/3 + ..., to x^39 (the next term is
    below 1e-17 of x)."""
    z = x * x
    p = _horner(_horner(_ATAN[0], z, _ATAN[1:10]), z, _ATAN[10:])
    return x + x * z * p


@kernel
def atan(x):
    """arctan x in (-pi/2, pi/2): for |x| > 1, pi/2 - atan(1/x); then atan x = pi/4 +
    atan((x - 1)/(x + 1)) above tan(pi/8); the rest by its series."""
    if x != x:
        return x
    a = abs(x)
    hi = 0.0
    lo = 0.0
    if a > 1.0:
        a = 1.0 / a
        hi = _PI_2
        lo = _PI_2_LO
        flip = True
    else:
        flip = False
    if a > 0.41421356237309503:                # tan(pi/8)
        t = (a - 1.0) / (a + 1.0)
        r = (_PI_4 + (_atan_small(t) + _PI_4_LO))
    else:
        r = _atan_small(a)
    if flip:
        r = hi - (r - lo)
    return math.copysign(r, x)


@kernel
def atan2(y, x):
    """The angle of (x, y) in [-pi, pi] (math.atan2's quadrants and signed zeros)."""
    if x != x or y != y:
        return x + y
    if y == 0.0:
        if x > 0.0 or (x == 0.0 and math.copysign(1.0, x) > 0.0):
            return y                          # +-0
        return math.copysign(_PI, y)
    if x == 0.0:
        return math.copysign(_PI_2, y)
    if math.isinf(x):
        if math.isinf(y):
            return math.copysign(_PI_4 if x > 0.0 else 3.0 * _PI_4, y)
        return math.copysign(0.0, y) if x > 0.0 else math.copysign(_PI, y)
    if math.isinf(y):
        return math.copysign(_PI_2, y)
    ax = abs(x)
    ay = abs(y)
    if ay > ax:
        r = _PI_2 - (atan(ax / ay) - _PI_2_LO)
    else:
        r = atan(ay / ax)
    if x < 0.0:
        r = _PI - (r - _PI_LO)
    return math.copysign(r, y)


@kernel
def asin(x):
    """arcsin x for |x| <= 1 (nan outside)."""
    if not abs(x) <= 1.0:
        return math.nan
    return atan2(x, math.sqrt((1.0 - x) * (1.0 + x)))


@kernel
def acos(x):
    """arccos x for |x| <= 1 (nan outside)."""
    if not abs(x) <= 1.0:
        return math.nan
    return atan2(math.sqrt((1.0 - x) * (1.0 + x)), x)


@kernel
def sinh(x):
    """sinh x: by its series below 0.5 in size (no cancellation), else (e^x - e^-x)/2."""
    a = abs(x)
    if a < 0.5:
        z = x * x
        p = 1.0 / 121645100408832000.0          # the series to x^19/19!
        p = p * z + 1.0 / 355687428096000.0
        p = p * z + 1.0 / 1307674368000.0
        p = p * z + 1.0 / 6227020800.0
        p = p * z + 1.0 / 39916800.0
        p = p * z + 1.0 / 362880.0
        p = p * z + 1.0 / 5040.0
        p = p * z + 1.0 / 120.0
        p = p * z + 1.0 / 6.0
        return x + x * z * p
    if a > 710.0:
        return math.copysign(math.inf, x) if x == x else x
    e = exp(a)
    return math.copysign(0.5 * (e - 1.0 / e), x)


@kernel
def cosh(x):
    """cosh x = (e^x + e^-x)/2."""
    a = abs(x)
    if a > 710.0:
        return math.inf if x == x else x
    e = exp(a)
    return 0.5 * (e + 1.0 / e)


@kernel
def atanh(x):
    """artanh x = log1p(2x / (1 - x)) / 2 for |x| < 1; +-inf at +-1, nan beyond."""
    a = abs(x)
    if not a <= 1.0:
        return math.nan
    if a == 1.0:
        return math.copysign(math.inf, x)
    return math.copysign(0.5 * log1p(2.0 * a / (1.0 - a)), x)


@kernel
def asinh(x):
    """arsinh x = log(|x| + sqrt(x^2 + 1)), with log1p for small x."""
    a = abs(x)
    if a != a or a == math.inf:
        return x
    if a > 1e150:
        r = log(a) + _LN2_HI + _LN2_LO
    elif a < 0.5:
        r = log1p(a + a * a / (1.0 + math.sqrt(1.0 + a * a)))
    else:
        r = log(a + math.sqrt(a * a + 1.0))
    return math.copysign(r, x)


@kernel
def cbrt(x):
    """The real cube root: a first guess from exp and log, then two Newton steps."""
    if x == 0.0 or x != x or math.isinf(x):
        return x
    a = abs(x)
    y = exp(log(a) / 3.0)
    y = y - (y - a / (y * y)) / 3.0
    y = y - (y - a / (y * y)) / 3.0
    return math.copysign(y, x)


@kernel
def _split(a):
    """a = hi + lo, hi with 26 significant bits (Veltkamp): products of halves are exact."""
    c = 134217729.0 * a                       # 2^27 + 1
    hi = c - (c - a)
    return hi, a - hi


@kernel
def two_product(a, b):
    """a b = p + e exactly, p the rounded product (Dekker's product, without fused
    multiply-add)."""
    p = a * b
    ah, al = _split(a)
    bh, bl = _split(b)
    return p, ((ah * bh - p) + ah * bl + al * bh) + al * bl


@kernel
def pow(x, y):
    """x^y for x > 0: exp(y log x) with log x as a sum of two doubles and the product y log x
    exact (Dekker), so that the error does not grow with log x: within 2 + |y| / 2 ulps.
    x == 0 and negative x with an integer y as math.pow; infinities and nan by math.pow,
    whose results there are exact."""
    if y == 0.0:
        return 1.0
    if not (math.isfinite(x) and math.isfinite(y)):
        return math.pow(x, y) if x == x and y == y else math.nan
    if x == 0.0:
        return 0.0 if y > 0.0 else math.inf
    if x < 0.0:
        if y != _floor(y):
            return math.nan
        r = pow(-x, y)
        return -r if abs(y) % 2.0 == 1.0 else r
    m, e = math.frexp(x)
    if m < _SQRT_HALF:
        m *= 2.0
        e -= 1
    k = float(e)
    a = k * _LN2_HI                            # exact
    b = k * _LN2_LO + _log1p_reduced(m - 1.0)
    hi = a + b
    lo = (b - (hi - a)) if abs(a) >= abs(b) else (a - (hi - b))
    t, err = two_product(y, hi)
    err += y * lo
    if t > 709.782712893384:
        return math.inf
    if t < -745.1332191019412:
        return 0.0
    r = exp(t)
    return r + r * err


# ----------------------------------------------------------------------------- on arrays

ARRAY = ("sin", "cos", "exp", "log", "cbrt", "acos")


@kernel
def _each(code, x, out):
    for i in range(x.size):
        v = x[i]
        if code == 0:
            out[i] = sin(v)
        elif code == 1:
            out[i] = cos(v)
        elif code == 2:
            out[i] = exp(v)
        elif code == 3:
            out[i] = log(v)
        elif code == 4:
            out[i] = cbrt(v)
        else:
            out[i] = acos(v)


def each(name, x):
    """The function `name` (one of ARRAY) of every element of x: a float64 array of x's
    shape (numpy's own would pick its SIMD version by the CPU)."""
    x = np.ascontiguousarray(x, np.float64)
    out = np.empty(x.shape)
    _each(ARRAY.index(name), x.reshape(-1), out.reshape(-1))
    return out


def twins(module_globals, names, **bound):
    """The kernels `names` of a module (its globals()) as plain Python, the kernels' source
    calling each other's twins, and `bound` in place of those globals (kernels/conics.py:
    libm=libm.py)."""
    space = dict(module_globals, **bound)
    for name in names:
        fn = module_globals[name].py_func
        space[name] = types.FunctionType(fn.__code__, space, name, fn.__defaults__)
    return types.SimpleNamespace(**{name: space[name] for name in names})


py = twins(globals(), ["_horner", "_sin_poly", "_cos_poly", "_floor", "_reduce", "sin", "cos", "tan", "exp", "_scale", "_pow2",
             "_log1p_reduced", "log", "log1p", "_atan_small", "atan", "atan2", "asin", "acos",
             "sinh", "cosh", "atanh", "asinh", "cbrt", "_split", "two_product", "pow"])
