"""Quaternions, up vectors and the task frame: the geometry every stage shares.

Quaternions are MuJoCo's ``(w, x, y, z)``; every function broadcasts over leading axes. The frames (mesh
frame, world, stable pose, task frame) are defined in :mod:`rail_mj.core.types`.
"""

from __future__ import annotations

import numpy as np

__all__ = [
    "quat_mul",
    "quat_conj",
    "quat_rotate",
    "quat_angle",
    "quat_to_angvel",
    "slerp",
    "up_in_mesh_frame",
    "rotation_to_z",
    "task_origin",
    "follow_task_frame",
    "to_task_frame",
    "tilt",
]

_Z = np.array([0.0, 0.0, 1.0])


def quat_mul(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Hamilton product of wxyz quaternions."""
    aw, ax, ay, az = np.moveaxis(a, -1, 0)
    bw, bx, by, bz = np.moveaxis(b, -1, 0)
    return np.stack(
        [
            aw * bw - ax * bx - ay * by - az * bz,
            aw * bx + ax * bw + ay * bz - az * by,
            aw * by - ax * bz + ay * bw + az * bx,
            aw * bz + ax * by - ay * bx + az * bw,
        ],
        axis=-1,
    )


def quat_conj(q: np.ndarray) -> np.ndarray:
    """The conjugate (the inverse of a unit quaternion)."""
    return q * np.array([1.0, -1.0, -1.0, -1.0])


def quat_rotate(q: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Rotate vectors v by unit quaternions q."""
    w = q[..., :1]
    u = q[..., 1:]
    t = 2.0 * np.cross(u, v)
    return v + w * t + np.cross(u, t)


def quat_angle(q0: np.ndarray, q1: np.ndarray) -> float:
    """Angle (rad) of the rotation between two unit quaternions."""
    return float(2.0 * np.arccos(min(1.0, abs(float(np.dot(q0, q1))))))


def quat_to_angvel(q0: np.ndarray, q1: np.ndarray, dt: float) -> np.ndarray:
    """Body-local angular velocity turning q0 into q1 in dt (as a free joint's qvel)."""
    dq = quat_mul(quat_conj(q0), q1)
    dq = np.where(dq[..., :1] < 0, -dq, dq)
    s = np.linalg.norm(dq[..., 1:], axis=-1, keepdims=True)
    angle = 2.0 * np.arctan2(s, dq[..., :1])
    axis = np.divide(dq[..., 1:], s, out=np.zeros_like(dq[..., 1:]), where=s > 1e-12)
    return axis * angle / dt


def slerp(q0: np.ndarray, q1: np.ndarray, f: np.ndarray | float) -> np.ndarray:
    """Unit quaternions a fraction ``f`` (scalar or (n,)) of the way from q0 to q1 on the shorter arc."""
    f = np.asarray(f, dtype=np.float64)
    d = float(np.dot(q0, q1))
    if d < 0:
        q1, d = -q1, -d
    if d > 0.9995:  # nearly equal: linear interpolation is exact enough and stays well conditioned
        q = q0 + f[..., None] * (q1 - q0)
    else:
        th = np.arccos(d)
        q = (np.sin((1 - f) * th)[..., None] * q0 + np.sin(f * th)[..., None] * q1) / np.sin(th)
    return q / np.linalg.norm(q, axis=-1, keepdims=True)


def up_in_mesh_frame(quat: np.ndarray) -> np.ndarray:
    """The mesh-frame unit vector that points to world +z when the mesh frame has orientation ``quat``."""
    w, x, y, z = np.moveaxis(np.asarray(quat), -1, 0)
    # third row of the rotation matrix = R^T e_z
    return np.stack([2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)], axis=-1)


def rotation_to_z(up: np.ndarray) -> np.ndarray:
    """Quaternion of the shortest rotation taking the vector ``up`` to +z."""
    up = up / np.linalg.norm(up)
    c = float(up @ _Z)
    if c < -1 + 1e-12:
        return np.array([0.0, 1.0, 0.0, 0.0])
    axis = np.cross(up, _Z)
    q = np.array([1.0 + c, *axis])
    return q / np.linalg.norm(q)


def task_origin(half_extents: np.ndarray) -> np.ndarray:
    """World position of the task-frame origin of objects placed in stable poses: their box centres, (..., 3)."""
    h = np.asarray(half_extents, dtype=np.float64)
    origin = np.zeros(h.shape)
    origin[..., 2] = h[..., 2]
    return origin


def follow_task_frame(
    origin0: np.ndarray, obj_pos0: np.ndarray, obj_quat0: np.ndarray, obj_pos1: np.ndarray, obj_quat1: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Where the task frame placed at ``origin0`` is once the object moved from pose 0 to pose 1.

    The frame rides on the object: its offset from the object origin, in object coordinates, is fixed.
    Returns the new origin (world) and the frame's orientation relative to placement, a unit quaternion.
    """
    rel = quat_rotate(quat_conj(obj_quat0), origin0 - obj_pos0)
    quat = quat_mul(obj_quat1, quat_conj(obj_quat0))
    quat /= np.linalg.norm(quat, axis=-1, keepdims=True)
    return obj_pos1 + quat_rotate(obj_quat1, rel), quat


def to_task_frame(
    origin: np.ndarray, quat: np.ndarray, pos: np.ndarray, orientation: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """World positions (B, N, 3) and orientations (B, N, 4) into the task frames (B, 3)/(B, 4)."""
    inv = quat_conj(quat)[:, None, :]
    return quat_rotate(inv, pos - origin[:, None, :]), quat_mul(np.broadcast_to(inv, orientation.shape), orientation)


def tilt(quat: np.ndarray) -> np.ndarray:
    """Angle (rad) between the rotated +z and world +z."""
    up = quat_rotate(quat, _Z)
    return np.arccos(np.clip(up[..., 2], -1.0, 1.0))
