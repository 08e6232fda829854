"""Orientations as LIBERO gives them: quaternions (w, x, y, z) and a class's placement rotation."""
from __future__ import annotations

import math

import numpy as np

INVERT = np.array([0.0, 1.0, 0.0, 0.0])  # 180 degrees about the world x axis


def quat_mul(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    w1, x1, y1, z1 = a
    w2, x2, y2, z2 = b
    return np.array([w1 * w2 - x1 * x2 - y1 * y2 - z1 * z2, w1 * x2 + x1 * w2 + y1 * z2 - z1 * y2,
                     w1 * y2 - x1 * z2 + y1 * w2 + z1 * x2, w1 * z2 + x1 * y2 - y1 * x2 + z1 * w2])


def axis_quat(axis: str, angle: float) -> np.ndarray:
    q = np.zeros(4)
    q[0], q[{"x": 1, "y": 2, "z": 3}[axis]] = math.cos(angle / 2), math.sin(angle / 2)
    return q


def quat_matrix(q: np.ndarray) -> np.ndarray:
    w, x, y, z = np.asarray(q, dtype=float) / np.linalg.norm(q)
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
                     [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
                     [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)]])


def _angle(bounds, rng: np.random.Generator | None) -> float:
    if isinstance(bounds, (tuple, list)):
        lo, hi = min(bounds), max(bounds)
        return float(rng.uniform(lo, hi)) if rng is not None else (lo + hi) / 2
    return float(bounds or 0.0)


def _xyzw_axis(axis: str, angle: float) -> np.ndarray:
    q = np.array([0.0, 0.0, 0.0, math.cos(angle / 2)])
    q[{"x": 0, "y": 1, "z": 2}[axis]] = math.sin(angle / 2)
    return q


def _xyzw_mul(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """robosuite's quat_multiply (x, y, z, w)."""
    x0, y0, z0, w0 = b
    x1, y1, z1, w1 = a
    return np.array([x1 * w0 + y1 * z0 - z1 * y0 + w1 * x0, -x1 * z0 + y1 * w0 + z1 * x0 + w1 * y0,
                     x1 * y0 - y1 * x0 + z1 * w0 + w1 * z0, -x1 * x0 - y1 * y0 - z1 * z0 + w1 * w0])


def class_quat(obj, rng: np.random.Generator | None = None) -> np.ndarray:
    """The free-joint quaternion LIBERO's region samplers give a fresh object of this class: its
    `rotation` (a range about `rotation_axis`, or a dict of ranges per axis composed in order),
    drawn from `rng` (the trial's stream, never the global one), or the middle of each range.

    Exactly as LIBERO does it, including its convention slip: the sampler builds an (x, y, z, w)
    quaternion and `_reset_internal` writes those four numbers into MuJoCo's (w, x, y, z) slots.
    The numbers returned here are those qpos values (a MuJoCo quaternion)."""
    rot = obj.rotation
    if isinstance(rot, dict):
        q = np.array([0.0, 0.0, 0.0, 1.0])
        for axis, bounds in rot.items():
            q = _xyzw_mul(_xyzw_axis(axis, _angle(bounds, rng)), q)
        return q
    return _xyzw_axis(getattr(obj, "rotation_axis", None) or "z", _angle(rot, rng))


def axis_angle_quat(axis, angle: float) -> np.ndarray:
    axis = np.asarray(axis, dtype=float)
    axis = axis / np.linalg.norm(axis)
    return np.concatenate([[math.cos(angle / 2)], math.sin(angle / 2) * axis])
