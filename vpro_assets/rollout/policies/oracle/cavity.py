"""Put an object into a covered cavity (the microwave) through its open side.

A region is covered when a geom of its owner lies over the region's centre lower than an object
and the hand above it need: the microwave's top plate is 14 cm over its floor, a mug held from
above needs about 19 cm. So the object goes in sideways: taken by the grasp nearest the opening
(a mug by its handle), carried in front of the opening, lowered to the cavity's floor height, slid
in as far as the hand stays outside the mouth (the hand rises into the top plate's height), and
released. It is then pushed deeper by the closed fingers, the hand tilted so that the fingertips
lead the wrist into the mouth, until its body position is well inside the region and its front
is behind the front face (where the door closes), or the push stops moving it.
Taken where the arm is stretched (a handle far out), the object is first set down nearer the arm;
the turn in the hand goes the way the wrist has room for; and when something stands in front of
the opening where the object would hang, it comes down at the mouth instead.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from vpro_assets.core.mjgeom import axis_angle_quat, geom_corners, quat_matrix
from vpro_assets.rollout.policies.oracle import motion
from vpro_assets.rollout.policies.oracle.articulation import is_drawer, owner_of
from vpro_assets.rollout.policies.oracle.clearance import object_boxes, obstacle_boxes
from vpro_assets.rollout.policies.oracle.grasp import ROBOT_BASE_XY, handle, outer_part_grasp
from vpro_assets.rollout.policies.oracle.hand import HAND_PARTS
from vpro_assets.rollout.policies.oracle.motion import CLOSE, OPEN, UP, Actions
from vpro_assets.rollout.policies.oracle.pick import pick
from vpro_assets.rollout.policies.oracle.pick_place import Destination, carry, lower_and_release, support_height
from vpro_assets.rollout.policies.oracle.world import SkillFailed, World

HAND_HEADROOM_M = 0.19  # a region with less free height over its floor is covered
HAND_MARGIN_M = 0.012
HAND_HALF_DEPTH_M = HAND_PARTS[2][2] + HAND_MARGIN_M  # the palm's half width across the closing axis, and a margin
FLOOR_CLEAR_M = 0.012  # the object's bottom this far above the cavity's floor while sliding in
STAGE_M = 0.03  # the object this far in front of the cavity's front face before sliding in
# When something stands where the object, brought down there, would hang (a mug's handle behind it):
# its front this far in front of the ceiling's front edge instead, as near the cavity as the ceiling
# lets it come down (libero_10-09's familiar-position red mug, 1.047 m tall, 10 cm in front of the
# microwave: the white mug's handle came down on it and stayed there).
MOUTH_STAGE_M = 0.015
STAGE_MARGIN_M = 0.015
INSIDE_M = 0.03  # the object's body position this far past the region's near side
BEHIND_FRONT_M = 0.008  # the object's front this far behind the front face
PUSH_TILT_RAD = 0.6  # fingertips lead the wrist by about 6 cm into the mouth
PUSH_HEIGHT_M = 0.025  # fingertips this far above the floor while pushing
PUSH_STEP_M = 0.01
TURN_STEPS, TURN_HOLD_M = 30, 0.01  # a turn in the hand (`motion.turn_about`): each move's steps and tolerance
# A handle pinched farther than this from the arm's base leaves the arm stretched, its elbow at its
# limit: libero_10-09's familiar-position mug, its handle's grip 0.786 m out at 1.0 m, was lifted but
# could then not be carried back toward the base (the grip site stayed 8 cm out from the stage).
# Nearer, the mug is carried as from nearer still: libero_10-09 -open25's, pushed out of the door's
# swing, has its handle's grip 0.745 and 0.749 m out (trials 1 and 5) and is carried to the stage in
# 21-22 steps (others 17-20); set down nearer first at 0.74 (111 steps), the case ran out of its 520.
CARRY_REACH_M = 0.76
# Set down nearer (`bring_near`), the handle's grip NEAR_MARGIN_M inside NEAR_M of the arm's base
# (NEAR_M: the reach first taken, 0.74; where the familiar-position mug is set down is unchanged).
NEAR_M, NEAR_MARGIN_M = 0.74, 0.02
WALL_PROBE_M = 0.06  # a side counts as walled when a geom lies this far past the region's box


@dataclass(frozen=True)
class Cavity:
    center: np.ndarray  # the region's centre
    inward: np.ndarray  # horizontal unit vector from the opening into the cavity
    near: float  # depth (along inward) of the region's near side
    front: float  # depth of the owner's frontmost point (the door closes in front of it)
    mouth: float  # depth of the ceiling's front edge
    floor: float  # top of the cavity's floor


def _depth(p: np.ndarray, inward: np.ndarray) -> np.ndarray:
    return np.asarray(p)[..., :2] @ inward[:2]


def covered(world: World, region: str) -> Cavity | None:
    """The cavity of `region` when its owner covers it and it is open on exactly one side."""
    if not world.has_site(region):
        return None
    owner = owner_of(world, region)
    if owner not in dict(world.task.fixtures) or is_drawer(world, region):
        return None
    moving = {g for j in world.joints_of(owner) for g in world.joint_geoms(j)}
    boxes = [geom_corners(world.m, world.d, [g]) for g in world.geoms(owner) if g not in moving]
    c = world.site_pos(region)
    frame = world.site_mat(region)
    half = np.abs(frame @ world.site_size(region))

    def over(b: np.ndarray, xy: np.ndarray) -> bool:
        return bool(np.all(b.min(0)[:2] <= xy) and np.all(xy <= b.max(0)[:2]))

    ceiling = [b for b in boxes if over(b, c[:2]) and c[2] < b.min(0)[2]]
    floors = [b for b in boxes if over(b, c[:2]) and b.max(0)[2] <= c[2]]
    if not ceiling or not floors:
        return None
    floor = max(float(b.max(0)[2]) for b in floors)
    low = min(ceiling, key=lambda b: b.min(0)[2])
    if low.min(0)[2] - floor >= HAND_HEADROOM_M:
        return None
    # The region's two horizontal directions: its most horizontal axis and the one across it (a
    # site may be turned on its side, one of its x and y axes then vertical).
    flat = max((frame[:, k] for k in range(3)), key=lambda a: float(np.linalg.norm(a[:2])))
    u = np.append(flat[:2] / np.linalg.norm(flat[:2]), 0.0)
    open_sides = []
    for d in (u, np.array([-u[1], u[0], 0.0])):
        for sign in (1.0, -1.0):
            reach = float(np.abs(half[:2] @ d[:2])) + WALL_PROBE_M
            probe = c + sign * d * np.linspace(0.0, reach, 16)[:, None]
            walled = any(np.any(np.all((probe >= b.min(0) - 1e-4) & (probe <= b.max(0) + 1e-4), axis=1)) for b in boxes)
            if not walled:
                open_sides.append(-sign * d)
    if len(open_sides) != 1:
        return None
    inward = open_sides[0]
    pts = np.concatenate(boxes)
    return Cavity(
        center=c,
        inward=inward,
        near=float(_depth(c, inward) - np.abs(half[:2] @ inward[:2])),
        front=float(_depth(pts, inward).min()),
        mouth=float(_depth(low, inward).min()),
        floor=floor,
    )


def handle_side(world: World, held: str, prefer: np.ndarray) -> np.ndarray:
    """The horizontal direction of the object's handle (`grasp.handle`), the nearest `prefer` of
    equals; `prefer` when it has none."""
    found = handle(world.hulls(held), prefer)
    return prefer if found is None else found


def _signed_angle(a: np.ndarray, b: np.ndarray) -> float:
    """The angle (rad) turning horizontal `a` to `b` counter-clockwise seen from above."""
    return float(np.arctan2(a[0] * b[1] - a[1] * b[0], a[0] * b[0] + a[1] * b[1]))


def _grip_distance(world: World, held: str, toward: np.ndarray) -> float:
    """How far from the arm's base the grip site takes the part of `held` sticking out toward
    `toward` (its handle); the body position's when it has no such thin part."""
    grasp = outer_part_grasp(world, held, toward)
    point = world.body_pos(held) if grasp is None else grasp.point
    return float(np.linalg.norm(point[:2] - ROBOT_BASE_XY))


def _out_of_reach(world: World, held: str, toward: np.ndarray) -> bool:
    return _grip_distance(world, held, toward) > CARRY_REACH_M


def bring_near(world: World, held: str, toward: np.ndarray) -> Actions:
    """Take `held` by its grasp nearest the arm (`pick`'s default) and set it down nearer the arm's
    base, its handle's grip NEAR_MARGIN_M inside NEAR_M of it, so that it can then be taken by the handle
    and carried with the elbow bent."""
    excess = _grip_distance(world, held, toward) - NEAR_M + NEAR_MARGIN_M
    start = world.body_pos(held)[:2]
    home = (ROBOT_BASE_XY - start) / np.linalg.norm(ROBOT_BASE_XY - start)
    xy = start + home * excess
    yield from pick(world, held)
    dest = Destination(xy, support_height(world, xy, exclude=(held,)), "table", "on")
    yield from carry(world, held, xy)
    yield from lower_and_release(world, held, dest)


def _stage_taken(world: World, held: str, region: str, body_xy: np.ndarray, bottom: float) -> bool:
    """Whether something other than the cavity's owner stands higher than `bottom` where the held
    object (its footprint as it hangs now), its body position moved over `body_xy`, comes down."""
    own = object_boxes(world, held)
    own = own + np.append(body_xy - world.body_pos(held)[:2], 0.0)
    lo, hi = own[:, 0, :2].min(0) - STAGE_MARGIN_M, own[:, 1, :2].max(0) + STAGE_MARGIN_M
    boxes = obstacle_boxes(world, (held, owner_of(world, region)))
    near = np.all(boxes[:, 0, :2] < hi, axis=1) & np.all(boxes[:, 1, :2] > lo, axis=1)
    return bool(np.any(near & (boxes[:, 1, 2] > bottom)))


def put_in(world: World, held: str, region: str) -> Actions:
    """Pick `held` and put it into the covered cavity of `region`."""
    cav = covered(world, region)
    if cav is None:
        raise SkillFailed(f"{region} is not a covered cavity open on one side")
    toward = handle_side(world, held, -cav.inward)
    if _out_of_reach(world, held, toward):
        yield from bring_near(world, held, toward)
        toward = handle_side(world, held, -cav.inward)
    yield from pick(world, held, toward=toward)
    # Turn the held object about the grip so that what was taken leads out of the opening, the way
    # the wrist has room for (`motion.wrist_turn`).
    turn = motion.wrist_turn(world, _signed_angle(toward, -cav.inward))
    yield from motion.turn_about(world, UP, turn, tol=TURN_HOLD_M, max_steps=TURN_STEPS)
    grip = world.eef()[:2] - world.body_pos(held)[:2]
    box = world.box(held)
    hang = world.eef()[2] - box.lo[2]
    ahead = float(_depth(world.points(held), cav.inward).max() - _depth(world.body_pos(held), cav.inward))
    lateral = cav.center[:2] - cav.inward[:2] * _depth(cav.center, cav.inward)

    def origin_at(depth: float) -> np.ndarray:
        return lateral + cav.inward[:2] * depth

    orient = world.eef_mat()
    z = cav.floor + FLOOR_CLEAR_M + hang
    stage = origin_at(cav.front - ahead - STAGE_M) + grip
    if _stage_taken(world, held, region, stage - grip, cav.floor + FLOOR_CLEAR_M):
        stage = origin_at(cav.mouth - ahead - MOUTH_STAGE_M) + grip
    # Over the stage point at carrying height, then down in front of the opening.
    yield from carry(world, held, stage - grip)
    yield from motion.move_to(world, [*stage, z], CLOSE, orient, tol=0.01, max_steps=120, speed=0.5)
    limit = cav.mouth - HAND_HALF_DEPTH_M  # deepest the grip site goes with the hand still outside
    inside = origin_at(min(cav.near + INSIDE_M, limit - float(grip @ cav.inward[:2]))) + grip
    yield from motion.move_to(world, [*inside, z], CLOSE, orient, tol=0.008, max_steps=120, speed=0.4)
    for _ in range(40):
        if world.touching(held) - {"gripper"} or world.box(held).lo[2] - cav.floor < 0.004:
            break
        yield motion.action_to(world, world.eef() - [0, 0, 0.02], CLOSE, orient, speed=0.3)
    yield from motion.gripper(world, OPEN, orient=orient)
    yield from motion.move_to(world, world.eef() + [0, 0, 0.06], OPEN, orient, tol=0.015, max_steps=40)
    yield from push_in(world, held, cav)


def _done(world: World, held: str, cav: Cavity) -> bool:
    depth = float(_depth(world.body_pos(held), cav.inward))
    front = float(_depth(world.points(held), cav.inward).min())
    return depth >= cav.near + INSIDE_M and front >= cav.front + BEHIND_FRONT_M


def push_in(world: World, held: str, cav: Cavity) -> Actions:
    """Push `held` deeper with the closed fingers, tilted so the fingertips lead into the mouth."""
    if _done(world, held, cav):
        return
    pts = world.points(held)
    depth = _depth(pts, cav.inward)
    back = pts[np.argmin(depth)]  # the object's point nearest the opening
    across = np.array([-cav.inward[1], cav.inward[0], 0.0])
    down = motion.facing([0, 0, -1], across, world.eef_mat())
    tilt = quat_matrix(axis_angle_quat(across, PUSH_TILT_RAD * np.sign(np.cross(across, [0, 0, -1]) @ cav.inward)))
    orient = tilt @ down
    z = cav.floor + PUSH_HEIGHT_M
    start = np.array([*(back[:2] - cav.inward[:2] * 0.04), z])
    yield from motion.move_to(world, start + [0, 0, 0.12] - cav.inward * 0.04, CLOSE, orient, tol=0.015, max_steps=150)
    yield from motion.move_to(world, start, CLOSE, orient, tol=0.01, max_steps=80, speed=0.5)
    stalled = 0
    for _ in range(60):
        if _done(world, held, cav) or stalled >= 8:
            break
        before = float(_depth(world.body_pos(held), cav.inward))
        goal = np.array([*(world.eef()[:2] + cav.inward[:2] * PUSH_STEP_M * 3), z])
        for _ in range(3):
            yield motion.action_to(world, goal, CLOSE, orient, speed=0.3)
        moved = float(_depth(world.body_pos(held), cav.inward)) - before
        stalled = stalled + 1 if moved < 0.001 else 0
    yield from motion.move_to(world, world.eef() - cav.inward * 0.08, CLOSE, orient, tol=0.02, max_steps=60)
    yield from motion.move_to(world, world.eef() + [0, 0, 0.10], CLOSE, orient, tol=0.02, max_steps=40)
    if not _done(world, held, cav):
        past = float(_depth(world.body_pos(held), cav.inward)) - cav.near
        behind = float(_depth(world.points(held), cav.inward).min()) - cav.front
        raise SkillFailed(
            f"{held} not pushed in: its body {past:+.3f} m past the region's near side (want {INSIDE_M}), "
            f"its front {behind:+.3f} m behind the front face (want {BEHIND_FRONT_M})"
        )
