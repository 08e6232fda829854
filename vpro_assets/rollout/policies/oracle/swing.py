"""A door's swing and the objects standing in it: push them out before the door opens.

A hinged door (the microwave's) passes, between its current angle and the open end of its joint's
range, through the sector around its hinge axis that its line from the hinge sweeps (out to its
geoms' farthest corner: 26 cm for libero_10-09's microwave), and through its thickness (plate
behind, handle in front) where it starts and ends, over its geoms' heights. An object with a
point of its hulls there is struck while the door opens: libero_10-09's mug stands 21-27 cm from
the hinge, and in 9 of 10 trials of its precondition case the opening door turned it 32-132
degrees (once off the table), and the sideways insertion that follows failed.

So before the door opens such an object is pushed out of the sweep, away from the hinge, by the
closed fingertips low on its side, the hand tilted so that the fingertips lead the wrist (the
palm, 3.3 cm wider than the fingers each way, would otherwise meet the object's wall first, 4 cm
up). The push goes along the hinge's radial through the object, or the nearest of a few directions
turned from it, the shortest distance that clears the sweep, leaves the object clear of its
neighbours and leaves the tilted hand room behind it (nothing of the fixture there).
"""

from __future__ import annotations

import numpy as np

from vpro_assets.core.mjgeom import axis_angle_quat, geom_corners, quat_matrix
from vpro_assets.rollout.policies.oracle import motion
from vpro_assets.rollout.policies.oracle.articulation import Joint
from vpro_assets.rollout.policies.oracle.clearance import object_boxes, obstacle_boxes
from vpro_assets.rollout.policies.oracle.motion import CLOSE, Actions
from vpro_assets.rollout.policies.oracle.world import World

SWING_MARGIN_M = 0.012  # an object this close to the door's sweep is in it
CLEAR_MARGIN_M = 0.02  # pushed until this far outside the sweep
NEIGHBOUR_M = 0.01  # the pushed object's footprint stays this far from its neighbours'
SHIFT_STEP_M = 0.005
MAX_SHIFT_M = 0.15
TURNS_DEG = (0.0, 20.0, -20.0, 40.0, -40.0)  # push directions off the hinge's radial, in order of preference
PUSH_TILT_RAD = 0.6  # fingertips lead the wrist by about 6 cm
PUSH_HEIGHT_M = 0.025  # fingertips this far above the object's bottom (above a mug's narrower foot)
BEHIND_M = 0.03  # the fingertips start this far behind the object
PUSH_AHEAD_M = 0.03  # each push step aims this far ahead of the fingertips
PUSH_STEPS = 40
STALL_STEPS = 6
HAND_BACK_M, HAND_HALF_M, HAND_UP_M = 0.10, 0.10, 0.20  # the tilted hand and wrist behind the fingertips
HOVER = np.array([0.0, 0.0, 0.06])  # the fingertips come down from this far over the push's start


def _frame(world: World, joint: Joint) -> tuple[np.ndarray, np.ndarray, float]:
    """(hinge anchor, horizontal unit vector from the hinge to the door's farthest corner, the door's
    turn: +1 when it opens counter-clockwise seen from above)."""
    door = geom_corners(world.m, world.d, world.joint_geoms(joint.id))
    anchor = world.d.xanchor[joint.id].copy()
    rel = door[:, :2] - anchor[:2]
    far = rel[np.argmax(np.linalg.norm(rel, axis=1))]
    return anchor, far / np.linalg.norm(far), float(np.sign(world.d.xaxis[joint.id][2])) * joint.open_sign


def _polar(p: np.ndarray, ref: np.ndarray, turn: float) -> tuple[np.ndarray, np.ndarray]:
    """(distance from the hinge, angle from `ref` in the opening sense) of horizontal offsets `p`."""
    cross = ref[0] * p[:, 1] - ref[1] * p[:, 0]
    return np.linalg.norm(p, axis=1), np.arctan2(cross * turn, p @ ref)


def in_swing(world: World, joint: Joint, points: np.ndarray, margin: float = SWING_MARGIN_M) -> bool:
    """Whether any of `points` (N x 3) lies, within `margin`, where the door passes between its
    current angle and the open end of its range: the sector its line from the hinge sweeps, and its
    thickness (the plate behind, the handle in front) where it starts and where it ends."""
    door = geom_corners(world.m, world.d, world.joint_geoms(joint.id))
    anchor, ref, turn = _frame(world, joint)
    swing = abs(joint.open_end - world.qpos(joint.id))
    rho, ang = _polar(door[:, :2] - anchor[:2], ref, turn)
    along, perp = rho * np.cos(ang), rho * np.sin(ang)  # the door's corners in its own frame
    dist, a = _polar(points[:, :2] - anchor[:2], ref, turn)
    level = (points[:, 2] > door[:, 2].min() - margin) & (points[:, 2] < door[:, 2].max() + margin)
    slack = margin / np.maximum(dist, 1e-6)
    swept = (dist < rho.max() + margin) & (a > -slack) & (a < swing + slack)
    for at in (a, a - swing):  # the door where it starts and where it ends
        x, y = dist * np.cos(at), dist * np.sin(at)
        swept |= (
            (x > along.min() - margin)
            & (x < along.max() + margin)
            & (y > perp.min() - margin)
            & (y < perp.max() + margin)
        )
    return bool(np.any(swept & level))


def clearing_push(world: World, joint: Joint, obj: str) -> tuple[np.ndarray, float] | None:
    """(horizontal unit direction, distance) of the shortest push, along the hinge's radial through
    the object or the nearest of a few directions turned from it, that takes `obj` CLEAR_MARGIN_M out
    of the sweep and leaves it clear of its neighbours; None when none does within MAX_SHIFT_M."""
    pts = world.points(obj)
    radial = world.body_pos(obj)[:2] - world.d.xanchor[joint.id][:2]
    radial /= np.linalg.norm(radial)
    others = obstacle_boxes(world, (obj,))
    own = object_boxes(world, obj)
    for deg in TURNS_DEG:
        c, s = np.cos(np.radians(deg)), np.sin(np.radians(deg))
        direction = np.array([c * radial[0] - s * radial[1], s * radial[0] + c * radial[1], 0.0])
        for dist in np.arange(SHIFT_STEP_M, MAX_SHIFT_M + 1e-9, SHIFT_STEP_M):
            if not in_swing(world, joint, pts + direction * dist, SWING_MARGIN_M + CLEAR_MARGIN_M):
                if not _meets(others, own + direction * dist) and _room_behind(others, pts, direction):
                    return direction, float(dist)
                break
    return None


def _room_behind(boxes: np.ndarray, pts: np.ndarray, direction: np.ndarray) -> bool:
    """Whether the tilted hand fits behind the object for a push along `direction`: nothing in
    HAND_BACK_M behind the fingertips' start, HAND_HALF_M to either side, from the fingertips up to
    HAND_UP_M (libero_10-09's mug 21 cm from the hinge: pushed along the radial, the wrist struck
    the microwave's front)."""
    across = np.array([-direction[1], direction[0], 0.0])
    back = float((pts[:, :2] @ direction[:2]).min()) - BEHIND_M
    g = np.meshgrid(
        np.linspace(0.0, HAND_BACK_M, 6), np.linspace(-HAND_HALF_M, HAND_HALF_M, 7), np.linspace(0.02, HAND_UP_M, 6)
    )
    along, side, up = (a.ravel() for a in g)
    mid = float((pts[:, :2] @ across[:2]).max() + (pts[:, :2] @ across[:2]).min()) / 2
    samples = np.column_stack(
        [
            direction[0] * (back - along) + across[0] * (mid + side),
            direction[1] * (back - along) + across[1] * (mid + side),
            float(pts[:, 2].min()) + PUSH_HEIGHT_M + up,
        ]
    )
    inside = np.all((samples[:, None] >= boxes[None, :, 0]) & (samples[:, None] <= boxes[None, :, 1]), axis=2)
    return not bool(inside.any())


def _meets(boxes: np.ndarray, own: np.ndarray) -> bool:
    """Whether any of the boxes `own` comes within NEIGHBOUR_M of an obstacle box (in plan, at heights
    they share)."""
    lo, hi = own[None, :, 0] - NEIGHBOUR_M, own[None, :, 1] + NEIGHBOUR_M
    lo[..., 2], hi[..., 2] = own[None, :, 0, 2] + 0.005, own[None, :, 1, 2]  # not what it stands on
    return bool(np.any(np.all(boxes[:, None, 0] < hi, axis=2) & np.all(boxes[:, None, 1] > lo, axis=2)))


def fingertips_leading(world: World, direction: np.ndarray) -> np.ndarray:
    """The hand pointing down, fingers closing across `direction`, tilted about that axis so the
    fingertips lead the wrist along `direction`. Of the two finger signs, the one that leaves the
    wrist's last joint farther from its limits (the nearer turn drove libero_10-09's to its limit,
    where the arm stalled short of the push's start)."""
    across = np.array([-direction[1], direction[0], 0.0])
    sign = np.sign(np.cross(across, [0, 0, -1]) @ direction)
    tilt = quat_matrix(axis_angle_quat(across, PUSH_TILT_RAD * sign))
    candidates = [tilt @ motion.facing([0, 0, -1], f * across) for f in (1.0, -1.0)]
    axis = world.d.xaxis[world.wrist_joint]
    return max(
        candidates, key=lambda goal: world.wrist_room(float(motion.rotation_error(world.eef_mat(), goal) @ axis))
    )


def push_out(world: World, joint: Joint, obj: str) -> Actions:
    """Push `obj` out of the door's sweep (nothing when it is not in it or no push clears it)."""
    if not in_swing(world, joint, world.points(obj)):
        return
    push = clearing_push(world, joint, obj)
    if push is None:
        return
    direction, dist = push
    orient = fingertips_leading(world, direction)
    pts = world.points(obj)
    back = pts[np.argmin(pts[:, :2] @ direction[:2])]
    z = float(pts[:, 2].min()) + PUSH_HEIGHT_M
    start = np.array([*(back[:2] - direction[:2] * BEHIND_M), z])
    goal_depth = float(world.body_pos(obj)[:2] @ direction[:2]) + dist
    yield from motion.move_to(world, start + HOVER - direction * 0.02, CLOSE, orient, tol=0.02, max_steps=40)
    yield from motion.move_to(world, start, CLOSE, orient, tol=0.008, max_steps=30, speed=0.6, stall_steps=3)
    first = before = float(world.body_pos(obj)[:2] @ direction[:2])
    stalled = 0
    for _ in range(PUSH_STEPS):
        depth = float(world.body_pos(obj)[:2] @ direction[:2])
        if depth >= goal_depth or stalled >= STALL_STEPS:
            break
        # Stalls count once the object moves: the fingertips start BEHIND_M short of it.
        stalled = stalled + 1 if depth - before < 0.001 and depth - first > 0.001 else 0
        before = depth
        aim = np.array([*(world.eef()[:2] + direction[:2] * min(PUSH_AHEAD_M, goal_depth - depth + 0.005)), z])
        yield motion.action_to(world, aim, CLOSE, orient, speed=0.5)
    yield from motion.move_to(
        world, world.eef() - direction * 0.02 + [0, 0, 0.08], CLOSE, orient, tol=0.02, max_steps=20
    )
