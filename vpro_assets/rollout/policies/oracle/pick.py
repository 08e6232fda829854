"""The pick skill: a grasp planned from the object's geometry (`grasp.plan_grasp`) executed through
the OSC action: approach over it, descend (sliding in under an overhang where the grasp enters from
the side), close (on a wall, across, or gently to a target opening), lift, and check that the object
came up with both fingers on it; planned again and retried when it did not.
"""

from __future__ import annotations

import numpy as np

from vpro_assets.rollout.policies.oracle import motion
from vpro_assets.rollout.policies.oracle.clearance import lift_clear
from vpro_assets.rollout.policies.oracle.grasp import HOVER_M, ROBOT_BASE_XY, Grasp, grasp_orientation, plan_grasp
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
        orient = grasp_orientation(world, grasp.axis)
        start_z = world.body_pos(instance)[2]
        entry = grasp.entry
        above = grasp.point + entry + [0, 0, HOVER_M]
        above[2] = max(above[2], world.eef()[2] if attempt == 0 else above[2])
        yield from motion.move_to(world, above, OPEN, orient, tol=0.015, max_steps=150, speed=_approach_speed(grasp))
        yield from motion.move_to(world, grasp.point + entry + [0, 0, HOVER_M], OPEN, orient, tol=0.01, max_steps=60)
        if grasp.squeeze_to is None:
            world.hold_grip = CLOSE
            yield from motion.move_to(world, grasp.point + entry, OPEN, orient, tol=0.006, max_steps=80, speed=0.6)
            if entry.any():  # slide in under the overhang, and after the close, back out with the object
                yield from motion.move_to(
                    world, grasp.point, OPEN, orient, tol=0.006, max_steps=60, speed=0.4, stall_steps=ENTRY_STALL_STEPS
                )
            if grasp.rim and not entry.any():
                yield from close_on_wall(world, instance, orient)
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
        yield from lift_clear(world, instance, world.table_z + CLEAR_ABOVE_TABLE_M)
        yield from motion.move_to(
            world, world.eef() + [0, 0, LIFT_M], world.hold_grip, orient, tol=0.015, max_steps=60, speed=0.5
        )
        if world.body_pos(instance)[2] - start_z > MIN_LIFT_M and world.finger_gap() > 0.002:
            return
        yield from motion.gripper(world, OPEN, orient=orient)
    raise SkillFailed(f"could not lift {instance} in {attempts} attempts")


def _far(grasp: Grasp) -> bool:
    """Whether a grasp's grip point lies farther than FAR_M from the arm's base."""
    return float(np.linalg.norm(grasp.point[:2] - ROBOT_BASE_XY)) > FAR_M


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


def squeeze(world: World, opening: float, orient: np.ndarray) -> Actions:
    """Close the fingers in place, one CLOSE action at a time, until their target opening is at most
    `opening`; then hold them there (action 0) while they settle."""
    hold = world.eef()
    for _ in range(motion.GRIPPER_STEPS):
        grip = CLOSE if world.finger_target_gap() > opening else 0.0
        yield motion.action_to(world, hold, grip, orient)
