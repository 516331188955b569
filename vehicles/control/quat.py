"""Scalar quaternion / vector helpers for the controllers (no numpy: 3- and 4-tuples of floats are
several times faster than tiny numpy arrays, and the attitude/rate loops run at 250 Hz per vehicle).

Rules: quaternions are (w, x, y, z) and rotate body FRD into NED (Hamilton product, PX4 matrix::Quatf
conventions). Vectors are 3-tuples. Every function is pure. The ones the compiled inner loop uses
(vehicles/inner_loop.py) are ``register_jitable``: plain Python when called from Python, compiled
into the caller when called from numba code — one source for both.
"""

from __future__ import annotations

import math

from numba.extending import register_jitable

from vehicles.types import Quat, Vec3

_FLT_EPSILON = 1.1920929e-07  # C's FLT_EPSILON, PX4's threshold for a zero element


@register_jitable
def q_mul(a: Quat, b: Quat) -> Quat:
    aw, ax, ay, az = a
    bw, bx, by, bz = b
    return (
        aw * bw - ax * bx - ay * by - az * bz,
        aw * bx + ax * bw + ay * bz - az * by,
        aw * by - ax * bz + ay * bw + az * bx,
        aw * bz + ax * by - ay * bx + az * bw,
    )


@register_jitable
def q_conj(q: Quat) -> Quat:
    return (q[0], -q[1], -q[2], -q[3])


@register_jitable
def q_normalized(q: Quat) -> Quat:
    n = math.sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3])
    return (q[0] / n, q[1] / n, q[2] / n, q[3] / n)


@register_jitable
def q_canonical(q: Quat) -> Quat:
    """The equivalent quaternion whose first element larger than FLT_EPSILON in size is positive
    (PX4 Quaternion::canonical): w >= 0, and for a half turn (w ~ 0) x, then y, then z decide."""
    for i in range(4):
        if abs(q[i]) > _FLT_EPSILON:
            return q if q[i] > 0.0 else (-q[0], -q[1], -q[2], -q[3])
    return q


@register_jitable
def q_dcm_z(q: Quat) -> Vec3:
    """Third column of the rotation matrix: body z (down) axis expressed in NED."""
    w, x, y, z = q
    return (2.0 * (x * z + w * y), 2.0 * (y * z - w * x), w * w - x * x - y * y + z * z)


def q_rotate(q: Quat, v: Vec3) -> Vec3:
    """R(q) @ v: body vector into NED."""
    w, x, y, z = q
    vx, vy, vz = v
    return (
        (1 - 2 * (y * y + z * z)) * vx + 2 * (x * y - w * z) * vy + 2 * (x * z + w * y) * vz,
        2 * (x * y + w * z) * vx + (1 - 2 * (x * x + z * z)) * vy + 2 * (y * z - w * x) * vz,
        2 * (x * z - w * y) * vx + 2 * (y * z + w * x) * vy + (1 - 2 * (x * x + y * y)) * vz,
    )


@register_jitable
def q_from_two_vectors(src: Vec3, dst: Vec3) -> Quat:
    """Shortest rotation taking ``src`` to ``dst`` (PX4 matrix::Quaternion(src, dst))."""
    cr = cross(src, dst)
    d = dot(src, dst)
    if norm(cr) < 1e-5 and d < 0.0:
        a = (abs(src[0]), abs(src[1]), abs(src[2]))
        if a[0] < a[1]:
            axis = (1.0, 0.0, 0.0) if a[0] < a[2] else (0.0, 0.0, 1.0)
        else:
            axis = (0.0, 1.0, 0.0) if a[1] < a[2] else (0.0, 0.0, 1.0)
        cr = cross(src, axis)
        w = 0.0
    else:
        w = d + math.sqrt(dot(src, src) * dot(dst, dst))
    return q_normalized((w, cr[0], cr[1], cr[2]))


@register_jitable
def q_from_dcm_columns(bx: Vec3, by: Vec3, bz: Vec3) -> Quat:
    """Quaternion of the rotation matrix whose columns are the body axes in NED."""
    r00, r10, r20 = bx
    r01, r11, r21 = by
    r02, r12, r22 = bz
    tr = r00 + r11 + r22
    if tr > 0.0:
        s = math.sqrt(tr + 1.0) * 2.0
        q = (0.25 * s, (r21 - r12) / s, (r02 - r20) / s, (r10 - r01) / s)
    elif r00 > r11 and r00 > r22:
        s = math.sqrt(1.0 + r00 - r11 - r22) * 2.0
        q = ((r21 - r12) / s, 0.25 * s, (r01 + r10) / s, (r02 + r20) / s)
    elif r11 > r22:
        s = math.sqrt(1.0 + r11 - r00 - r22) * 2.0
        q = ((r02 - r20) / s, (r01 + r10) / s, 0.25 * s, (r12 + r21) / s)
    else:
        s = math.sqrt(1.0 + r22 - r00 - r11) * 2.0
        q = ((r10 - r01) / s, (r02 + r20) / s, (r12 + r21) / s, 0.25 * s)
    return q_canonical(q_normalized(q))


def q_yaw(q: Quat) -> float:
    w, x, y, z = q
    return math.atan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z))


@register_jitable
def cross(a: Vec3, b: Vec3) -> Vec3:
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


@register_jitable
def dot(a: Vec3, b: Vec3) -> float:
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


@register_jitable
def norm(a: Vec3) -> float:
    return math.sqrt(a[0] * a[0] + a[1] * a[1] + a[2] * a[2])


def normalized(a: Vec3) -> Vec3:
    n = norm(a)
    return (a[0] / n, a[1] / n, a[2] / n)
