"""Rotations as unit quaternions (w, x, y, z), for the kernels: products, the rotation by an
angular velocity over a time, a vector rotated. From + - x / sqrt and libm: the same bits on
every CPU."""
import math

from .._jit import kernel
from . import libm


@kernel
def qmul(a0, a1, a2, a3, b0, b1, b2, b3):
    return (a0 * b0 - a1 * b1 - a2 * b2 - a3 * b3,
            a0 * b1 + a1 * b0 + a2 * b3 - a3 * b2,
            a0 * b2 - a1 * b3 + a2 * b0 + a3 * b1,
            a0 * b3 + a1 * b2 - a2 * b1 + a3 * b0)


@kernel
def qexp(wx, wy, wz, t):
    """The rotation by the angle |w| t about w, as a quaternion."""
    norm = math.sqrt(wx * wx + wy * wy + wz * wz)
    if norm == 0.0:
        return 1.0, 0.0, 0.0, 0.0
    half = 0.5 * norm * t
    s = libm.sin(half) / norm
    return libm.cos(half), wx * s, wy * s, wz * s


@kernel
def rotate(q0, q1, q2, q3, vx, vy, vz):
    """R(q) v for a unit quaternion q."""
    # t = 2 q_vec x v; v' = v + q0 t + q_vec x t
    tx = 2.0 * (q2 * vz - q3 * vy)
    ty = 2.0 * (q3 * vx - q1 * vz)
    tz = 2.0 * (q1 * vy - q2 * vx)
    return (vx + q0 * tx + (q2 * tz - q3 * ty),
            vy + q0 * ty + (q3 * tx - q1 * tz),
            vz + q0 * tz + (q1 * ty - q2 * tx))


@kernel
def normalised(q0, q1, q2, q3):
    s = 1.0 / math.sqrt(q0 * q0 + q1 * q1 + q2 * q2 + q3 * q3)
    return q0 * s, q1 * s, q2 * s, q3 * s
