"""The rotation matrix of a unit quaternion (w, x, y, z), for the compiled kernels.

``dcm(qw, qx, qy, qz)`` returns R row by row (r00, r01, r02, r10, …, r22), R mapping body
vectors (FRD) to NED: v_ned = R v_body, v_body = Rᵀ v_ned. A ``register_jitable`` function: the
kernels of vehicles/inner_loop.py and vehicles/estimation.py inline it, Python can call it.
"""

from __future__ import annotations

from numba.extending import register_jitable


@register_jitable
def dcm(qw: float, qx: float, qy: float, qz: float) -> tuple[float, float, float, float, float,
                                                            float, float, float, float]:
    return (1 - 2 * (qy * qy + qz * qz), 2 * (qx * qy - qw * qz), 2 * (qx * qz + qw * qy),
            2 * (qx * qy + qw * qz), 1 - 2 * (qx * qx + qz * qz), 2 * (qy * qz - qw * qx),
            2 * (qx * qz - qw * qy), 2 * (qy * qz + qw * qx), 1 - 2 * (qx * qx + qy * qy))
