"""The pick skill: a grasp planned from the object's geometry (`grasp.plan_grasp`) executed through
the OSC action: approach over it, descend (sliding in under an overhang where the grasp enters from
the side; to a gentle pinch far out and high, from nearer the arm's base, `come_out`), close (on a
wall, across, or gently to a target opening), lift, and check that the object came up with both
fingers on it; planned again and retried when it did not.
"""

from __future__ import annotations

import numpy as np

from vpro_assets.rollout.policies.oracle import motion, reach
from vpro_assets.rollout.policies.oracle.clearance import lift_clear, obstacle_boxes
from vpro_assets.rollout.policies.oracle.grasp import (
    HOVER_M,
    ROBOT_BASE_XY,
    Grasp,
    grasp_orientation,
    plan_grasp,
)
from vpro_assets.rollout.policies.oracle.hand import FINGERTIP_M, WITH_WRIST, reach_height
from vpro_assets.rollout.policies.oracle.motion import CLOSE, OPEN, Actions
from vpro_assets.rollout.policies.oracle.world import SkillFailed, World

CLEAR_ABOVE_TABLE_M = 0.40  # overhangs below this height over a grasped object are slid out from under
LIFT_M = 0.10  # lift after closing, before any carry
MIN_LIFT_M = 0.02  # the object counts as lifted when it rose this much
# A gentle pinch (`foot_grasp`) farther out than FAR_M is approached at FAR_APPROACH_SPEED and
# closed with the hand at rest (`settle`); nearer ones (libero_spatial-00 to -03's inverted bowls,
# at most 0.745 m out) as before.
FAR_M, FAR_APPROACH_SPEED = 0.75, 0.5
SETTLE_M, SETTLE_STILL_M, SETTLE_STEPS = 0.001, 0.0003, 20
# A gentle pinch far out and high is reached from nearer the base where it can be (`inner_way`,
# `come_out`): the open hand comes down INNER_M nearer the arm's base than the pinch, its fingertips
# FINGERTIPS_CLEAR_M over the object's top, goes out there at OUT_SPEED, its last OUT_SLOW_M at
# OUT_SLOW_SPEED, then down to within REACH_TOL_M of the pinch (at most REACH_STEPS steps). Which
# pinches, measured: on libero_spatial-09's cabinet (1.18 m, 0.28 m over the table) the pinch from
# above failed from 0.726 m out (9 of 9 trials; 0.70 m solved); on the table (libero_spatial-03's
# cookie box, 0.07 m over it) it solves 0.72-0.75 m in about 120 steps, where from nearer the base
# the hand comes down 20 cm (overshooting into the bowl at full speed, 1 of 10 solved; slowed, 190-206
# steps), and libero_spatial-06's 0.78-0.80 m lost 1-2 of 7 solved trials with it.
INNER_FROM_M = 0.72  # (horizontally) farther than this from the arm's base
INNER_ABOVE_TABLE_M = 0.15  # the pinch higher than this over the table
INNER_M, FINGERTIPS_CLEAR_M = 0.04, 0.003
OUT_SPEED, OUT_SLOW_M, OUT_SLOW_SPEED = 0.3, 0.012, 0.1
REACH_TOL_M, REACH_STEPS = 0.0015, 30
WAY_SAMPLES = 5  # points of the way out where the hand is tested against the obstacles
ENTRY_STALL_STEPS = 5  # sliding in under an overhang, a hand stopped this many steps closes where it is
# A wall pinch closes only while the grip site stays this close (horizontally) to where the close began
# (`close_on_wall`; under WALL_INSET_M); a hand swayed farther is held there for at most SWAY_STEPS
# while it comes back.
SWAY_M, SWAY_STEPS = 0.01, 30


def pick(
    world: World, instance: str, attempts: int = 3, toward: np.ndarray | None = None, planned: Grasp | None = None
) -> Actions:
    """Grasp `instance` (on its `toward` side, see `plan_grasp`) and lift it LIFT_M; SkillFailed
    when it does not come up after `attempts`. `planned`: `plan_grasp`'s grasp made in the state the
    pick starts in (the caller's, not planned again); later attempts plan anew."""
    for attempt in range(attempts):
        grasp = planned if attempt == 0 and planned is not None else plan_grasp(world, instance, toward)
        world.hung = grasp.hung
        orient = grasp_orientation(world, grasp.axis, grasp.sided)
        start_z = world.body_pos(instance)[2]
        entry = grasp.entry
        inner = inner_way(world, instance, grasp) if _reached_from_inside(world, grasp) else None
        over = grasp.point + entry if inner is None else inner
        above = over + [0, 0, HOVER_M]
        above[2] = max(above[2], world.eef()[2] if attempt == 0 else above[2])
        above = reach.lowered(world, above, over[2] + HOVER_M)  # far out, no higher than the arm reaches bent
        if inner is not None and grasp.squeeze_to is not None:  # (`_reached_from_inside`: a gentle pinch)
            world.hold_grip = 0.0
            yield from motion.move_to(world, above, OPEN, orient, tol=0.015, max_steps=150)
            yield from come_out(world, grasp, inner, orient)
            yield from squeeze(world, grasp.squeeze_to, orient, hold=grasp.point)
            yield from _lift(world, instance, orient)
            if _lifted(world, instance, start_z):
                return
            yield from motion.gripper(world, OPEN, orient=orient)
            continue
        yield from motion.move_to(world, above, OPEN, orient, tol=0.015, max_steps=150, speed=_approach_speed(grasp))
        yield from motion.move_to(world, over + [0, 0, HOVER_M], OPEN, orient, tol=0.01, max_steps=60)
        if grasp.squeeze_to is None:
            world.hold_grip = CLOSE if grasp.close_to is None else 0.0  # 0: hold the gentle close's target
            yield from motion.move_to(world, grasp.point + entry, OPEN, orient, tol=0.006, max_steps=80, speed=0.6)
            if entry.any():  # slide in under the overhang, and after the close, back out with the object
                yield from motion.move_to(
                    world, grasp.point, OPEN, orient, tol=0.006, max_steps=60, speed=0.4, stall_steps=ENTRY_STALL_STEPS
                )
            if grasp.rim and not entry.any():
                yield from close_on_wall(world, instance, orient)
            elif grasp.close_to is not None:
                yield from squeeze(world, grasp.close_to, orient)
            else:
                yield from motion.gripper(world, CLOSE, orient=orient)
            if entry.any():
                yield from motion.move_to(world, world.eef() + entry, CLOSE, orient, tol=0.006, max_steps=60, speed=0.4)
        else:
            world.hold_grip = 0.0  # keep the fingers' target where the gentle close leaves it
            yield from motion.move_to(world, grasp.point, OPEN, orient, tol=0.001, max_steps=120, speed=0.4)
            if _far(grasp):
                yield from settle(world, grasp.point, orient)
            yield from squeeze(world, grasp.squeeze_to, orient)
        yield from _lift(world, instance, orient)
        if _lifted(world, instance, start_z):
            return
        yield from motion.gripper(world, OPEN, orient=orient)
    raise SkillFailed(f"could not lift {instance} in {attempts} attempts")


def _lift(world: World, instance: str, orient: np.ndarray) -> Actions:
    """Raise the closed hand LIFT_M, first out from under any overhang."""
    yield from lift_clear(world, instance, world.table_z + CLEAR_ABOVE_TABLE_M)
    yield from motion.move_to(
        world, world.eef() + [0, 0, LIFT_M], world.hold_grip, orient, tol=0.015, max_steps=60, speed=0.5
    )


def _lifted(world: World, instance: str, start_z: float) -> bool:
    """Whether the object rose MIN_LIFT_M from `start_z` with the fingers still apart on it."""
    return bool(world.body_pos(instance)[2] - start_z > MIN_LIFT_M and world.finger_gap() > 0.002)


def _far(grasp: Grasp, far_m: float = FAR_M) -> bool:
    """Whether a grasp's grip point lies farther than `far_m` from the arm's base."""
    return float(np.linalg.norm(grasp.point[:2] - ROBOT_BASE_XY)) > far_m


def _reached_from_inside(world: World, grasp: Grasp) -> bool:
    """Whether a grasp is a gentle pinch far out (farther than INNER_FROM_M) and high (more than
    INNER_ABOVE_TABLE_M over the table), reached from nearer the arm's base (`come_out`) where the
    way is clear (`inner_way`)."""
    high = grasp.point[2] - world.table_z > INNER_ABOVE_TABLE_M
    return grasp.squeeze_to is not None and high and _far(grasp, INNER_FROM_M)


def _approach_speed(grasp: Grasp) -> float:
    """The speed of the hand's way over a grasp: FAR_APPROACH_SPEED over a gentle pinch far out
    (`_far`: coming out there at full speed, the arm straightens its elbow to its limit and the grip
    site then stops short of the pinch: libero_spatial-04's inverted bowl in the drawer, 80-120
    steps), full speed otherwise."""
    return FAR_APPROACH_SPEED if _far(grasp) and grasp.squeeze_to is not None else 1.0


def settle(world: World, point: np.ndarray, orient: np.ndarray) -> Actions:
    """Hold the open hand at `point` until the grip site is within SETTLE_M of it and has come to
    rest (moved less than SETTLE_STILL_M in a step), at most SETTLE_STEPS steps: a hand that
    arrives moving drifts on 2-4 mm (far out, libero_spatial-04's inverted bowl in its drawer), and a
    foot pinch 2 mm low closes on the shoulders, which let the bowl go as it rises."""
    last = None
    for _ in range(SETTLE_STEPS):
        now = world.eef()
        if last is not None and np.linalg.norm(now - point) < SETTLE_M and np.linalg.norm(now - last) < SETTLE_STILL_M:
            return
        last = now
        yield motion.action_to(world, point, OPEN, orient, speed=0.4)


def close_on_wall(world: World, instance: str, orient: np.ndarray) -> Actions:
    """Close the fingers on a wall pinch in place (`motion.gripper`'s GRIPPER_STEPS closing actions),
    but only while the grip site stays within SWAY_M (horizontally) of where the close began: while
    it is farther and no finger touches the object yet, the fingers stop where they are (gripper
    action 0) and the hand is held there (at most SWAY_STEPS steps). Once a finger touches it, the
    close goes on: stopped against a lobe of libero_spatial-07's multipeak-s3 bowl while the hand
    was pulled back, the fingers took it by the lobe's edge and it slipped out (6 of 10 trials). A wall is a few millimetres thick and pinched WALL_INSET_M (1.2 cm)
    inside the object's outer extent, so a hand 1.2 cm off shuts its outer finger on air and only
    the inner one reaches the wall. The arm folded over an object near its base (a bowl on
    libero_spatial-07's stove, 36 cm from it) sways away toward the base after the descent stops,
    tilting 4 degrees: 1 cm off 4 steps into the close, 1.4 cm at its end, back in about 20 steps.
    Elsewhere the hand sways at most about 7 mm and is back by the close's end (libero_spatial-04,
    -05): it closes exactly as `motion.gripper`."""
    hold, closing, waited = world.eef(), 0, 0
    while closing < motion.GRIPPER_STEPS:
        swayed = float(np.linalg.norm((world.eef() - hold)[:2])) > SWAY_M
        if swayed and waited < SWAY_STEPS and "gripper" not in world.touching(instance):
            waited += 1
            yield motion.action_to(world, hold, 0.0, orient)
            continue
        closing += 1
        yield motion.action_to(world, hold, CLOSE, orient)


def inner_way(world: World, instance: str, grasp: Grasp) -> np.ndarray | None:
    """Where the open hand comes down to reach the gentle pinch `grasp` of `instance` from nearer
    the arm's base (`come_out`): INNER_M nearer the base than the pinch, the grip site high enough
    for the fingertips to pass FINGERTIPS_CLEAR_M over the object's top. None when an obstacle stops
    the hand (its wrist included) over that point or over its way out to the pinch."""
    radial = np.append(grasp.point[:2] - ROBOT_BASE_XY, 0.0)
    radial /= np.linalg.norm(radial)
    low = float(world.points(instance)[:, 2].max()) + FINGERTIP_M + FINGERTIPS_CLEAR_M
    boxes = obstacle_boxes(world, (instance,))
    way = [grasp.point - radial * INNER_M * f for f in np.linspace(1.0, 0.0, WAY_SAMPLES)]
    if any(reach_height(boxes, p, grasp.axis, WITH_WRIST) > low for p in way):
        return None
    return np.append(way[0][:2], max(low, float(grasp.point[2])))


def come_out(world: World, grasp: Grasp, inner: np.ndarray, orient: np.ndarray) -> Actions:
    """Bring the open hand from over `inner` (`inner_way`) to the gentle pinch `grasp`: down to
    `inner`, out at that height to over the pinch (slowing for the last OUT_SLOW_M), then down to
    within REACH_TOL_M of it. Far out (the grip site 0.75-0.77 m from the arm's base at 1.18 m,
    libero_spatial-09's inverted bowl on the cabinet), the arm is near the farthest it reaches with
    the hand pointing down (0.79 m there): the OSC's weakest direction is then along the arm (the
    grip site's Jacobian's smallest singular value 0.055-0.10, against 0.13-0.14 at 0.70 m). Coming down there from over the pinch, or arriving fast, the arm
    straightened its elbow to its limit and the grip site stopped 0.7-1 cm over and beyond the pinch
    for the rest of the episode (9 of 10 trials). Come down nearer the base, the elbow stays bent;
    there the grip site still drifts 2-5 mm along the arm and back over 30 steps, which
    `squeeze` (holding the pinch point) takes up."""
    radial = np.append(grasp.point[:2] - inner[:2], 0.0)
    radial /= np.linalg.norm(radial)
    over = np.append(grasp.point[:2], inner[2])
    yield from motion.move_to(world, inner, OPEN, orient, tol=0.015, max_steps=60)
    yield from motion.move_to(world, over - radial * OUT_SLOW_M, OPEN, orient, tol=0.004, max_steps=60, speed=OUT_SPEED)
    yield from motion.move_to(world, over, OPEN, orient, tol=0.002, max_steps=60, speed=OUT_SLOW_SPEED)
    yield from motion.move_to(world, grasp.point, OPEN, orient, tol=REACH_TOL_M, max_steps=REACH_STEPS, speed=0.2)


def squeeze(world: World, opening: float, orient: np.ndarray, hold: np.ndarray | None = None) -> Actions:
    """Close the fingers, one CLOSE action at a time, until their target opening is at most
    `opening`; then hold them there (action 0) while they settle. The hand is held where it is, or
    driven to `hold` (a hand still drifting, `come_out`)."""
    hold = world.eef() if hold is None else hold
    for _ in range(motion.GRIPPER_STEPS):
        grip = CLOSE if world.finger_target_gap() > opening else 0.0
        yield motion.action_to(world, hold, grip, orient)
