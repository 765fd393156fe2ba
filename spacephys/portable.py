"""Maths that gives the same bits on every CPU, for a game's own code that builds or changes
a World's state: spawn places, aiming, headings, orbits set by hand. A game played in
lockstep or with rollback (spacephys.netplay) must compute these the same way on every
peer; numpy's sin, cos, exp and power and the C library's (Python's math, and x ** y) pick
their code by the CPU, and numpy's a @ b and linalg.norm call BLAS, which does too.

    sin, cos, tan, atan, atan2, asin, acos, exp, log, log1p, sinh, cosh, atanh, asinh,
    cbrt, pow        floats in, a float out (spacephys's own functions, kernels/libm.py:
                     within 3 units in the last place of the C library's)
    dot(a, b), norm(a)   short vectors, the products added in index order

sqrt, + - * / and whole powers written as products are the same everywhere already.
"""
import math

import numpy as np

from .kernels.libm import py as _libm

sin, cos, tan = _libm.sin, _libm.cos, _libm.tan
atan, atan2, asin, acos = _libm.atan, _libm.atan2, _libm.asin, _libm.acos
exp, log, log1p, pow = _libm.exp, _libm.log, _libm.log1p, _libm.pow
sinh, cosh, atanh, asinh, cbrt = _libm.sinh, _libm.cosh, _libm.atanh, _libm.asinh, _libm.cbrt

__all__ = ["sin", "cos", "tan", "atan", "atan2", "asin", "acos", "exp", "log", "log1p",
           "pow", "sinh", "cosh", "atanh", "asinh", "cbrt", "dot", "norm"]


def dot(a, b):
    """sum a[i] b[i] in index order: a float (a, b: vectors of one length)."""
    s = 0.0
    for x, y in zip(np.ravel(a).tolist(), np.ravel(b).tolist()):
        s += x * y
    return s


def norm(a):
    """sqrt(dot(a, a)): a float."""
    return math.sqrt(dot(a, a))
