"""Close a hinged door (the microwave's) by pushing its free edge around the hinge.

The door is the body the fixture's hinge joint moves. Its free edge is its point farthest from the
hinge axis; the closing direction at a point is the axis crossed with the door's direction, signed
toward the closed end of the joint's range. The closed fingers stand on the near side of the door,
a little inside its edge, and follow the door's arc, always aiming a little ahead of its current
angle, until LIBERO's `Close` check holds. Coming down there, the hand (its 21 cm palm across the
door) often meets the door's top edge first; it pushes from where it meets it (coming on down, it
slid along the door and pushed it about for up to 77 steps: libero_10-09 Normal's close took 139
steps in trial 4, and the object_pose-v1-lying case ran out of its 520 in 4 trials of 10).

A closed door opens by its handle: the door's geoms other than its plate that stand out in front of
it, the one farthest out the bar (LIBERO's microwave, measured from the model: a vertical bar
2 x 2 x 15 cm on two standoffs, 1.9 cm in front of the plate, 24 cm from the hinge). The hand,
pointing down, straddles the bar with its fingers closing along the line from the hinge (the bar's
standoffs lie across it, between the fingers), 1.6 cm under the bar's top (lower, the fingers meet
the upper standoff), and closes on it. It then swings the grasp point about the hinge, aiming a
little past the door's current angle, the hand turning about the vertical with the door, until
LIBERO's `Open` check holds and the door is a margin past it (or the bar slips out); then it lets
go, backs off the door and rises over its top, so that the next skill's path does not sweep it shut.

A door part open swings at a touch (libero_10-09's precondition case -open25 starts the microwave at
-0.33 rad), so the hand comes to the handle without touching the door:
- The grip site goes 1.6 cm under the bar's top, not to its middle: the palm, 2.6 cm over the grip
  site and 6.6 cm wide, then passes over the bar. Aimed at the middle (7.5 cm under the top), the
  palm came down on the bar's top and pushed the door shut (-0.26 to -0.23 rad), and the fingers
  closed on nothing; a shut door (at its range's end) does not move, which hid it.
- A hand lower than its hover over the handle (after pushing the mug out of the swing, it is at the
  mug's height) rises first without turning, turns there, and only then comes across: moving and
  turning at once, the 21 cm palm swept the bar on its way (-0.33 to -0.26 rad in trial 0 of 10).
  The turn is commanded at most TURN_SPEED of the action's full turn: at full speed, a 1.5 rad turn
  drew the grip site 26 cm off its place and down to the bar's height (trial 5).
- Of the two finger signs, the hand takes the one that leaves the wrist's last joint more room
  through the turn to it and the door's turn after it (the hand turning with the door to its
  range's open end at most): the sign nearer the hand's orientation after the push needed the
  joint 1.2 rad past its limit; the arm turned there anyway, then could not follow the door, and
  the bar slipped out at -0.41 rad (trial 9).
- The grip point is taken again once the hand is over the handle, where the door is then.
"""

from __future__ import annotations

import numpy as np

from vpro_assets.core.mjgeom import axis_angle_quat, geom_corners, quat_matrix
from vpro_assets.rollout.policies.oracle import motion
from vpro_assets.rollout.policies.oracle.articulation import joint_for
from vpro_assets.rollout.policies.oracle.motion import CLOSE, OPEN, Actions
from vpro_assets.rollout.policies.oracle.world import SkillFailed, World

LEAD_RAD = 0.25  # aim this far ahead of the door's current angle
EDGE_INSET = 0.8  # push at this fraction of the door's radius
STANDOFF_M = 0.03  # grip site this far from the door's face before pushing
OPEN_MARGIN_RAD = 0.2  # this far past where LIBERO's Open first holds (0.35 cost libero_10-09 ~15 steps)
OPEN_STEPS = 200
DESCEND_STEPS = 20  # the palm may stop short on the door's top
SWING_SPEED = 0.8
LOST_GAP_M = 0.01  # fingers closer than this hold nothing
CLEAR_TOP_M = 0.1  # the grip site this far over the door's top after letting go
RELEASE_STEPS = 8  # the fingers open off a 2 cm bar
STALL_STEPS = 5  # moves toward the door end when the hand stops this many steps (resting on the door)
HOVER_M = 0.06  # the grip site this far over the handle's grip point before coming down on it
HOVER_OUT_M = 0.05  # and this far in front of it
OVER_TOP_M = 0.02  # the grip site at least this far over the door's top while it turns and comes across
RISE_TOL_M, RISE_STEPS = 0.03, 40
TURN_STEPS = 30
TURN_SPEED = 0.5  # of the action's full turn (0.5 rad): a full-speed turn of 1.5 rad drew the grip site 26 cm off
TURN_DONE_RAD = 0.15  # the move across finishes a turn this close
GRIP_BELOW_TOP_M = 0.016  # the grip site this far below the bar's top (lower, the fingers meet its upper standoff)


def _door_frame(world: World, joint) -> tuple[np.ndarray, np.ndarray, float, float, float]:
    """(hinge anchor, unit direction hinge -> free edge, radius, half thickness, mid height)."""
    pts = geom_corners(world.m, world.d, world.joint_geoms(joint.id))
    anchor = world.d.xanchor[joint.id].copy()
    rel = pts[:, :2] - anchor[:2]
    far = rel[np.argmax(np.linalg.norm(rel, axis=1))]
    u = np.append(far / np.linalg.norm(far), 0.0)
    normal = np.array([-u[1], u[0], 0.0])
    thick = float(np.abs(rel @ normal[:2]).max())
    return anchor, u, float(np.linalg.norm(far)), thick, float((pts[:, 2].min() + pts[:, 2].max()) / 2)


def _handle_point(world: World, joint, u: np.ndarray, out: np.ndarray) -> np.ndarray:
    """The middle of the handle's bar: of the door's geoms, the one reaching farthest out along
    `out` (the plate's outward normal) beyond the plate's outer face, the tallest of those within
    3 mm of the farthest (the bar, not its standoffs)."""
    geoms = world.joint_geoms(joint.id)
    corners = {g: geom_corners(world.m, world.d, [g]) for g in geoms}
    plate = max(geoms, key=lambda g: float(np.ptp(corners[g][:, :2] @ u[:2])))
    face = float((corners[plate][:, :2] @ out[:2]).max())
    standing = [g for g in geoms if g != plate and float((corners[g][:, :2] @ out[:2]).max()) > face + 0.005]
    if not standing:
        raise SkillFailed(f"{joint.region}: the door has no handle in front of its plate")
    reach = {g: float((corners[g][:, :2] @ out[:2]).max()) for g in standing}
    front = [g for g in standing if reach[g] > max(reach.values()) - 0.003]
    bar = max(front, key=lambda g: float(np.ptp(corners[g][:, 2])))
    point = (corners[bar].min(0) + corners[bar].max(0)) / 2
    point[2] = float(corners[bar][:, 2].max()) - GRIP_BELOW_TOP_M
    return point


def _handle_orient(world: World, joint, u: np.ndarray) -> np.ndarray:
    """The hand pointing down, its fingers closing along `u`: of the two finger signs, the one that
    leaves the wrist's last joint more room through the turn to it and then the door's turn, the
    hand turning with the door up to its range's open end."""
    axis = world.d.xaxis[world.wrist_joint]
    swing = (joint.open_end - world.qpos(joint.id)) * float(world.d.xaxis[joint.id] @ axis)

    def room(goal: np.ndarray) -> float:
        turn = float(motion.rotation_error(world.eef_mat(), goal) @ axis)
        return min(world.wrist_room(turn), world.wrist_room(turn + swing))

    return max((motion.facing([0, 0, -1], f * u) for f in (1.0, -1.0)), key=room)


def _turn_at(world: World, at: np.ndarray, orient: np.ndarray) -> Actions:
    """Turn the open hand to `orient` holding the grip site at `at`, the turn commanded at most
    TURN_SPEED of the action's full rotation."""
    for _ in range(TURN_STEPS):
        if np.linalg.norm(motion.rotation_error(world.eef_mat(), orient)) < TURN_DONE_RAD:
            return
        action = motion.action_to(world, at, OPEN, orient)
        action[3:6] *= min(1.0, TURN_SPEED / float(np.abs(action[3:6]).max()))
        yield action


def _turn(axis: np.ndarray, angle: float) -> np.ndarray:
    return quat_matrix(axis_angle_quat(axis, angle))


def open_(world: World, region: str) -> Actions:
    joint = joint_for(world, region)
    goal = ("open", joint.fixture)  # LIBERO's Open of the fixture (its hinge past -1.3 for the microwave)
    if world.holds(goal):
        return
    axis = world.d.xaxis[joint.id].copy()
    sign = joint.open_sign  # the joint's direction of opening
    anchor, u, _, _, _ = _door_frame(world, joint)
    out = np.cross(axis * sign, u)  # motion of the door's points while it opens: out of its front
    hover = _handle_point(world, joint, u, out) + out * HOVER_OUT_M + [0, 0, HOVER_M]
    orient0 = _handle_orient(world, joint, u)
    # A hand lower than the hover (or the door's top) comes up first, not turning, turns there, then comes across.
    top = float(geom_corners(world.m, world.d, world.joint_geoms(joint.id))[:, 2].max())
    up = np.array([*world.eef()[:2], max(hover[2], top + OVER_TOP_M)])
    if world.eef()[2] < up[2] - RISE_TOL_M:
        yield from motion.move_to(world, up, OPEN, world.eef_mat(), tol=RISE_TOL_M, max_steps=RISE_STEPS)
        yield from _turn_at(world, up, orient0)
    yield from motion.move_to(world, hover, OPEN, orient0, tol=0.02, max_steps=100)
    # The handle where the door is now (a partly open door swings away at a touch).
    anchor, u, _, _, _ = _door_frame(world, joint)
    out = np.cross(axis * sign, u)
    grip_pt = _handle_point(world, joint, u, out)
    q0 = world.qpos(joint.id)
    orient0 = motion.facing([0, 0, -1], u, world.eef_mat())
    yield from motion.move_to(
        world, grip_pt, OPEN, orient0, tol=0.01, max_steps=DESCEND_STEPS, speed=0.6, stall_steps=STALL_STEPS
    )
    yield from motion.gripper(world, CLOSE, orient=orient0)
    done_at = None
    for _ in range(OPEN_STEPS):
        q = world.qpos(joint.id)
        if done_at is None and world.holds(goal):
            done_at = q
        if (done_at is not None and abs(q - done_at) >= OPEN_MARGIN_RAD) or world.finger_gap() < LOST_GAP_M:
            break  # far enough, or the bar slipped out of the fingers
        turn = _turn(axis, q - q0 + sign * LEAD_RAD)
        target = anchor + turn @ (grip_pt - anchor)
        yield motion.action_to(world, target, CLOSE, turn @ orient0, speed=SWING_SPEED)
    orient = world.eef_mat()
    yield from motion.gripper(world, OPEN, steps=RELEASE_STEPS, orient=orient)
    _, u_now, _, _, _ = _door_frame(world, joint)
    away = np.cross(axis * sign, u_now)
    yield from motion.move_to(world, world.eef() + away * 0.05, OPEN, orient, tol=0.015, max_steps=10)
    # Over the door's top: the next skill's path to the object must not sweep the door shut.
    top = float(geom_corners(world.m, world.d, world.joint_geoms(joint.id))[:, 2].max())
    over = world.eef()
    over[2] = max(over[2], top + CLEAR_TOP_M)
    yield from motion.move_to(world, over, OPEN, orient, tol=0.02, max_steps=30)
    if not world.holds(goal):
        raise SkillFailed(f"{region} did not open (hinge at {world.qpos(joint.id):.3f})")


def close(world: World, region: str) -> Actions:
    joint = joint_for(world, region)
    goal = ("close", region)
    if world.holds(goal):
        return
    axis = world.d.xaxis[joint.id].copy()
    sign = -np.sign(joint.open_end - joint.closed_end)  # the joint's direction of closing
    anchor, u, radius, thick, mid_z = _door_frame(world, joint)
    push_dir = np.cross(axis * sign, u)  # motion of the door's points while it closes
    r = radius * EDGE_INSET
    orient = world.eef_mat()
    start = anchor + u * r - push_dir * (thick + STANDOFF_M)
    start[2] = mid_z
    yield from motion.move_to(world, start + [0, 0, 0.12], CLOSE, orient, tol=0.015, max_steps=150)
    # The hand may come to rest on the door's edge short of the start: the push goes on from there,
    # as soon as the hand touches the door.
    door_geoms = frozenset(world.joint_geoms(joint.id))
    for action in motion.move_to(
        world, start, CLOSE, orient, tol=0.01, max_steps=80, speed=0.6, stall_steps=STALL_STEPS
    ):
        if world.robot_touches(door_geoms):
            break
        yield action
    for _ in range(220):
        if world.holds(goal):
            break
        ahead = quat_matrix(axis_angle_quat(axis * sign, LEAD_RAD))
        _, u_now, _, _, _ = _door_frame(world, joint)
        u_goal = ahead @ u_now
        n_goal = np.cross(axis * sign, u_goal)
        target = anchor + u_goal * r - n_goal * (thick * 0.5)
        target[2] = mid_z
        yield motion.action_to(world, target, CLOSE, orient, speed=0.6)
    yield from motion.move_to(
        world, world.eef() - push_dir * 0.05 + [0, 0, 0.05], CLOSE, orient, tol=0.02, max_steps=30
    )
    if not world.holds(goal):
        raise SkillFailed(f"{region} did not close (hinge at {world.qpos(joint.id):.3f})")
