"""Turning a held object about the vertical so that its footprint fits into a narrow region
(`pick_place`): a slot such as a desk caddy's back compartment, 6.1 cm between its walls.

LIBERO's `In` of a region (`SiteObject.in_box`) wants the object's body position inside the
region's box, taken axis-aligned in the world (half sizes `|mat @ size|`). An object carried in the
yaw it was taken at may not go down into the box at all: libero_10-05's book (2.9 x 11 cm in plan)
came over the back compartment (5.6 x 12.4 cm) turned 19-40 degrees, rested on the walls' tops when
let go and tipped in or out (taper-s3: out in 4 of 10 trials, flat on the table). Where the footprint
overflows the box as held and some turn (at most a quarter turn either way: a footprint's extents
repeat every half turn) makes it fit, the hand turns by the smallest such turn, the wrist's limit
permitting (`grasp.grasp_orientation`), and the carry aims the footprint's middle, not the body
position, at the box's middle (the body position kept FIT_MARGIN_M inside the box). An object that
no turn fits, too wide on one axis only, is leaned in over one wall (`lean`).
"""

from __future__ import annotations

import numpy as np
from scipy.spatial.transform import Rotation

from vpro_assets.rollout.policies.oracle.grasp import grasp_orientation
from vpro_assets.rollout.policies.oracle.lay import turned
from vpro_assets.rollout.policies.oracle.world import World

TURNS = np.radians(np.arange(-90.0, 90.1, 2.5))  # candidate turns about the vertical
FIT_MARGIN_M = 0.005  # the body position this far inside LIBERO's box
FIT_SLACK_M = 0.003  # a footprint fits when it is at least this much narrower than the box each way
LEAN_INSIDE_M = 0.01  # a leaned footprint's inner end this far inside the box


def overflow(pts: np.ndarray, half: np.ndarray) -> float:
    """How far the plan extent of `pts` exceeds the box `2 * half` on its worse axis (negative: room)."""
    extent = pts[:, :2].max(0) - pts[:, :2].min(0)
    return float(np.max(extent - 2 * half))


def fit_turn(world: World, held: str, region: str) -> tuple[np.ndarray, np.ndarray] | None:
    """(hand orientation, where the carry brings the body position (xy)) that fit the held object's
    footprint into `region`'s box, or that lean it in (`lean`) when no turn makes it fit; None when
    it fits as held, or overflows the box both ways however turned."""
    half = world.region_half(region)[:2]
    if overflow(world.points(held), half) <= -FIT_SLACK_M:
        return None
    now = world.eef_mat()
    spin = list(Rotation.from_euler("z", TURNS[:, None]).as_matrix())
    fits = [
        (abs(t), r)
        for t, r in zip(TURNS, spin, strict=True)
        if overflow(turned(world, held, r @ now)[0], half) <= -FIT_SLACK_M
    ]
    center = world.site_pos(region)[:2]
    if not fits:
        return lean(world, held, half, center, now, spin)
    turn = min(fits, key=lambda f: f[0])[1]
    # The fingers' axis turned so; the yaw nearest now or half a turn away, as the wrist allows
    # over the box.
    orient = grasp_orientation(world, turn @ world.finger_axis(), at=center)
    pts, body = turned(world, held, orient)
    xy = center - (pts.min(0) + pts.max(0))[:2] / 2 + body[:2]
    return orient, np.clip(xy, center - half + FIT_MARGIN_M, center + half - FIT_MARGIN_M)


def lean(
    world: World, held: str, half: np.ndarray, center: np.ndarray, now: np.ndarray, spin: list[np.ndarray]
) -> tuple[np.ndarray, np.ndarray] | None:
    """(hand orientation, body position xy) that lean in an object too wide for the box on one axis
    only, turned by the least-overflowing turn: its footprint goes LEAN_INSIDE_M inside the box at one
    end and rests on the wall beyond the other, its middle over the box; let go, it tips in about that
    wall's top. libero_10-05 taper-s3's book is 14.5 cm wide at its foot against a 12.8 cm compartment:
    lowered centred it would rest on both side walls, its body position 1 cm over LIBERO's box; leaned,
    it tips in to 37 degrees and its body position passes into the box. None when both axes overflow.
    Of the two ends, the one that keeps the body position nearer the box's middle goes in."""
    scores = [overflow(turned(world, held, r @ now)[0], half) for r in spin]
    turn = spin[int(np.argmin(scores))]
    orient = grasp_orientation(world, turn @ world.finger_axis(), at=center)
    pts, body = turned(world, held, orient)
    over = (pts[:, :2].max(0) - pts[:, :2].min(0)) - 2 * half
    a = int(np.argmax(over))
    if over[1 - a] > -FIT_SLACK_M:
        return None
    mid = (pts.min(0) + pts.max(0))[:2] / 2
    shift = over[a] / 2 + LEAN_INSIDE_M
    off = body[a] - mid[a]
    sign = 1.0 if abs(shift + off) <= abs(-shift + off) else -1.0
    foot = center.copy()
    foot[a] += sign * shift
    xy = foot - mid + body[:2]
    return orient, np.clip(xy, center - half + FIT_MARGIN_M, center + half - FIT_MARGIN_M)
