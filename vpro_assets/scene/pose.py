"""Orientations as LIBERO gives them: quaternions (w, x, y, z) and a class's placement rotation.
The quaternion maths is mujoco's (`vpro_assets.core.mjgeom`)."""

from __future__ import annotations

import math

import numpy as np

from vpro_assets.core.mjgeom import quat_mul

INVERT = np.array([0.0, 1.0, 0.0, 0.0])  # 180 degrees about the world x axis
LIE = np.array([math.sqrt(0.5), math.sqrt(0.5), 0.0, 0.0])  # 90 degrees about the world x axis: on its side
_WXYZ, _XYZW = [3, 0, 1, 2], [1, 2, 3, 0]  # index orders between the (x, y, z, w) and (w, x, y, z) conventions


def _angle(bounds, rng: np.random.Generator | None) -> float:
    if isinstance(bounds, (tuple, list)):
        lo, hi = min(bounds), max(bounds)
        return float(rng.uniform(lo, hi)) if rng is not None else (lo + hi) / 2
    return float(bounds or 0.0)


def _xyzw_axis(axis: str, angle: float) -> np.ndarray:
    """LIBERO's sampler quaternion (x, y, z, w) for `angle` about one axis, built as LIBERO does."""
    q = np.array([0.0, 0.0, 0.0, math.cos(angle / 2)])
    q[{"x": 0, "y": 1, "z": 2}[axis]] = math.sin(angle / 2)
    return q


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
            # robosuite's quat_multiply(turn, q) in (x, y, z, w), computed by mju_mulQuat in (w, x, y, z)
            q = quat_mul(_xyzw_axis(axis, _angle(bounds, rng))[_WXYZ], q[_WXYZ])[_XYZW]
        return q
    return _xyzw_axis(getattr(obj, "rotation_axis", None) or "z", _angle(rot, rng))
