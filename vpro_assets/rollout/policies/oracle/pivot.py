"""Standing a flat book up on its bottom end before it goes into a region (`plan`).

libero_10-05's book (object_pose-v1-lying) lies flat on the table: 11 x 13.5 cm across, wider than
the open fingers (7.6 cm) every way, 2.9 cm thick, 6 mm from the caddy's wall. The pick found no
pinch (0 of 10 trials). Levering it onto its end did not work: a finger pushing its end face while
rising slid the 42 g book across the table before friction raised that end (a corner rose 5 mm);
the hand tilted to put one finger at the end face and the other on the cover pressed it down
(16 N); and a stop at the far end must stay under the book's top, since a taller one (the caddy's
wall) blocks the upper corner from turning (the caddy's base plate, 1.6 cm high, stands 5 mm out
from the wall: 10 degrees of turn at most).

The fingers' pads (friction 2.0, the book's 0.95) take the book across one corner of its top end
(`corner_pinch`): one pad on the top end's face, the other on the side face, the contacts CHORD_M
apart on a line ANGLE_RAD off the side face's normal, each inside its pad's friction cone (63
degrees); lifted so, the book stayed flat in the fingers. Held so, the hand turns it a quarter turn
about its bottom end's lower edge (`pivot`), the grip site on the circle about that edge and the
hand turning with the book, lets go and turns back to pointing down; the book stands on its bottom
face, upright, where the ordinary pick takes it as in libero_10-05's Normal (object_pose-v1-lying:
10 of 10 trials, 278 to 292 steps of 520). Of the top end's two corners it takes the one away from
the caddy (`hand.reach_height`); the line's angle keeps the palm off the mug beside the book
(2.6 to 6.2 cm from it).
"""

from __future__ import annotations

import numpy as np
from scipy.spatial.transform import Rotation

from vpro_assets.rollout.policies.oracle import lay, motion, turn_over
from vpro_assets.rollout.policies.oracle.articulation import is_fixture_region
from vpro_assets.rollout.policies.oracle.clearance import obstacle_boxes
from vpro_assets.rollout.policies.oracle.hand import FINGERTIP_M, HAND_PARTS, reach_height
from vpro_assets.rollout.policies.oracle.motion import CLOSE, OPEN, Actions
from vpro_assets.rollout.policies.oracle.shape import MAX_PINCH_M, narrowest
from vpro_assets.rollout.policies.oracle.world import SkillFailed, World

# The pinch line 55 degrees off the side face's normal (35 off the end face's), its contacts 5 cm
# apart: inside the pads' friction cones (63 degrees) both, and the hand clear of the mug. 35
# degrees and 4 cm: the hand came down on the mug in 5 of 10 trials; 50 to 60 degrees, 5 to 5.5 cm
# stood the book up in 10 of 10.
ANGLE_RAD, CHORD_M = np.radians(55.0), 0.05
# The open hand as `hand.HAND_PARTS` has it, its palm measured closer (robosuite's Panda
# `hand_collision` hull): 18.6 x 3.2 cm from 2.6 cm over the grip site, 20.1 x 3.8 cm from 3.4 cm,
# 21 x 6.6 cm from 5 cm; which of the top end's two corners the hand comes down to lower.
PINCH_HAND = (
    *HAND_PARTS[:2],
    (0.0, 0.093, 0.016, -0.026),
    (0.0, 0.1005, 0.019, -0.034),
    (0.0, 0.105, 0.033, -0.05),
)
TIP_CLEAR_M = 0.005  # the fingertips this far over the table at the pinch
HOVER_M = 0.06
PIVOT_STEP_DEG, PIVOT_WAY_STEPS = 10.0, 15  # way points of the quarter turn
PIVOT_TOL_M, PIVOT_TURN_TOL = 0.006, 0.08
UPRIGHT_COS = np.cos(np.radians(30.0))  # stood up: its up axis this near the vertical
RISE_M = 0.08  # let go, the hand rises this far, then turns back to pointing down
UNTURN_STEPS = 40


def lies_flat(world: World, obj: str) -> bool:
    """Whether `obj` lies on its side (`lay.lying`) with its thinnest extent upright: a book flat on
    its cover, not standing on its spine."""
    if not lay.lying(world, obj):
        return False
    pts = world.points(obj)
    return float(np.ptp(pts[:, 2])) < narrowest(pts)[1]


def needs_pivot(world: World, obj: str, region: str) -> bool:
    """Whether `obj`, lying flat, too wide every way for the open fingers and thin enough for a pad
    to meet its edge, must be stood up to go `In` `region`: a region of a fixture (not a drawer's)."""
    if not is_fixture_region(world, region) or not lies_flat(world, obj):
        return False
    pts = world.points(obj)
    return narrowest(pts)[1] > MAX_PINCH_M and float(np.ptp(pts[:, 2])) < MAX_PINCH_M


def _frame(world: World, obj: str) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(the level up axis, the level axis across it, the object's points)."""
    up = lay.up_axis(world, obj)
    if up is None:
        raise SkillFailed(f"{obj} has no measured up axis to stand it on")
    up = np.append(up[:2], 0.0) / np.linalg.norm(up[:2])
    return up, np.array([-up[1], up[0], 0.0]), world.points(obj)


def corner_pinch(world: World, obj: str) -> tuple[np.ndarray, np.ndarray]:
    """(the grip site, the fingers' closing axis) of a pinch across a corner of `obj`'s top end,
    its contacts CHORD_M apart on a line ANGLE_RAD off the side face's normal, at mid-thickness: of
    the two corners, the one the open hand pointing down comes down to lower (`hand.reach_height`;
    the other is the caddy's side)."""
    up, across, pts = _frame(world, obj)
    z = float(pts[:, 2].min()) + max(float(np.ptp(pts[:, 2])) / 2, FINGERTIP_M + TIP_CLEAR_M)
    boxes = obstacle_boxes(world, (obj,))
    centre = (pts.min(0) + pts.max(0)) / 2
    top = float((pts[:, :2] @ up[:2]).max() - centre[:2] @ up[:2])
    pinches = []
    for side in (across, -across):
        corner = centre + up * top + side * float((pts[:, :2] @ side[:2]).max() - centre[:2] @ side[:2])
        point = corner - CHORD_M / 2 * (np.cos(ANGLE_RAD) * side + np.sin(ANGLE_RAD) * up)
        point[2] = z
        pinches.append((point, np.cos(ANGLE_RAD) * side - np.sin(ANGLE_RAD) * up))
    return min(pinches, key=lambda pinch: reach_height(boxes, pinch[0], pinch[1], PINCH_HAND))


def _orientation(world: World, axis: np.ndarray) -> tuple[np.ndarray, float]:
    """(the hand pointing down, fingers along `axis`; the turn about the vertical to it): of the
    two yaws and their turns either way round, the one leaving the wrist's last joint nearest the
    middle of its range (the quarter turn that follows moves it by about a radian, either way)."""
    now = motion.yaw_of(world.eef_mat())
    per_rad = float(world.d.xaxis[world.wrist_joint][2])
    lo, hi = (float(x) for x in world.m.jnt_range[world.wrist_joint])
    q = world.qpos(world.wrist_joint)
    turn = min(motion.yaw_turns(world, axis), key=lambda t: (abs(q + t * per_rad - (lo + hi) / 2), abs(t)))
    return motion.down_with_yaw(now + turn), turn


def pivot(world: World, obj: str, angle_deg: float = 90.0) -> Actions:
    """Turn the pinched, flat `obj` `angle_deg` about its bottom end's lower edge, its top end up:
    the grip site moves on the circle about that edge, the hand turning with the object."""
    up, _, pts = _frame(world, obj)
    axis = np.cross(up, [0.0, 0.0, 1.0])
    edge = (pts.min(0) + pts.max(0)) / 2
    edge[:2] += up[:2] * float((pts[:, :2] @ up[:2]).min() - edge[:2] @ up[:2])
    edge[2] = float(pts[:, 2].min())
    start, orient = world.eef() - edge, world.eef_mat()
    for deg in np.arange(PIVOT_STEP_DEG, angle_deg + 1e-9, PIVOT_STEP_DEG):
        turn = Rotation.from_rotvec(axis * np.radians(deg)).as_matrix()
        yield from motion.move_to(
            world,
            edge + turn @ start,
            CLOSE,
            turn @ orient,
            tol=PIVOT_TOL_M,
            max_steps=PIVOT_WAY_STEPS,
            turn_tol=PIVOT_TURN_TOL,
        )


def stand_up(world: World, obj: str) -> Actions:
    """Stand the flat `obj` upright on its bottom end: pinch a corner of its top end (`corner_pinch`),
    pivot it a quarter turn (`pivot`), let go, rise and turn the hand back to pointing down as it
    came (the pick that follows turns it from there: turned from pointing sideways, the wrist's
    last joint ran into its limit in 1 of 10 trials)."""
    point, axis = corner_pinch(world, obj)
    down, turn = _orientation(world, axis)
    world.hold_grip = OPEN
    over = point + [0.0, 0.0, HOVER_M]
    yield from motion.turn_about(
        world,
        motion.UP,
        turn,
        at=np.array([*over[:2], max(over[2], world.eef()[2])]),
        tol=turn_over.TURN_HOLD_M,
        max_steps=turn_over.TURN_STEPS,
    )
    yield from motion.move_to(world, over, OPEN, down, tol=0.01, max_steps=40)
    yield from motion.move_to(world, point, OPEN, down, tol=0.004, max_steps=40, speed=0.5, stall_steps=5)
    yield from motion.gripper(world, CLOSE, steps=15, orient=down)
    if not world.held(obj):
        yield from motion.gripper(world, OPEN, orient=down)
        raise SkillFailed(f"{obj}'s corner not pinched")
    world.hold_grip = CLOSE
    yield from pivot(world, obj)
    world.hold_grip = OPEN
    yield from motion.gripper(world, OPEN, orient=world.eef_mat())
    yield from motion.move_to(world, world.eef() + [0.0, 0.0, RISE_M], OPEN, world.eef_mat(), tol=0.01, max_steps=20)
    yield from motion.turn_in_place(world, down, UNTURN_STEPS)
    up = lay.up_axis(world, obj)
    if up is None or up[2] < UPRIGHT_COS:
        raise SkillFailed(f"{obj} not upright after standing it up (up axis {up})")
