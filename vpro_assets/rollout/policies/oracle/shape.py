"""An object's shape as the fingers meet it, from points or the convex hulls of its collision geoms
in the world: its width across every horizontal direction, the part above a height or beyond a
plane, its cross-section. What the grasp planners (`grasp.py`, `foot.py`) and the planner's size
checks (`plan.py`) measure with."""

from __future__ import annotations

import numpy as np

MAX_PINCH_M = 0.074  # widest object the open fingers (7.8 cm apart) take across
SOLID_TOP_M = 0.025  # a geom over the centre reaching this close to the top makes the top solid
NARROW_DEPTH_M = 0.03  # deepest pinch below a solid object's top


def principal_axes(points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(major, minor) horizontal unit axes of a point cloud."""
    xy = points[:, :2] - points[:, :2].mean(0)
    _, vecs = np.linalg.eigh(xy.T @ xy)
    minor, major = vecs[:, 0], vecs[:, 1]
    return np.append(major, 0.0), np.append(minor, 0.0)


def widths(points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(180 x 3 horizontal unit axes, their widths): a point cloud's extent across each direction
    in 1-degree steps. Swept rather than taken from the principal axes, which miss the narrowest
    direction of twisted and tapered shapes; half a degree off it adds under 0.004% to a width."""
    ang = np.radians(np.arange(180))
    dirs = np.c_[np.cos(ang), np.sin(ang), np.zeros(180)]
    return dirs, np.ptp(points[:, :2] @ dirs[:, :2].T, axis=0)


def narrowest(points: np.ndarray) -> tuple[np.ndarray, float]:
    """(horizontal unit axis, width) across which a point cloud is narrowest."""
    dirs, across = widths(points)
    k = int(np.argmin(across))
    return dirs[k], float(across[k])


def above(hulls: list[np.ndarray], z: float) -> np.ndarray:
    """The points bounding the parts of convex hulls (each a point array) above height `z`."""
    return beyond(hulls, np.array([0.0, 0.0, 1.0]), z)


def beyond(hulls: list[np.ndarray], direction: np.ndarray, offset: float) -> np.ndarray:
    """The points bounding the parts of convex hulls (each a point array) beyond `offset` along the
    unit vector `direction`: their points beyond it and where their chords cross it."""
    out = []
    for pts in hulls:
        reach = pts @ direction
        up, down = pts[reach >= offset], pts[reach < offset]
        if not len(up):
            continue
        out.append(up)
        if len(down):
            a, b = np.repeat(up, len(down), axis=0), np.tile(down, (len(up), 1))
            ra, rb = a @ direction, b @ direction
            out.append(a + (b - a) * ((ra - offset) / (ra - rb))[:, None])
    return np.concatenate(out) if out else np.zeros((0, 3))


def section(hulls: list[np.ndarray], z: float) -> np.ndarray:
    """The points bounding an object's (its convex hulls') cross-section at height `z`."""
    cut = above(hulls, z)
    return cut[np.abs(cut[:, 2] - z) < 1e-9]


def extent_middle(pts: np.ndarray, axis: np.ndarray, z: float) -> np.ndarray:
    """The centre of a point cloud's extent along `axis` and across it, at height `z`."""
    across = np.array([-axis[1], axis[0], 0.0])
    along_axis, along_across = pts[:, :2] @ axis[:2], pts[:, :2] @ across[:2]
    point = axis * (along_axis.max() + along_axis.min()) / 2 + across * (along_across.max() + along_across.min()) / 2
    point[2] = z
    return point
