"""The foot of an upside-down object (an inverted bowl): where the fingers pinch the low foot on top of
its wide sloping shoulders (`foot_pinch`; `grasp.foot_grasp` makes it a gentle grasp), and the two
measurements it rests on: the top face's normal and how deep the object is solid under its top."""

from __future__ import annotations

import numpy as np
from scipy.spatial import ConvexHull, QhullError

from vpro_assets.rollout.policies.oracle.hand import FINGER_HALF_WIDTH_M, FINGER_THICK_M, FINGERTIP_M
from vpro_assets.rollout.policies.oracle.shape import (
    MAX_PINCH_M,
    NARROW_DEPTH_M,
    SOLID_TOP_M,
    beyond,
    extent_middle,
    widths,
)

# One CLOSE action moves the fingers' target opening 1 cm (robosuite: 25 substeps of 1% of the 8 cm range).
FOOT_SLICE_M = 0.001  # the foot: the object's top this deep
FOOT_CLEAR_M = 0.002  # the fingers' footprint starts this far outside the foot
FOOT_STEP_M = 0.0005
MIN_FOOT_BAND_M = 0.002  # a foot standing less than this over what is under the fingers is not pinched
FOOT_SQUEEZE_M = 0.002  # the fingers' target opening at least this far inside the foot (at most 1 cm more)
# A top face tilted less than this is taken as level: across a 4.6 cm foot it falls under half of FOOT_SLICE_M.
LEVEL_TILT_RAD = 0.01


def foot_pinch(hulls: list[np.ndarray]) -> tuple[np.ndarray, np.ndarray, float] | None:
    """(grip point, closing axis, width across) of the pinch of a top too wide for a narrow-top grasp
    because shoulders slope out under it
    (an inverted akita bowl: a 4.6 cm plus-shaped foot, its arms' ends 1.3 mm over the shoulders'
    inner edge, the shoulders sloping 35 degrees out to 9 cm, rim on the table). The fingertips
    (friction 1) on the shoulders squeeze the bowl down and out of the hand, so the fingers' sides
    take the foot's vertical sides, the fingertips just over the shoulders. Of the directions the
    foot (its top FOOT_SLICE_M) fits the open fingers across, the one where it stands highest over
    what lies under the fingers' footprint (across the plus's corners: about 4 mm, where the shoulders
    under the fingers are lower). The fingers close to just inside the foot and hold there: closed
    fully, their 20 N press them over the foot's edge. None when the top does not stand over the
    object's middle, is not solid there (the mouth of an upright bowl a taper narrowed to 7 cm: a
    ring round the cavity, whose wall slopes out under the fingers, so a gentle squeeze from
    outside slides up it) or no direction leaves MIN_FOOT_BAND_M. Depths are measured square to
    the top face (`top_face_up`): an inverted bowl resting 2.4 degrees tilted on a ramekin has its
    foot's top 2 mm lower on one side, so a level slice of FOOT_SLICE_M was a 2.4 cm crescent off
    the middle, and a level cut reached the high side's shoulders 1.7 mm under the top."""
    top = max(float(h[:, 2].max()) for h in hulls)
    if solid_below(hulls, top) > SOLID_TOP_M:
        return None
    up = top_face_up(hulls)
    top = max(float((h @ up).max()) for h in hulls)  # along `up`: the world top when the face is level
    foot = beyond(hulls, up, top - FOOT_SLICE_M)
    dirs, across = widths(foot)
    # A foot stands over the object's middle: the top of a tilted upright bowl is an arc of its rim.
    pts = np.concatenate(hulls)
    middle = (pts.min(0)[:2] + pts.max(0)[:2]) / 2 @ dirs[:, :2].T
    reach = foot[:, :2] @ dirs[:, :2].T
    if np.any(middle < reach.min(0) + FOOT_CLEAR_M) or np.any(middle > reach.max(0) - FOOT_CLEAR_M):
        return None
    cuts = [beyond(hulls, up, top - depth) for depth in np.arange(FOOT_STEP_M, NARROW_DEPTH_M + 1e-9, FOOT_STEP_M)]
    best: tuple[float, int] | None = None
    for k in range(0, len(dirs), 5):
        if across[k] + 2 * FOOT_CLEAR_M > MAX_PINCH_M:
            continue
        band = _foot_band(foot, cuts, dirs[k])
        if best is None or band > best[0] + 1e-9:
            best = band, k
    if best is None or best[0] < MIN_FOOT_BAND_M:
        return None
    band, k = best
    point = extent_middle(foot, dirs[k], 0.0)
    face = (top - up[:2] @ point[:2]) / up[2]  # the top face's height over the foot's middle
    point[2] = face - band + FOOT_STEP_M + FINGERTIP_M
    return point, dirs[k], float(across[k])


def top_face_up(hulls: list[np.ndarray]) -> np.ndarray:
    """The unit normal of an object's top face (its collision geoms' convex hulls): of the hull
    holding the highest point, its facet nearest level; exactly vertical when that facet tilts less
    than LEVEL_TILT_RAD (or the hull is flat)."""
    vertical = np.array([0.0, 0.0, 1.0])
    highest = max(hulls, key=lambda h: float(h[:, 2].max()))
    try:
        facets = ConvexHull(highest).equations
    except QhullError:
        return vertical
    normal = facets[int(np.argmax(facets[:, 2])), :3]
    normal = normal / np.linalg.norm(normal)
    return vertical if float(np.arccos(np.clip(normal[2], -1.0, 1.0))) < LEVEL_TILT_RAD else normal


def solid_below(hulls: list[np.ndarray], top: float) -> float:
    """How far below `top` the object (its collision geoms' convex hulls) is first solid on the
    vertical line through the middle of its extent (inf: nowhere, the line misses every hull). From
    each hull's facets (`scipy.spatial.ConvexHull`: n . p + d <= 0 inside), the line's highest
    point inside it."""
    pts = np.concatenate(hulls)
    middle = (pts.min(0)[:2] + pts.max(0)[:2]) / 2
    highest = -np.inf
    for h in hulls:
        try:
            facets = ConvexHull(h).equations
        except QhullError:  # a flat piece (coplanar points) has no inside
            continue
        normal_z, rest = facets[:, 2], facets[:, :2] @ middle + facets[:, 3]
        level = np.abs(normal_z) < 1e-12
        if np.any(rest[level] > 1e-12):
            continue
        upper = np.min(-rest[normal_z > 0] / normal_z[normal_z > 0], initial=np.inf)
        lower = np.max(-rest[normal_z < 0] / normal_z[normal_z < 0], initial=-np.inf)
        if lower <= upper:
            highest = max(highest, upper)
    return top - highest


def _foot_band(foot: np.ndarray, cuts: list[np.ndarray], axis: np.ndarray) -> float:
    """How far below the top the fingertips come down beside `foot` (its points) closing along
    `axis`: the depth of the last of `cuts` (the object above FOOT_STEP_M, 2 * FOOT_STEP_M, ... below
    its top) with none of its points under the fingers' footprint (from FOOT_CLEAR_M outside the
    foot, FINGER_THICK_M thick, 2 * FINGER_HALF_WIDTH_M wide)."""
    across = np.array([-axis[1], axis[0]])
    along_foot, across_foot = foot[:, :2] @ axis[:2], foot[:, :2] @ across
    mid_along, half = (along_foot.max() + along_foot.min()) / 2, np.ptp(along_foot) / 2
    mid_across = (across_foot.max() + across_foot.min()) / 2
    for n, cut in enumerate(cuts):
        out = np.abs(cut[:, :2] @ axis[:2] - mid_along) - half - FOOT_CLEAR_M
        side = np.abs(cut[:, :2] @ across - mid_across)
        if np.any((out > 0) & (out < FINGER_THICK_M) & (side < FINGER_HALF_WIDTH_M)):
            return n * FOOT_STEP_M
    return len(cuts) * FOOT_STEP_M
