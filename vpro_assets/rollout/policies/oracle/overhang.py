"""A wall pinch of a bowl standing partly under an overhang (libero_goal-03's bowl once the top
drawer is open over it), planned with the hand's actual shape on its actual side.

`grasp.plan_grasp` models the wrist as reaching 9 cm to both sides of the grip site along the closing
axis and 4.4 cm across, since which side it is on depends on the yaw. Under the drawer no radial
side is then free from above, and the sideways entry it falls back to (`grasp.side_entry`) comes
down 4-6 cm along a round wall: the inner finger lands on the rim (libero_goal-03 taper-s3, trials 2-5,
8, 9). Here the wrist is where the Panda's link7 really is for the yaw the pick will turn to (its
collision mesh, measured in the hand's frame: 8.8 cm toward the left finger, 5.4 cm toward the right,
3.8 and 5.2 cm to either side across, narrower toward its ends), the closing axis may turn off the radial direction, and a
pinch is kept only where both fingers come down clear of the object's own wall: one inside its mouth,
the other outside it.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from vpro_assets.rollout.policies.oracle.hand import FINGER_HALF_WIDTH_M, FINGER_THICK_M, FINGERTIP_M, under_parts
from vpro_assets.rollout.policies.oracle.shape import section

OPEN_GAP_M = 0.08  # the open fingers' pads this far apart
# The open hand's parts in its own frame: (along the closing axis toward the left finger, across it
# (the left finger's direction turned a quarter left), half along, half across, bottom below the grip
# site, top above it). The palm and link7 from their collision meshes (robosuite's Panda).
FINGER_ALONG_M = OPEN_GAP_M / 2 + FINGER_THICK_M / 2
PARTS = (
    (FINGER_ALONG_M, 0.0, FINGER_THICK_M / 2, FINGER_HALF_WIDTH_M, FINGERTIP_M, 0.026),
    (-FINGER_ALONG_M, 0.0, FINGER_THICK_M / 2, FINGER_HALF_WIDTH_M, FINGERTIP_M, 0.026),
    (-0.002, 0.005, 0.102, 0.032, -0.026, 0.124),  # the palm
    # The wrist (robot0_link7, 9.5-15.4 cm over the grip site): its footprint, rounded toward the
    # right finger, in three boxes (along -5.4 to -3, -3 to 3, 3 to 8.8 cm).
    (-0.042, 0.007, 0.012, 0.033, -0.095, 0.154),
    (0.0, 0.007, 0.03, 0.045, -0.095, 0.154),
    (0.059, 0.007, 0.029, 0.041, -0.095, 0.154),
)
RING_SIDES = 48  # grip points around the wall
RING_OFFSETS_M = (-0.012, -0.004, 0.004)  # the grip point this far out from the object's outer radius
AXIS_TURN_MAX_DEG, AXIS_TURN_STEP_DEG = 45.0, 7.5  # the closing axis turned off the radial direction
FINGER_CLEAR_M = (
    0.0  # each finger this far clear of the wall, coming down (the radii are already the worst of 40 degrees)
)
SECTOR_RAD = np.radians(20)  # the wall's radius at a finger's corner: of the points this close in angle
RIM_BELOW_M = 0.004  # the mouth measured this far below the rim
# A sideways entry (`grasp.side_entry`) whose inner finger comes down at most this far over the
# mouth's edge grazes the rim and slides in: libero_goal-03's round bowls (Normal trial 3, open50
# trial 0, asymmetric-s1 trial 5: 0.9-2.7 mm over, entries of 4 cm, solved so); on taper-s3's rim,
# narrowed to 3.8 cm, the same entries land 12-17 mm over it and the fingers close on the rim.
RIM_SLACK_M = 0.005


def placed_parts(point: np.ndarray, left: np.ndarray) -> list[tuple[np.ndarray, np.ndarray, tuple]]:
    """Each part of PARTS as (its centre, the closing axis, (half along, half across, bottom, top)),
    the hand pointing down over `point` with its left finger toward `left` (a horizontal unit vector)."""
    across = np.array([-left[1], left[0], 0.0])
    return [(point + left * a + across * c, left, tuple(rest)) for a, c, *rest in PARTS]


def blocked(boxes: np.ndarray, point: np.ndarray, left: np.ndarray) -> bool:
    """Whether any obstacle box ((N, 2, 3) world boxes) stops the open hand coming down to `point`
    (any box over a part's footprint higher than the part's bottom there)."""
    for centre, axis, (half_along, half_across, below, _top) in placed_parts(point, left):
        under = under_parts(boxes, centre, axis, ((0.0, half_along, half_across, below),))[0]
        if np.any(under & (boxes[:, 1, 2] > point[2] - below)):
            return True
    return False


def wall_radii(hulls: list[np.ndarray], center: np.ndarray) -> tuple[np.ndarray, np.ndarray] | None:
    """(the mouth's radius, the object's outer radius) about `center`, per degree of angle: the least
    radius of the section RIM_BELOW_M under the rim, and the greatest of all the object's points, of
    the points within SECTOR_RAD in angle. None when the section is empty."""
    pts = np.concatenate(hulls)
    rim = section(hulls, float(pts[:, 2].max()) - RIM_BELOW_M)
    if not len(rim):
        return None
    degrees = np.radians(np.arange(360))
    radii = []
    for xy, pick in ((rim[:, :2], np.min), (pts[:, :2], np.max)):
        r, ang = _polar(xy - center[:2])
        off = np.abs(np.angle(np.exp(1j * (ang[None, :] - degrees[:, None]))))
        radii.append(np.array([pick(r[o < SECTOR_RAD]) if np.any(o < SECTOR_RAD) else np.nan for o in off]))
    return radii[0], radii[1]


def fingers_clear(
    radii: tuple[np.ndarray, np.ndarray], center: np.ndarray, point: np.ndarray, left: np.ndarray, slack: float = 0.0
) -> bool:
    """Whether, the hand over `point`, one open finger comes down inside the object's mouth and the
    other outside it, each corner FINGER_CLEAR_M clear of the wall (`wall_radii`); the inner one
    may reach `slack` over the mouth's edge."""
    mouth, outer = radii
    across = np.array([-left[1], left[0]])
    inside = outside = 0
    for centre, axis, (half_along, half_across, *_) in placed_parts(point, left)[:2]:
        corners = [
            centre[:2] + axis[:2] * a + across * c
            for a in (-half_along, half_along)
            for c in (-half_across, half_across)
        ]
        r, ang = _polar(np.array(corners) - center[:2])
        k = np.round(np.degrees(ang)).astype(int) % 360
        inside += bool(np.all(r < mouth[k] - FINGER_CLEAR_M + slack))
        outside += bool(np.all(r > outer[k] + FINGER_CLEAR_M))
    return inside == 1 and outside == 1


def lands_clear(hulls: list[np.ndarray], point: np.ndarray, axis: np.ndarray) -> bool:
    """Whether the open hand coming down over `point`, fingers closing along `axis`, has one finger
    inside the object's mouth, at most RIM_SLACK_M over its edge, and the other outside its wall
    (`fingers_clear`)."""
    pts = np.concatenate(hulls)
    center = np.append((pts.min(0)[:2] + pts.max(0)[:2]) / 2, 0.0)
    radii = wall_radii(hulls, center)
    return radii is not None and fingers_clear(radii, center, point, axis, RIM_SLACK_M)


def overhang_pinch(
    hulls: list[np.ndarray], boxes: np.ndarray, z: float, toward: np.ndarray, room: Callable[[np.ndarray], bool]
) -> tuple[np.ndarray, np.ndarray] | None:
    """(grip point, the left finger's direction) of a wall pinch at height `z` that the open hand
    comes straight down to with nothing in its way and both fingers clear of the wall
    (`fingers_clear`), the wrist able to turn there (`room(left)`): grip points RING_SIDES ways around
    the wall at RING_OFFSETS_M from its outer radius, the closing axis turned up to AXIS_TURN_MAX_DEG
    off the radial direction. Of those, the least turned, then the nearest `toward` (the robot). None
    when there is none."""
    pts = np.concatenate(hulls)
    center = np.append((pts.min(0)[:2] + pts.max(0)[:2]) / 2, 0.0)
    radii = wall_radii(hulls, center)
    if radii is None:
        return None
    near = boxes[
        np.all(boxes[:, 1, :2] > center[:2] - 0.35, axis=1) & np.all(boxes[:, 0, :2] < center[:2] + 0.35, axis=1)
    ]
    turns = sorted(np.arange(-AXIS_TURN_MAX_DEG, AXIS_TURN_MAX_DEG + 1e-9, AXIS_TURN_STEP_DEG), key=abs)
    best: tuple[tuple[float, float], np.ndarray, np.ndarray] | None = None
    for k in range(RING_SIDES):
        ang = 2 * np.pi * k / RING_SIDES
        out = np.array([np.cos(ang), np.sin(ang), 0.0])
        for offset in RING_OFFSETS_M:
            point = center + out * (radii[1][round(np.degrees(ang)) % 360] + offset)
            point[2] = z
            for turn in turns:
                key = (abs(float(turn)), -float(out @ toward))
                if best is not None and key >= best[0]:
                    break
                t = np.radians(turn)
                axis = np.array([out[0] * np.cos(t) - out[1] * np.sin(t), out[0] * np.sin(t) + out[1] * np.cos(t), 0.0])
                for left in (axis, -axis):
                    if fingers_clear(radii, center, point, left) and room(left) and not blocked(near, point, left):
                        best = (key, point, left)
                        break
    return None if best is None else (best[1], best[2])


def _polar(xy: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    return np.linalg.norm(xy, axis=1), np.arctan2(xy[:, 1], xy[:, 0])
