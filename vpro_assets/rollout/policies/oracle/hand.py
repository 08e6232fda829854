"""The open hand pointing down, as boxes around its grip site: which obstacles stop it coming down
over a point, and whether it fits at one (grasps, and the reach of drawers and cavities)."""

from __future__ import annotations

import numpy as np

# The open hand around its grip site: (centre along the closing axis, half length along it, half
# width across, height of the part's bottom below the grip site). The fingertips' spots (4.5 cm
# out, 1 cm below: what the fingers need to pass beside a bowl's wall); the palm 21 x 6.6 cm,
# 2.6 cm above (robosuite's Panda `hand_collision`).
HAND_PARTS = ((0.045, 0.01, 0.012, 0.01), (-0.045, 0.01, 0.012, 0.01), (0.0, 0.105, 0.033, -0.026))
# With the wrist (robot0_link7, 9 to 16 cm over the grip site, 9 cm to one side along the closing
# axis, which side depends on the yaw, so both): it meets an opened drawer's front over a bowl.
WITH_WRIST = (*HAND_PARTS, (0.0, 0.09, 0.044, -0.09))
PART_TOPS = (0.026, 0.026, 0.124, 0.16)  # each part's top over the grip site
# The Panda's finger collision meshes reach 9.3 mm below the grip site, 5 mm below the pads, and are
# about 1.5 cm thick and 2.2 cm wide.
FINGERTIP_M = 0.0093
FINGER_THICK_M = 0.015
FINGER_HALF_WIDTH_M = 0.011

Parts = tuple[tuple[float, float, float, float], ...]


def under_parts(boxes: np.ndarray, point: np.ndarray, axis: np.ndarray, parts: Parts) -> list[np.ndarray]:
    """For each of `parts` (as HAND_PARTS), which boxes ((N, 2, 3) world boxes) its footprint
    overlaps, the hand pointing down over `point` with its fingers closing along `axis`."""
    across = np.array([-axis[1], axis[0]])
    rel = (boxes[:, 0, :2] + boxes[:, 1, :2]) / 2 - point[:2]
    half = (boxes[:, 1, :2] - boxes[:, 0, :2]) / 2
    along_c, across_c = rel @ axis[:2], rel @ across
    along_r, across_r = half @ np.abs(axis[:2]), half @ np.abs(across)
    return [
        (np.abs(along_c - offset) <= half_along + along_r) & (np.abs(across_c) <= half_across + across_r)
        for offset, half_along, half_across, _ in parts
    ]


def reach_height(boxes: np.ndarray, point: np.ndarray, axis: np.ndarray, parts: Parts = HAND_PARTS) -> float:
    """Lowest grip-site height at which the open hand, coming down over `point` with its fingers
    closing along `axis`, touches no obstacle (boxes: (N, 2, 3) world boxes): each part of the hand
    (HAND_PARTS: the two fingers, the palm; WITH_WRIST: and the wrist) stops on the highest top
    under its footprint."""
    z = -np.inf
    for under, (*_, below) in zip(under_parts(boxes, point, axis, parts), parts, strict=True):
        if under.any():
            z = max(z, float(boxes[under, 1, 2].max()) + below)
    return z


def hand_fits(boxes: np.ndarray, point: np.ndarray, axis: np.ndarray) -> bool:
    """Whether the open hand and the wrist, the grip site at `point`, are clear of every box: each
    part between its bottom and its top (PART_TOPS)."""
    unders = under_parts(boxes, point, axis, WITH_WRIST)
    for under, (*_, below), top in zip(unders, WITH_WRIST, PART_TOPS, strict=True):
        hit = under & (boxes[:, 1, 2] > point[2] - below) & (boxes[:, 0, 2] < point[2] + top)
        if hit.any():
            return False
    return True
