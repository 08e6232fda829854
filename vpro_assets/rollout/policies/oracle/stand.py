"""Standing a lying cup upright on the table by its rim (`plan`: before it goes into a covered cavity).

libero_10-09's lying mug (object_pose-v1-lying) rests on its handle, its mouth level and facing
sideways: 10.7 cm across and 10.3 cm long, nothing of it is narrow enough to pinch from above, and
the narrow-top pinch (6 mm below its round top) squeezed it off its handle (2 of 3 attempts); held
lying, it is 14 cm tall and with the hand over it did not fit under the microwave's top plate
(14.4 cm over the floor). So it is stood up first: the hand, level and pointing into the mouth,
pinches the rim's wall (one finger inside the cup, one outside) RIM_ANGLE_RAD from the rim's top
toward the side with more room (level at the side, the palm's 21 cm along the fingers reached down
onto the other mug; at the top, robot link 7, beside the left finger, came down on it, and with the
fingers the other way round the wrist could not turn there). It lifts until the cup clears the
table turned about the grip, turns the hand to point down (the cup's up axis back to vertical) while
coming TURN_IN_M toward the arm's base, sets the cup down standing and lets go. Turned where it
pinched, the elbow straightened to its limit (joint 4 at -0.07 rad) and the pick that followed could
not come back toward the base; it is unbent after (`reach.unbend`) when it still is. (At 60 degrees
from the top the hand stopped 4 cm over the pinch; over the mouth at 19 cm over the table the
elbow straightened: it turns 5 cm over the cup.) The pinch and the way point over the mouth lie at
the arm's reach: the way point ends once the turn there stops closing in, and an elbow gone past
straight coming to the pinch is unbent before the turn, which otherwise stalled for all its steps.
Turned upright, the cup is moved clear of its nearest neighbour before it comes down (the pick by
its handle that follows closed on the porcelain mug beside it). object_pose-v1-lying 0/10 -> 5/10
-> 10/10: the stand takes 152-184 of the 520 steps (was 132-256), the put-in and close after it
250-310.
"""

from __future__ import annotations

import numpy as np

from vpro_assets.rollout.policies.oracle import lay, level, motion, reach
from vpro_assets.rollout.policies.oracle.clearance import obstacle_boxes
from vpro_assets.rollout.policies.oracle.grasp import ROBOT_BASE_XY
from vpro_assets.rollout.policies.oracle.motion import CLOSE, OPEN, Actions
from vpro_assets.rollout.policies.oracle.pick_place import Destination, lower_and_release, support_height
from vpro_assets.rollout.policies.oracle.world import SkillFailed, World

MOUTH_M = 0.01  # the rim: the cup's points this close to its mouth's end
INSIDE_M = 0.015  # the grip site this far inside the mouth
WALL_M = 0.005  # and this far inside the rim's outer edge (the wall between the fingers)
RIM_ANGLE_RAD = np.radians(45.0)  # the pinch this far round the rim from its top
OUT_M = 0.08  # the hand comes in along the cup's axis from this far out of its mouth
ABOVE_M = 0.05  # first over that point this far above the cup's top (turning there, not lower)
# There the turn ends once it is this near and has stopped coming nearer (by TURN_STALL_RAD in
# TURN_STALL_STEPS): 8 cm out of the mouth the arm is stretched (elbow at its limit) and the hand
# stayed 0.09 rad off for 70 steps (object_pose-v1-lying trials 1, 4, 6, 8); the moves in finish it.
# Not merely this near: still turning, the hand missed the rim (trials 0, 2).
ABOVE_TURN_TOL = 0.15
TURN_STALL_RAD, TURN_STALL_STEPS = 0.005, 5
LIFT_CLEAR_M = 0.015  # the cup, turned about the grip, clears the table by this much
TURN_IN_M = 0.08
TURN_MOVE_SPEED, TURN_STEPS = 0.5, 70  # toward the base while it turns
# The stood cup is set down this far (in plan) from its nearest neighbour, moved away from it (at
# most MAX_SHIFT_M a step, SHIFT_STEPS steps): set down 1 cm from the porcelain mug, the pick by its
# handle that followed closed one finger on the porcelain mug too (object_pose-v1-lying trials 0 and
# 9: in 9 both went into the microwave and the door closed on the porcelain mug; in 0 the mug was
# let go tipping out over the microwave's lip).
NEIGHBOUR_GAP_M, MAX_SHIFT_M, SHIFT_STEPS = 0.04, 0.06, 12


def on_side(world: World, instance: str) -> bool:
    """Whether `instance` lies on its side (`lay.lying`), not upside down: its up axis nearer level
    than vertical (an inverted mug goes into the microwave as it is, `cavity`)."""
    up = lay.up_axis(world, instance)
    return up is not None and abs(float(up[2])) < lay.LYING_COS


def rim_pinch(world: World, held: str) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(the grip site's point on the lying cup's rim, the hand's orientation there, the level
    direction out of its mouth): the hand level, pointing into the mouth, the fingers closing across
    the wall RIM_ANGLE_RAD round from the rim's top, on the side whose grip point stands farther
    from any obstacle, the left finger (and link 7) outside."""
    up = lay.up_axis(world, held)
    if up is None or np.linalg.norm(up[:2]) < 1e-6:
        raise SkillFailed(f"{held} has no level up axis to stand it by")
    out = np.append(up[:2], 0.0) / np.linalg.norm(up[:2])
    across = np.array([-out[1], out[0], 0.0])
    pts = world.points(held)
    depth = pts @ out
    rim = pts[depth > depth.max() - MOUTH_M]
    side = rim @ across
    centre = across * (side.max() + side.min()) / 2 + out * (depth.max() - INSIDE_M)
    centre[2] = (rim[:, 2].max() + rim[:, 2].min()) / 2
    radius = float(np.ptp(side)) / 2 - WALL_M
    boxes = obstacle_boxes(world, (held,))

    def room(p: np.ndarray) -> float:
        gap = np.maximum(np.maximum(boxes[:, 0, :2] - p[:2], p[:2] - boxes[:, 1, :2]), 0.0)
        return float(np.linalg.norm(gap, axis=1).min(initial=np.inf))

    candidates = []
    for sign in (1.0, -1.0):
        radial = sign * across * np.sin(RIM_ANGLE_RAD) + np.array([0.0, 0.0, np.cos(RIM_ANGLE_RAD)])
        candidates.append((centre + radial * radius, radial))
    point, radial = max(candidates, key=lambda c: room(c[0] + c[1] * 0.1))
    approach = -out
    return point, np.column_stack([-radial, np.cross(approach, -radial), approach]), out


def _over_mouth(world: World, at: np.ndarray, orient: np.ndarray) -> Actions:
    """Move to `at` turning to `orient`, as `motion.move_to`; ends early once there with the turn
    within ABOVE_TURN_TOL and no longer closing (the arm stretched)."""
    errors: list[float] = []
    for action in motion.move_to(world, at, OPEN, orient, tol=0.02, max_steps=100):
        errors.append(float(np.linalg.norm(motion.rotation_error(world.eef_mat(), orient))))
        stalled = len(errors) > TURN_STALL_STEPS and errors[-1 - TURN_STALL_STEPS] - errors[-1] < TURN_STALL_RAD
        if stalled and errors[-1] < ABOVE_TURN_TOL and np.linalg.norm(at - world.eef()) < 0.02:
            return
        yield action


def _clear_of_neighbours(world: World, held: str) -> np.ndarray:
    """The horizontal shift that sets the held cup down NEIGHBOUR_GAP_M (in plan) from the nearest
    other object, away from it (at most MAX_SHIFT_M); zero when it already is that far."""
    pts = world.points(held)[:, :2]
    best = (np.inf, np.zeros(2))
    for inst, _ in world.task.objects:
        if inst == held:
            continue
        other = world.points(inst)[:, :2]
        d = np.linalg.norm(pts[:, None] - other[None], axis=2)
        i, j = np.unravel_index(int(np.argmin(d)), d.shape)
        if d[i, j] < best[0]:
            best = (float(d[i, j]), pts[i] - other[j])
    gap, away = best
    if gap >= NEIGHBOUR_GAP_M or np.linalg.norm(away) < 1e-9:
        return np.zeros(2)
    return away / np.linalg.norm(away) * min(NEIGHBOUR_GAP_M - gap, MAX_SHIFT_M)


def stand_up(world: World, held: str) -> Actions:
    """Pinch the lying cup's rim (`rim_pinch`), turn it upright and set it down standing."""
    point, orient, out = rim_pinch(world, held)
    top = float(world.points(held)[:, 2].max())
    front = point + out * OUT_M
    # Turned over the mouth, clear of what stands near (a stall there, the hand still turning, came
    # down half turned, its palm onto the other mug).
    yield from _over_mouth(world, np.array([*front[:2], top + ABOVE_M]), orient)
    yield from motion.move_to(world, front, OPEN, orient, tol=0.01, max_steps=60, stall_steps=5)
    yield from motion.move_to(world, point, OPEN, orient, tol=0.005, max_steps=60, speed=0.5, stall_steps=5)
    yield from motion.gripper(world, CLOSE, orient=orient)
    if world.finger_gap() < 0.002 or "gripper" not in world.touching(held):
        yield from motion.gripper(world, OPEN, orient=orient)
        raise SkillFailed(f"{held}'s rim not pinched")
    world.hold_grip = CLOSE
    now = lay.up_axis(world, held)
    assert now is not None  # (rim_pinch found it)
    turn = level.to_vertical(now)
    # Up until the cup, turned about the grip site, clears the table.
    axis = turn.as_rotvec() / max(turn.magnitude(), 1e-9)
    rel = world.points(held) - world.eef()
    swing = float(np.linalg.norm(rel - np.outer(rel @ axis, axis), axis=1).max())
    z = max(world.eef()[2], world.table_z + swing + LIFT_CLEAR_M)
    yield from motion.move_to(world, [*world.eef()[:2], z], CLOSE, orient, tol=0.01, max_steps=40, speed=0.5)
    home = np.append(ROBOT_BASE_XY - world.eef()[:2], 0.0)
    hold = world.eef() + home / np.linalg.norm(home) * TURN_IN_M
    # The pinch is at the arm's reach: an elbow gone past straight brings the hand no nearer the base,
    # and the turn stalled 0.27 rad short for its 70 steps (object_pose-v1-lying trials 1, 4, 6, 7, 8).
    # Unbent (out and up), the turn comes back to where it would have gone.
    yield from reach.unbend(world, CLOSE, orient)
    goal = turn.as_matrix() @ world.eef_mat()
    yield from motion.turn_in_place(world, goal, TURN_STEPS, at=hold, speed=TURN_MOVE_SPEED)
    # Away from a neighbour over the table, before it comes down (lowering, it touched down first).
    orient = world.eef_mat()
    for _ in range(SHIFT_STEPS):
        shift = _clear_of_neighbours(world, held)
        if not shift.any():
            break
        yield motion.action_to(world, world.eef() + np.append(shift, 0.0), CLOSE, orient, speed=0.5)
    xy = world.body_pos(held)[:2]
    # Set down before it is let go (let go 1.2 cm over the table, it can land on its edge and tip).
    dest = Destination(xy, support_height(world, xy, exclude=(held,)), "table", "on")
    yield from lower_and_release(world, held, dest, above=-np.inf)
    yield from reach.unbend(world, OPEN, world.eef_mat())
