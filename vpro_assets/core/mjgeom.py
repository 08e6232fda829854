"""MuJoCo geometry helpers (numpy and mujoco only): world boxes of geoms, and rotations through
mujoco's own `mju_*` quaternion functions.

Every geom carries its own bounding box in its frame (`model.geom_aabb`: centre, half-sizes); its
8 corners, carried to the world by the geom's pose in `data`, bound it there. The scene build
measures layouts with these corners, the distractor pool measures objects, the visual-only copies
find their extent, and the scripted policy finds what it grasps.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence

import mujoco
import numpy as np


def subtree(model, root: int) -> list[int]:
    """Body `root` and every body below it, in body order (MuJoCo numbers a child after its parent)."""
    out, inside = [root], {root}
    for body in range(root + 1, model.nbody):
        if model.body_parentid[body] in inside:
            out.append(body)
            inside.add(body)
    return out


# The 8 corners of the unit box [-1, 1]^3, in a fixed order.
_CORNERS = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)], dtype=float)


def colliding(model, geoms: Iterable[int]) -> list[int]:
    """The geoms among `geoms` that can collide (contype or conaffinity set)."""
    return [g for g in geoms if model.geom_contype[g] or model.geom_conaffinity[g]]


def geom_corners(model, data, geoms: Iterable[int]) -> np.ndarray:
    """World positions of the 8 box corners of each geom, stacked: shape (8 * len(geoms), 3)."""
    pts = [
        (_CORNERS * model.geom_aabb[g][3:] + model.geom_aabb[g][:3]) @ data.geom_xmat[g].reshape(3, 3).T
        + data.geom_xpos[g]
        for g in geoms
    ]
    return np.concatenate(pts) if pts else np.zeros((0, 3))


def geom_pieces(model, data, geom: int, piece_m: float) -> np.ndarray:
    """World boxes (K, 2, 3: lo, hi) of the pieces of a geom's box cut into cells at most
    `piece_m` long along each of its axes. A rotated plate's one world box covers much empty
    space (a cabinet turned 64 degrees: its top panel's box reaches 5 cm over a bowl the panel
    does not cover); its pieces' boxes hug it to about `piece_m`."""
    return posed_pieces(data, geom, piece_corners(model.geom_aabb[geom], piece_m))


def piece_corners(aabb: np.ndarray, piece_m: float) -> np.ndarray:
    """The corners (K, 8, 3) of `geom_pieces`' cells in the geom's frame, from its box `aabb` (its
    row of `model.geom_aabb`: centre, half sizes): of the model only, so a caller that measures a
    geom at many poses makes them once."""
    half = aabb[3:]
    counts = np.maximum(1, np.ceil(2 * half / piece_m).astype(int))
    axes = [np.linspace(-h, h, n + 1) for h, n in zip(half, counts, strict=True)]
    lo = np.stack(np.meshgrid(*(a[:-1] for a in axes), indexing="ij"), -1).reshape(-1, 3)
    hi = np.stack(np.meshgrid(*(a[1:] for a in axes), indexing="ij"), -1).reshape(-1, 3)
    center = (lo + hi) / 2 + aabb[:3]
    return center[:, None, :] + _CORNERS[None] * ((hi - lo) / 2)[:, None, :]


def posed_pieces(data, geom: int, corners: np.ndarray) -> np.ndarray:
    """`geom_pieces` from its cells' corners (`piece_corners`) and the geom's pose in `data`."""
    world = corners @ data.geom_xmat[geom].reshape(3, 3).T + data.geom_xpos[geom]
    return np.stack([world.min(1), world.max(1)], axis=1)


def world_aabb(model, data, geoms: Sequence[int]) -> tuple[np.ndarray, np.ndarray]:
    """(lo, hi): the world axis-aligned box around the geoms' boxes (`geoms` not empty)."""
    if not len(geoms):
        raise ValueError("world_aabb needs at least one geom")
    pts = geom_corners(model, data, geoms)
    return pts.min(0), pts.max(0)


# ---- rotations (MuJoCo's quaternion convention: w, x, y, z) --------------------------------------
def quat_mul(a, b) -> np.ndarray:
    """The quaternion product a * b (`mju_mulQuat`)."""
    out = np.zeros(4)
    mujoco.mju_mulQuat(out, np.asarray(a, dtype=np.float64), np.asarray(b, dtype=np.float64))
    return out


def quat_matrix(q) -> np.ndarray:
    """The 3x3 rotation matrix of a quaternion, normalised first (`mju_quat2Mat`)."""
    q = np.asarray(q, dtype=np.float64)
    out = np.zeros(9)
    mujoco.mju_quat2Mat(out, q / np.linalg.norm(q))
    return out.reshape(3, 3)


def axis_angle_quat(axis, angle: float) -> np.ndarray:
    """The rotation by `angle` (radians) about `axis` (normalised first) (`mju_axisAngle2Quat`)."""
    axis = np.asarray(axis, dtype=np.float64)
    out = np.zeros(4)
    mujoco.mju_axisAngle2Quat(out, axis / np.linalg.norm(axis), float(angle))
    return out
