"""Turning an upside-down object over on the table before it goes into a region (`plan`).

LIBERO's `In` of a region (`SiteObject.in_box`) wants the object's body position inside the
region's box. libero_10-05's book (object_pose-v1) stands upside down: its body position, the
book's bottom face when upright, is its top face, 13.7 cm over the table. Settled in the caddy's
6.1 cm back compartment it stands at z 1.0374 against the box's top at 1.033 (it can lean 14
degrees there at most, which raises that point). So it is turned over first, by two quarter turns
about its thickness (`quarter`), each a pinch of its top edge from above, a tip of the hand forward
and a set-down: first onto its side (11 cm tall), then upright; the pick-and-place that follows
takes it as it takes the upright book of libero_10-05's Normal.

A half turn in the hand does not work there. Pinched from the side with the hand level (pointing
along the book's width, to roll it half a turn about that axis), the arm's wrist comes down 20 cm
behind the grip site and 10 cm over it: beside the book, the caddy's top and wall were in the way
of the wrist and the forearm, and the level hand pointing back toward the base is out of the arm's
reach. The hand tips forward only along the line from the arm's base (about its fingers' axis,
joint 6 alone): tipped elsewhere, the OSC turned the forearm (joint 5) half a turn and could not
turn it back. So each quarter turns the book about the vertical while carrying it to a spot where
that line, back from the grip site, is clear of obstacles (`spot`), and tips it there.
"""

from __future__ import annotations

import numpy as np
from scipy.spatial.transform import Rotation

from vpro_assets.rollout.policies.oracle import lay, motion
from vpro_assets.rollout.policies.oracle.articulation import is_fixture_region
from vpro_assets.rollout.policies.oracle.clearance import obstacle_boxes
from vpro_assets.rollout.policies.oracle.grasp import ROBOT_BASE_XY
from vpro_assets.rollout.policies.oracle.motion import CLOSE, OPEN, UP, Actions
from vpro_assets.rollout.policies.oracle.pick_place import support_height
from vpro_assets.rollout.policies.oracle.shape import MAX_PINCH_M
from vpro_assets.rollout.policies.oracle.world import SkillFailed, World

TOP_SLICE_M = 0.01  # the top edge: the object's points this close to its top
PINCH_DEPTH_M = 0.02  # the grip site this far under the top
HOVER_M = 0.05  # the hand comes down onto the top edge from this far over it
WRIST_MARGIN_RAD = 0.15  # the wrist's last joint this far inside its range after a turn
CARRY_CLEAR_M = 0.02  # carried, the object's bottom this far over the table and what it passes
TIP_STEPS = 60
TURN_STEPS, TURN_HOLD_M = 40, 0.02  # per quarter turn about the vertical (`motion.turn_about`), and its tolerance
# Where the tipped object is set down (`spot`): the level hand's wrist comes down 20 cm behind the
# grip site and 10 cm over it, the forearm behind that; the line back from the grip site toward the
# base (ARM_BACK_M long) keeps ARM_ROOM_M (in plan) from every obstacle, and the object's footprint
# FOOT_ROOM_M; the grip site MIN_REACH_M to MAX_REACH_M from the arm's base, within SPOT_SEARCH_M.
ARM_BACK_M, ARM_ROOM_M, FOOT_ROOM_M = 0.25, 0.08, 0.02
MIN_REACH_M, MAX_REACH_M = 0.4, 0.6
SPOT_SEARCH_M, SPOT_STEP_M = 0.25, 0.02
SET_DOWN_STEPS = 40
SLOW_M, SLOW_SPEED = 0.02, 0.4  # set down slowly over its last 2 cm
STALL_STEPS, STALL_DROP_M = 5, 0.002  # the hand has stopped sinking when it sank less than this in so many steps
TIP_SHORT_RAD = np.radians(15.0)  # the hand tips this much short of level
TIP_TOL = 0.1  # rad
# Tipped as far as the hand goes (joint 6 at its limit), the book turned 53 degrees at the carry's
# height and, let go, stood 36 degrees off upright, its middle 3 mm nearer the base than the corner
# it rests on, or leaned further where it had turned in the fingers (trial 3: 59 degrees) and fell
# back on its side (6 of 10 trials). TIP_LIFT_M higher, the arm tips it 60 degrees.
TIP_LIFT_M = 0.1
BACK_M = 0.04  # let go, the hand backs off along its pointing axis this far
UNTIP_RISE_M = 0.03  # and tips back to pointing down rising this much


def upside_down(world: World, instance: str) -> bool:
    """Whether `instance`'s up axis as LIBERO stands it (`lay.up_axis`) points more than 135
    degrees from the vertical."""
    up = lay.up_axis(world, instance)
    return up is not None and bool(up[2] < -lay.LYING_COS)


def needs_turning_over(world: World, obj: str, region: str) -> bool:
    """Whether `obj`, upside down, must be turned over to go `In` `region`: a region of a fixture
    (not a drawer's) over whose floor the object's body position, as it stands, stays above the
    region's box, while upright it passes into the box as it is lowered (libero_10-05's Normal
    succeeds so: settled, the upright book's body position is 1.3 cm under the box), and the
    object's thinnest side fits between the open fingers."""
    if not is_fixture_region(world, region) or not upside_down(world, obj):
        return False
    up = lay.up_axis(world, obj)
    assert up is not None  # (upside_down found it)
    rel = world.points(obj) - world.body_pos(obj)
    rise_now = float(-rel[:, 2].min())
    rise_upright = float(-(rel @ up).min())  # turned over, `up` points up
    center = world.site_pos(region)
    top = center[2] + world.region_half(region)[2]
    floor = support_height(world, center[:2], exclude=(obj,))
    return floor + rise_upright <= top < floor + rise_now and _thickness(world, obj)[1] < MAX_PINCH_M


def _thickness(world: World, obj: str) -> tuple[np.ndarray, float]:
    """(the level body axis along which `obj` is thinnest, its extent along it)."""
    mat = world.body_mat(obj)
    rel = world.points(obj) - world.body_pos(obj)
    level = [mat[:, k] for k in range(3) if abs(mat[2, k]) < lay.LYING_COS]
    extents = [float(np.ptp(rel @ axis)) for axis in level]
    k = int(np.argmin(extents))
    axis = np.append(level[k][:2], 0.0)
    return axis / np.linalg.norm(axis), extents[k]


def _room(boxes: np.ndarray, xy: np.ndarray) -> np.ndarray:
    """How far (in plan) each of the points `xy` (N x 2) stays from the nearest of `boxes`."""
    gap = np.maximum(np.maximum(boxes[None, :, 0, :2] - xy[:, None], xy[:, None] - boxes[None, :, 1, :2]), 0.0)
    return np.linalg.norm(gap, axis=2).min(axis=1, initial=np.inf)


def _level(v: np.ndarray) -> np.ndarray:
    return np.append(v[:2], 0.0) / np.linalg.norm(v[:2])


def spot(world: World, obj: str, length: float, thickness: float) -> np.ndarray:
    """Where (xy) the grip site sets the object down tipped forward along the line from the arm's
    base (`quarter`), `length` of it ahead of the grip site: the nearest place to where it is taken
    at which that line, back from the grip site, keeps the level hand's arm ARM_ROOM_M from every
    obstacle and the object's footprint keeps FOOT_ROOM_M."""
    pts = world.points(obj)
    here = (pts.min(0) + pts.max(0))[:2] / 2
    boxes = obstacle_boxes(world, (obj,))
    back = np.arange(0.0, ARM_BACK_M, 0.02)[:, None]
    ahead = np.arange(0.0, length + 1e-9, 0.01)[:, None]
    grid = np.arange(-SPOT_SEARCH_M, SPOT_SEARCH_M + 1e-9, SPOT_STEP_M)
    for dx, dy in sorted(((x, y) for x in grid for y in grid), key=lambda o: np.hypot(*o)):
        xy = here + [dx, dy]
        reach = float(np.linalg.norm(xy - ROBOT_BASE_XY))
        if not MIN_REACH_M <= reach <= MAX_REACH_M:
            continue
        out = (xy - ROBOT_BASE_XY) / reach
        if (
            _room(boxes, xy - out * back).min() >= ARM_ROOM_M
            and _room(boxes, xy + out * ahead).min() >= FOOT_ROOM_M + thickness / 2
        ):
            return xy
    raise SkillFailed(f"no room within {SPOT_SEARCH_M} m of {obj} to tip it over")


def top_pinch(world: World, obj: str, across: np.ndarray, then: float) -> tuple[np.ndarray, float]:
    """(the grip site's point PINCH_DEPTH_M under the middle of the object's top edge, the turn
    about the vertical that brings the hand, pointing down, to close its fingers along `across`):
    of the two yaws that do, each either way round, the least turn that leaves the wrist's last
    joint WRIST_MARGIN_RAD of its range there and after a further turn of `then`."""
    pts = world.points(obj)
    top = pts[pts[:, 2] > pts[:, 2].max() - TOP_SLICE_M]
    point = (top.min(0) + top.max(0)) / 2
    point[2] = pts[:, 2].max() - PINCH_DEPTH_M
    turns = motion.yaw_turns(world, across)

    def room(turn: float) -> float:
        return min(motion.wrist_yaw_room(world, turn), motion.wrist_yaw_room(world, turn + then))

    return point, max(turns, key=lambda t: (room(t) >= WRIST_MARGIN_RAD, -abs(t), room(t)))


def quarter(world: World, obj: str, ahead: np.ndarray) -> Actions:
    """Turn the standing object a quarter turn about its thickness, its level direction `ahead`
    (in its plane) coming up: pinch its top edge from above, lift it, carry it to `spot` turned so
    that `ahead` points along the line from the arm's base, tip the hand forward to point along
    that line (turned about the fingers' axis only: pointing elsewhere, the OSC turned the forearm
    half a turn and could not turn it back), set it down, let go, back off and tip the hand back
    down."""
    across, thickness = _thickness(world, obj)
    pts = world.points(obj)
    length = float(np.ptp(pts[:, 2]))  # hanging under the grip, ahead of it once tipped
    xy = spot(world, obj, length, thickness)
    out = _level(np.append(xy - ROBOT_BASE_XY, 0.0))
    yaw = float(np.arctan2(out[1], out[0]) - np.arctan2(ahead[1], ahead[0]))
    yaw = (yaw + np.pi) % (2 * np.pi) - np.pi
    point, turn = top_pinch(world, obj, across, yaw)
    world.hold_grip = OPEN
    over = point + [0.0, 0.0, HOVER_M]
    above = np.array([*over[:2], max(over[2], world.eef()[2])])
    yield from motion.turn_about(world, UP, turn, at=above, tol=TURN_HOLD_M, max_steps=TURN_STEPS)
    down = world.eef_mat()
    yield from motion.move_to(world, over, OPEN, down, tol=0.01, max_steps=40)
    yield from motion.move_to(world, point, OPEN, down, tol=0.006, max_steps=40, stall_steps=5)
    yield from motion.gripper(world, CLOSE, orient=down)
    if world.finger_gap() < 0.002 or not world.held(obj):
        yield from motion.gripper(world, OPEN, orient=down)
        raise SkillFailed(f"{obj}'s top edge not pinched")
    world.hold_grip = CLOSE
    hang = world.eef()[2] - float(world.points(obj)[:, 2].min())
    tops = support_height(world, xy, exclude=(obj,), radius=length)
    lift = (
        max(world.eef()[2], max(tops, support_height(world, world.eef()[:2], (obj,))) + hang + CARRY_CLEAR_M)
        + TIP_LIFT_M
    )
    yield from motion.move_to(world, [*world.eef()[:2], lift], CLOSE, down, tol=0.01, max_steps=40)
    carried = Rotation.from_euler("z", yaw).as_matrix() @ down
    yield from motion.move_to(world, [*xy, lift], CLOSE, carried, tol=0.01, max_steps=60)
    fingers = carried[:, 0]
    # Tipped TIP_SHORT_RAD short of level (joint 6 reaches its limit about there), the object's far
    # end touches first and it settles the rest of the way let go.
    pointing = out * np.cos(TIP_SHORT_RAD) - np.array([0.0, 0.0, np.sin(TIP_SHORT_RAD)])
    tipped = np.column_stack([fingers, np.cross(pointing, fingers), pointing])
    yield from lay.clear_tip(world, obj, tipped, world.table_z)
    yield from motion.turn_in_place(world, tipped, TIP_STEPS, tol=TIP_TOL)
    yield from set_down(world, obj)
    back = world.eef() - out * BACK_M
    yield from motion.move_to(world, back, OPEN, world.eef_mat(), tol=0.01, max_steps=20, turn_tol=None)
    yield from motion.turn_in_place(world, carried, TIP_STEPS, at=back + [0.0, 0.0, UNTIP_RISE_M])


def set_down(world: World, obj: str) -> Actions:
    """Lower the hand until the held object rests on something (or the hand stops sinking), and let
    go: at full speed until its lowest point is SLOW_M over the table, then at SLOW_SPEED."""
    orient = world.eef_mat()
    heights: list[float] = []
    for _ in range(SET_DOWN_STEPS):
        if world.touching(obj) - {"gripper"}:
            break
        heights.append(float(world.eef()[2]))
        if len(heights) > STALL_STEPS and heights[-STALL_STEPS - 1] - heights[-1] < STALL_DROP_M:
            break
        above = float(world.points(obj)[:, 2].min()) - world.table_z
        speed = 1.0 if above > SLOW_M else SLOW_SPEED
        yield motion.action_to(world, world.eef() - [0.0, 0.0, max(above, 0.03)], CLOSE, orient, speed=speed)
    world.hold_grip = OPEN
    yield from motion.gripper(world, OPEN, orient=orient)


def turn_over(world: World, obj: str) -> Actions:
    """Turn the upside-down `obj` over: two quarter turns (`quarter`) about its thickness, tipping
    first its width's end away from the arm's base up, then its up axis (level by then) up."""
    across, _ = _thickness(world, obj)
    width = np.array([-across[1], across[0], 0.0])
    pts = world.points(obj)
    if width[:2] @ ((pts.min(0) + pts.max(0))[:2] / 2 - ROBOT_BASE_XY) < 0:
        width = -width
    yield from quarter(world, obj, width)
    up = lay.up_axis(world, obj)
    if up is None or abs(up[2]) > lay.LYING_COS:
        raise SkillFailed(f"{obj} not on its side after a quarter turn (up axis {up})")
    yield from quarter(world, obj, _level(up))
    up = lay.up_axis(world, obj)
    if up is None or up[2] < lay.LYING_COS:
        raise SkillFailed(f"{obj} not upright after turning it over (up axis {up})")
