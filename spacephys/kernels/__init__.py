"""numba kernels: arrays and scalars in, caller-owned `out` arrays written; no classes, units or I/O."""
