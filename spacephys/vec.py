"""Dot products and lengths of short vectors with the same bits on every CPU.

numpy's `a @ b` and `np.linalg.norm(a)` of 1-D vectors call BLAS, whose kernel (and with it
the order of the sums and whether they fuse multiply-adds) is picked by the CPU; these add
the products in index order in plain doubles. For code that builds or changes a state;
readouts may use numpy's.
"""
import math

import numpy as np


def dot(a, b):
    """sum a[i] b[i] in index order: a float (a, b: vectors of one length)."""
    s = 0.0
    for x, y in zip(np.ravel(a).tolist(), np.ravel(b).tolist()):
        s += x * y
    return s


def norm(a):
    """sqrt(dot(a, a)): a float."""
    return math.sqrt(dot(a, a))
