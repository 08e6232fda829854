"""Open and close a drawer by its handle, along the slide joint's axis.

Opening: the handle is the part of the drawer that sticks out farthest along the opening direction
(the joint's world axis, signed toward the open end of its range). The hand turns to face the
drawer (pointing against the opening direction, fingers closing vertically) in front of the handle,
moves onto it, closes on it and pulls along the axis until LIBERO's `Open` check holds. Facing the
drawer matters: the handles of a cabinet's drawers stand one above the other, so a hand coming down
from above meets the handle over the one it wants. A handle lower over the table than half the
palm's length (libero_10-03's bottom drawer, 4.6 cm: the palm is 21 cm along the closing axis, so
a vertical pinch puts it on the table), or over what stands in front of the drawer under the palm
(libero_goal-00's middle drawer half open: its handle 9.6 cm over the plate's rim), is dragged instead: the closed fingertips, the hand leaning
down as for closing (its palm then under the handle above and clear of the table), press on the
handle's top and drag it along the axis. Neither a hook nor a horizontal pinch fits there: the
fingers (1.6 cm across) are as thick as the gap behind the bar, and the bar (8.9 cm) is longer than
the open fingers' 7.8 cm. Closing: the closed fingers, facing the drawer the same way but closing
horizontally (the hand's long side then stays off the table in front of a bottom drawer) and the
hand leaning down over the handle (its wrist above whatever stands in front of the drawer), push on
the handle along the axis until LIBERO's `Close` check holds (the cabinets count as closed only
once pushed fully home, where a hand pointing down would hit the handles above).
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from vpro_assets.core.mjgeom import geom_corners
from vpro_assets.rollout.policies.oracle import motion
from vpro_assets.rollout.policies.oracle.articulation import Joint, fully_open, joint_for
from vpro_assets.rollout.policies.oracle.clearance import obstacle_boxes
from vpro_assets.rollout.policies.oracle.hand import HAND_PARTS, PART_TOPS
from vpro_assets.rollout.policies.oracle.motion import CLOSE, OPEN, Actions
from vpro_assets.rollout.policies.oracle.world import SkillFailed, World

HANDLE_DEPTH_M = 0.012  # geoms within this of the outermost point along the axis form the handle
PULL_STEPS = 160
# Pinching, the hand pulls at this speed (of the action's box): at 0.5 it took 26 steps to open
# libero_goal-03's top drawer, at 0.8 17 (the drawer comes along, the pinch holds).
PULL_SPEED = 0.8
PUSH_STANDOFF_M = 0.03
FRONT_M = 0.12  # where the hand turns to face the drawer, in front of the handle
# Opening, the hand turns nearer: a top drawer out 75% (libero_goal-03 open75) put the point 12 cm in
# front of its handle so far out that the arm came there stretched to its limit (elbow straight) and
# stayed stuck 3 cm off the handle; nearer, it also saves about 10 steps.
OPEN_FRONT_M = 0.06
# Opening, the hand's last move onto the handle at full speed (the proportional law slows it for
# its last 2.5 cm): 4 steps fewer than at 0.5. The fingers close on the handle in PINCH_STEPS: one
# CLOSE action moves their target 1 cm, so 8 close them from open (8 cm) and a ninth presses; the
# pull's CLOSE actions hold on. 3 steps fewer than GRIPPER_STEPS.
ONTO_SPEED = 1.0
PINCH_STEPS = 9
ABOVE_M = 0.06
LEAVE_BACK_M = 0.08  # leaving, the hand backs away this far along the axis before it rises
# Closing, the hand leans this far below horizontal over the handle: its wrist then stays above what
# stands in front of a bottom drawer (libero_10-03's wine rack stopped a level wrist in 6 of 10 trials).
CLOSE_TILT_RAD = 0.8
PALM_HALF_M = HAND_PARTS[2][1]  # half the palm's length along the closing axis
PALM_HALF_WIDTH_M = HAND_PARTS[2][2]  # half the palm's width across the closing axis
# The palm's near and far ends behind the grip site, along the hand's pointing direction.
PALM_NEAR_M, PALM_FAR_M = -HAND_PARTS[2][3], PART_TOPS[2]
PALM_MARGIN_M = 0.01  # what stands this close beside the palm counts as under it
FINGERTIP_M = 0.012  # the closed fingertips reach this far past the grip site
PRESS_M = 0.03  # dragging, the grip site's goal this far below where it is: the fingertips press on the handle
PRESS_STEPS = 6
DRAG_STEP_M = 0.005  # dragging, the grip site's goal this far ahead of it along the axis
BACK_M = 0.003  # the fingertips this far behind the middle of the handle's top
VIA_M = 0.04  # a way point is passed once the grip site is this close
RELEASE_STEPS = 4  # opening, the fingers let go of the handle in this many steps
SLIP_M = 0.03  # the hand moved this much farther than the drawer: it slid off the handle
STALL_STEPS, STALL_M = 20, 0.002  # a drawer dragged this long that moved less than this is stuck


def open_direction(world: World, joint: Joint) -> np.ndarray:
    """World direction the drawer front moves when the drawer opens."""
    return world.d.xaxis[joint.id] * joint.open_sign


def handle_box(world: World, joint: Joint) -> tuple[np.ndarray, np.ndarray]:
    """World box of the handle: the drawer's collision geoms that stick out farthest along the axis."""
    axis = open_direction(world, joint)
    geoms = world.joint_geoms(joint.id)
    reach = {g: float((geom_corners(world.m, world.d, [g]) @ axis).max()) for g in geoms}
    front = max(reach.values())
    handle = [g for g, r in reach.items() if r > front - HANDLE_DEPTH_M]
    pts = geom_corners(world.m, world.d, handle)
    return pts.min(0), pts.max(0)


def handle_point(world: World, joint: Joint) -> np.ndarray:
    """Centre of the handle."""
    lo, hi = handle_box(world, joint)
    return (lo + hi) / 2


def pinch_fits(world: World, joint: Joint) -> bool:
    """Whether the hand can pinch the handle with its fingers closing vertically: the palm, as long
    as the closing axis, then reaches below the handle by half its length, over the table and over
    whatever stands under it in front of the drawer (a plate's rim the palm would rest on and slide
    along: libero_goal-00's half-open middle drawer, the grip then off the handle's middle)."""
    return float(handle_point(world, joint)[2]) - PALM_HALF_M > floor_under_palm(world, joint)


def floor_under_palm(world: World, joint: Joint) -> float:
    """The highest top, the table's or an obstacle's, under where the palm is while pinching the
    handle: in front of the handle from the palm's near to its far end, as wide as the palm."""
    axis = open_direction(world, joint)
    lo, hi = handle_box(world, joint)
    handle = (lo + hi) / 2
    outer = float(hi @ np.maximum(axis, 0) + lo @ np.minimum(axis, 0))  # the handle's face farthest out
    across = np.cross(axis, [0.0, 0.0, 1.0])
    boxes = obstacle_boxes(world, ())
    mid = (boxes[:, 0] + boxes[:, 1]) / 2
    half = (boxes[:, 1] - boxes[:, 0]) / 2
    along_c, along_r = mid @ axis - outer, half @ np.abs(axis)
    across_c, across_r = (mid - handle) @ across, half @ np.abs(across)
    span = PALM_HALF_WIDTH_M + PALM_MARGIN_M  # the pinch is at the handle's middle
    under = (along_c + along_r > PALM_NEAR_M) & (along_c - along_r < PALM_FAR_M) & (np.abs(across_c) < span + across_r)
    under &= boxes[:, 1, 2] < handle[2]  # below the handle, not what the palm passes beside
    return max(world.table_z, float(boxes[under, 1, 2].max(initial=-np.inf)))


def face_handle(
    world: World,
    joint: Joint,
    grip: float,
    standoff: float,
    vertical: bool,
    tilt: float = 0.0,
    turn_early: bool = False,
    front_m: float = FRONT_M,
    last_speed: float = 0.5,
) -> motion.Posing:
    """Bring the hand, facing the drawer, to `standoff` in front of the handle; the orientation.
    `vertical`: the fingers close vertically (to pinch a horizontal bar); else horizontally, which
    keeps the hand's long side off the table in front of a bottom drawer. `tilt`: the hand points
    this far (rad) below horizontal. `turn_early`: the hand turns on its way to the point above the
    front, passing through it (about 10 steps fewer); else it turns only there (the hand leaning down
    to push a bottom drawer, turning on the way, stalled against libero_10-03's wine rack). `front_m`:
    how far in front of the handle it turns; `last_speed`: the speed of its last move, onto the
    handle."""
    axis = open_direction(world, joint)
    handle = handle_point(world, joint)
    fingers = np.array([0.0, 0.0, 1.0]) if vertical else np.cross(axis, [0.0, 0.0, 1.0])
    orient = motion.facing(-axis * np.cos(tilt) - np.array([0.0, 0.0, np.sin(tilt)]), fingers, world.eef_mat())
    front = handle + axis * front_m
    if turn_early:
        yield from motion.move_to(world, front + [0, 0, ABOVE_M], grip, orient, tol=VIA_M, max_steps=120, turn_tol=None)
    else:
        yield from motion.move_to(world, front + [0, 0, ABOVE_M], grip, None, tol=0.015, max_steps=120)
    yield from motion.move_to(world, front, grip, orient, tol=0.012, max_steps=120)
    yield from motion.move_to(world, handle + axis * standoff, grip, orient, tol=0.008, max_steps=80, speed=last_speed)
    return orient


def leave(world: World, joint: Joint, grip: float, turn_on: bool = False) -> Actions:
    """Back away from the drawer and point the hand down again. `turn_on`: the turn down need not
    be done when the hand is up (a way point: the next skill's first move, turning the hand too,
    ends it on its way)."""
    axis = open_direction(world, joint)
    down = motion.down_with_yaw(float(np.arctan2(axis[1], axis[0])))
    yield from motion.move_to(world, world.eef() + axis * LEAVE_BACK_M, grip, None, tol=0.015, max_steps=40)
    turn_tol = None if turn_on else motion.TURN_TOL
    yield from motion.move_to(
        world, world.eef() + [0, 0, ABOVE_M], grip, down, tol=0.02, max_steps=80, turn_tol=turn_tol
    )


def open_(world: World, region: str, attempts: int = 2, full: bool = False) -> Actions:
    """`full`: out to the end of the drawer's range, not only as far as LIBERO's Open (an object going
    in wide end first: an inverted bowl's 10.7 cm rim passes libero_10-03's bottom drawer's mouth,
    10.4 cm between its front wall and the handles above at -0.146, only out at -0.16)."""
    joint = joint_for(world, region)
    goal = ("open", region)

    def done() -> bool:
        return world.holds(goal) and (not full or fully_open(world, region))

    for _ in range(attempts):
        if done():
            return
        if not pinch_fits(world, joint):
            yield from drag(world, joint, done)
            continue
        axis = open_direction(world, joint)
        orient = yield from face_handle(
            world, joint, OPEN, 0.0, vertical=True, turn_early=True, front_m=OPEN_FRONT_M, last_speed=ONTO_SPEED
        )
        yield from motion.gripper(world, CLOSE, steps=PINCH_STEPS, orient=orient)
        travel = abs(joint.open_end - world.qpos(joint.id))
        start = world.eef()
        for _ in range(PULL_STEPS):
            if done():
                break
            yield motion.action_to(world, start + axis * (travel + 0.01), CLOSE, orient, speed=PULL_SPEED)
        # A few steps open the fingers off the handle; they open on while the hand backs away.
        yield from motion.gripper(world, OPEN, steps=RELEASE_STEPS, orient=orient)
        yield from leave(world, joint, OPEN, turn_on=True)
    if not world.holds(goal):
        raise SkillFailed(f"{region} did not open (joint at {world.qpos(joint.id):.3f})")


def drag(world: World, joint: Joint, done: Callable[[], bool]) -> Actions:
    """Open a low drawer by friction: the closed fingertips, the hand leaning down over the handle as
    for closing, press on the handle's top and drag it along the axis."""
    axis = open_direction(world, joint)
    lo, hi = handle_box(world, joint)
    top = np.array([(lo[0] + hi[0]) / 2, (lo[1] + hi[1]) / 2, hi[2]])
    approach = -axis * np.cos(CLOSE_TILT_RAD) - np.array([0.0, 0.0, np.sin(CLOSE_TILT_RAD)])
    orient = motion.facing(approach, np.cross(axis, [0.0, 0.0, 1.0]), world.eef_mat())
    touch = top - axis * BACK_M - approach * FINGERTIP_M + [0, 0, 0.004]
    yield from motion.move_to(world, touch + axis * FRONT_M + [0, 0, ABOVE_M], CLOSE, None, tol=0.015, max_steps=120)
    yield from motion.move_to(world, touch - approach * 0.05, CLOSE, orient, tol=0.012, max_steps=120)
    yield from motion.move_to(world, touch, CLOSE, orient, tol=0.008, max_steps=60, speed=0.5)
    press = np.array([0.0, 0.0, -PRESS_M])
    for _ in range(PRESS_STEPS):
        yield motion.action_to(world, touch + press, CLOSE, orient)
    q0, start = world.qpos(joint.id), touch + press
    travel = abs(joint.open_end - q0)
    for k in range(PULL_STEPS):
        if done():
            break
        moved = abs(world.qpos(joint.id) - q0)
        if float((world.eef() - touch) @ axis) - moved > SLIP_M or (k >= STALL_STEPS and moved < STALL_M):
            break  # slid off the handle, or the drawer does not move
        yield motion.action_to(world, start + axis * min(DRAG_STEP_M * (k + 1), travel + 0.02), CLOSE, orient)
    # Up first (behind the hand, the wrist is over what stands in front of the drawer), then turn down.
    up = world.eef() + [0, 0, ABOVE_M]
    yield from motion.move_to(world, up, CLOSE, orient, tol=0.02, max_steps=40)
    down = motion.facing([0.0, 0.0, -1.0], np.cross(axis, [0.0, 0.0, 1.0]), world.eef_mat())
    yield from motion.move_to(world, up, CLOSE, down, tol=0.02, max_steps=60)


def close(world: World, region: str) -> Actions:
    joint = joint_for(world, region)
    goal = ("close", region)
    if world.holds(goal):
        return
    axis = open_direction(world, joint)
    yield from motion.gripper(world, CLOSE)
    orient = yield from face_handle(world, joint, CLOSE, PUSH_STANDOFF_M, vertical=False, tilt=CLOSE_TILT_RAD)
    start = world.eef()
    travel = abs(world.qpos(joint.id) - joint.closed_end)
    for _ in range(PULL_STEPS):
        if world.holds(goal):
            break
        yield motion.action_to(world, start - axis * (travel + PUSH_STANDOFF_M + 0.02), CLOSE, orient, speed=0.6)
    yield from leave(world, joint, CLOSE)
    if not world.holds(goal):
        raise SkillFailed(f"{region} did not close (joint at {world.qpos(joint.id):.3f})")
