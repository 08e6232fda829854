"""Grasping an object from its actual geometry: where to put the fingers and at which yaw (the
pick skill that executes a grasp is `pick.py`).

The object's shape is the convex hulls of its collision geoms in the world (deformed, inverted,
recoloured and look-alike objects alike: nothing is read from the object's name). An object narrow
enough for the open fingers in some horizontal directions is pinched across the one where the open
hand comes down lowest (turned away from its neighbours); one narrow only toward its top (a tapered
can) is pinched there; one whose top is a low foot over wide sloping shoulders (an inverted bowl)
gently by the foot's sides; a wider one (bowls, mugs, baskets) by its handle or at its wall, the
fingers closing radially on the side nearest the robot.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np

from vpro_assets.core.mjgeom import geom_corners
from vpro_assets.rollout.policies.oracle import motion
from vpro_assets.rollout.policies.oracle.clearance import obstacle_boxes
from vpro_assets.rollout.policies.oracle.foot import FOOT_SQUEEZE_M, foot_pinch
from vpro_assets.rollout.policies.oracle.hand import HAND_PARTS, WITH_WRIST, hand_fits, reach_height
from vpro_assets.rollout.policies.oracle.overhang import lands_clear, overhang_pinch
from vpro_assets.rollout.policies.oracle.shape import (
    MAX_PINCH_M,
    NARROW_DEPTH_M,
    SOLID_TOP_M,
    above,
    beyond,
    extent_middle,
    narrowest,
    section,
    widths,
)
from vpro_assets.rollout.policies.oracle.world import World

WALL_INSET_M = 0.012  # the fingers' centre this far inside an object's outer wall
MIN_RIM_PINCH_M = 0.012  # a wall pinch less deep than this below the rim does not hold
WALL_DEPTH_M = 0.035  # a wall is pinched this far below its top (deep: a shallow pinch lets a bowl swing out)
HOVER_M = 0.08  # approach height above the grasp point
TABLE_CLEARANCE_M = 0.008  # grip site at least this high above the object's bottom
ROBOT_BASE_XY = np.array([-0.66, 0.0])  # the arm stands at -x in every LIBERO scene
# The grip site, the hand pointing down, comes 0.81-0.83 m out from the arm's base at 0.92-1.0 m
# (measured, stretched and slowly there): a wall pinched farther out is taken this far out, the
# wall still between the open fingers (the grip site moved at most REACH_SHIFT_M).
REACH_M, REACH_SHIFT_M = 0.80, 0.035
WALL_SIDES = 16  # candidate sides of a wide object's wall
HANDLE_MAX_M = 0.045  # a handle is thinner than this across (a wall cut OUTER_BAND_M deep is wider)
HANDLE_DIRECTIONS = 72  # directions searched for a handle, 5 degrees apart
HANDLE_MIN_HEIGHT_M = 0.02  # a handle is at least this tall
FINGER_PAD_HALF_M = 0.01  # the finger pads reach this far below the grip site
OUTER_BAND_M = 0.03  # a part sticking out toward a side: the object this close to its farthest point
# A side entry (`side_entry`): the shifts along the wall tried.
ENTRY_STEP_M, ENTRY_MAX_M = 0.005, 0.06
# A whole pinch whose sides narrow toward the top by more than MAX_SIDE_SLOPE (each side's run per
# rise where the pads touch) closes to SLOPED_SQUEEZE_M inside its width and holds there (`close_to`):
# each finger then presses 8-13 N (kp 1000 N/m; the target moves in 1 cm steps), not a full close's
# 20 N. Measured on libero_object-06's butter tapered to 0.63 (taper-s3): closed fully, it crept down
# out of the fingers during 4 of 10 carries (the gap shrinking 1.8 cm over 80 steps); at 0.39
# (taper-s2) it held in 10 of 10. At 1-3 N (2 and 8 mm inside) libero_object-01's cream cheese
# tapered to 0.79 did not come up (1 of 5); 1.6 cm inside, both held (5 of 5 each).
MAX_SIDE_SLOPE = 0.5
SLOPED_SQUEEZE_M = 0.016
# A pinch of an object longer than LONG_M across the fingers where the open hand stops more than
# BLOCKED_M over it is moved along the object in SHIFT_STEP_M steps, END_M inside its ends (`along_free`).
# LONG_M sits between libero_goal's lying bottles (15.8 cm) and libero_object's cream cheese box
# (10.0 cm): at 10 cm the turn a push gave the box decided whether its pinch moved, and on the twisted
# box (twist-s3) a pinch moved 2 cm off its middle, where its section has turned, slipped (5 of 10).
LONG_M, BLOCKED_M, SHIFT_STEP_M, END_M = 0.12, 0.01, 0.01, 0.03


@dataclass(frozen=True)
class Grasp:
    point: np.ndarray  # grip site position at closing
    axis: np.ndarray  # horizontal unit vector the fingers close along
    width: float  # extent of the object along `axis` at the grasp (m)
    rim: bool  # pinching a wall rather than the whole object
    # A gentle pinch: the fingers' target opening (m), reached in whole CLOSE actions and then held
    # (a full close on a low foot presses the fingers over it). None: close fully.
    squeeze_to: float | None = None
    # Held by its narrow top only (`narrow_top_grasp`): the object hangs from its top few millimetres.
    hung: bool = False
    # Of a hung grasp, the part pinched: (the points of the object's top the pads reach, the grip
    # site's height), `narrow_top`'s; what `nudge` tests the hand's way down against. None otherwise.
    part: tuple[np.ndarray, float] | None = None
    # The shift along the wall the open hand comes down at beside an overhang (`side_entry`, of a wall
    # pinch; zero: straight down), measured by `plan_grasp` against the obstacles it planned among.
    entry: np.ndarray = field(default_factory=lambda: np.zeros(3))
    # A whole pinch of sides that slope in toward the top (`sloped_close`): the fingers' target opening
    # (m), closed to and held there, the hand otherwise as for a full close. None: close fully.
    close_to: float | None = None
    # The left finger is toward `axis` (`overhang.overhang_pinch`: planned with the wrist on that
    # side): the pick turns the hand so (`grasp_orientation`), not to the nearer of the two yaws.
    sided: bool = False


def plan_grasp(world: World, instance: str, toward: np.ndarray | None = None) -> Grasp:
    """The grasp of `instance`; with `toward` (a horizontal unit vector), one on that side of the
    object (a thin part sticking out there, else its wall there), so the hand can lead it into a
    covered cavity and stay outside. The one decision of how an object is taken: `pick` follows it
    (its `entry` too) and `nudge` reads from it whether, and where (`part`), the object is pinched by
    its narrow top."""
    pts = world.points(instance)
    lo, hi = pts.min(0), pts.max(0)
    height = hi[2] - lo[2]
    center = np.append((lo[:2] + hi[:2]) / 2, 0.0)
    z = max(hi[2] - float(np.clip(height * 0.5, 0.01, 0.03)), lo[2] + TABLE_CLEARANCE_M)
    whole = _clear_pinch(world, instance, pts, z)
    if whole is not None:
        return sloped_close(world.hulls(instance), whole)
    handle = handle_grasp(world, instance, pts) if toward is None else outer_part_grasp(world, instance, toward)
    if handle is not None:
        return handle
    narrow = narrow_top_grasp(world, instance)
    if narrow is not None:
        return narrow
    foot = foot_grasp(world, instance)
    if foot is not None:
        return foot
    # A wide object: pinch its wall, fingers closing radially, on the side nearest the robot where
    # the outer finger and the hand have room (a bowl in a drawer stands close to the drawer's wall).
    robot = np.append(ROBOT_BASE_XY - center[:2], 0.0) if toward is None else np.asarray(toward, dtype=float)
    robot /= np.linalg.norm(robot)
    boxes = obstacle_boxes(world, (instance,))
    z = max(hi[2] - WALL_DEPTH_M, lo[2] + 0.4 * height)
    sides = []
    for k in sorted(range(WALL_SIDES), key=lambda k: abs(((k + WALL_SIDES / 2) % WALL_SIDES) - WALL_SIDES / 2)):
        ang = 2 * np.pi * k / WALL_SIDES
        rot = np.array([[np.cos(ang), -np.sin(ang), 0], [np.sin(ang), np.cos(ang), 0], [0, 0, 1]])
        toward = rot @ robot
        proj = (pts[:, :2] - center[:2]) @ toward[:2]
        point = center + toward * (proj.max() - WALL_INSET_M)
        point[2] = z
        sides.append(Grasp(point, toward, 2 * WALL_INSET_M, rim=True))  # nearest the robot first
    reach = [max(z, reach_height(boxes, g.point, g.axis, WITH_WRIST)) for g in sides]
    k = int(np.argmin(np.round(reach, 3)))  # the deepest pinch; of equals, nearest the robot
    if reach[k] <= hi[2] - MIN_RIM_PINCH_M:
        grasp = replace(sides[k], point=within_reach(np.append(sides[k].point[:2], reach[k])))
        return replace(grasp, entry=side_entry(boxes, grasp))  # zero: the hand comes down to `reach`
    # No side is free from above (an opened drawer over a bowl): aim at the full depth on a side the
    # hand slides in at (`side_entry`) where it comes down with the fingers clear of the wall; else a
    # pinch it comes straight down to with its wrist on the side the yaw puts it (`overhang`): a long
    # slide along a round wall lands the inner finger on the rim (libero_goal-03 taper-s3: 4-6 cm).
    # Else on the side with the fewest obstacles where the fingertips come down; the hand squeezes past.
    sides = [replace(g, entry=side_entry(boxes, g)) for g in sides]
    entering = [g for g in sides if g.entry.any()]
    slid = min(entering or sides, key=lambda g: blocked_spots(boxes, g))
    if slid.entry.any() and lands_clear(world.hulls(instance), slid.point + slid.entry, slid.axis):
        return slid
    sided = overhang_pinch(world.hulls(instance), boxes, z, robot, lambda left: sided_yaw(world, left) is not None)
    if sided is None:
        return slid
    point, left = sided
    return Grasp(within_reach(point), left, 2 * WALL_INSET_M, rim=True, sided=True)


def sloped_close(hulls: list[np.ndarray], grasp: Grasp) -> Grasp:
    """A whole pinch closed gently (`close_to`, SLOPED_SQUEEZE_M inside its width) when the object
    is tapered where the pads' bottom and top meet it: its cross-section there narrows toward the
    top every way, across the fingers' axis more steeply than MAX_SIDE_SLOPE (a tapered butter). As
    it is otherwise: a twisted box's section turns, wider some ways at its top (libero_goal-06's
    cream cheese at twist-s1, 0.65 across the fingers: closed gently, 2 of 10 trials were lost)."""
    pts = np.concatenate(hulls)
    low = max(grasp.point[2] - FINGER_PAD_HALF_M, float(pts[:, 2].min()) + 0.001)
    high = min(grasp.point[2] + FINGER_PAD_HALF_M, float(pts[:, 2].max()) - 0.001)
    if high - low < 0.002:
        return grasp
    dirs, bottom = widths(section(hulls, low))
    _, top = widths(section(hulls, high))
    k = int(np.argmax(np.abs(dirs @ grasp.axis)))
    tapered = bool(np.all(top < bottom)) and (bottom[k] - top[k]) / 2 / (high - low) > MAX_SIDE_SLOPE
    return replace(grasp, close_to=grasp.width - SLOPED_SQUEEZE_M) if tapered else grasp


def bearing(xy: np.ndarray) -> float:
    """The direction (rad) of `xy` seen from the arm's base: what its first joint turns to."""
    off = np.asarray(xy, dtype=float)[:2] - ROBOT_BASE_XY
    return float(np.arctan2(off[1], off[0]))


def within_reach(point: np.ndarray) -> np.ndarray:
    """A wall pinch's grip point moved toward the arm's base to REACH_M from it (by at most
    REACH_SHIFT_M), or as it is when nearer."""
    off = point[:2] - ROBOT_BASE_XY
    dist = float(np.linalg.norm(off))
    if dist <= REACH_M:
        return point
    out = np.array(point, dtype=float)
    out[:2] -= off / dist * min(dist - REACH_M, REACH_SHIFT_M)
    return out


def handle_grasp(world: World, instance: str, pts: np.ndarray) -> Grasp | None:
    """A grasp across a handle: a wide object whose top is solid (the wall pinch's inner finger
    would stand in the object's own geoms, a moka pot) is taken by its handle (`handle`)."""
    center = (pts.min(0) + pts.max(0)) / 2
    boxes = [geom_corners(world.m, world.d, [g]) for g in world.geoms(instance)]
    solid_top = any(
        np.all(np.abs((c.min(0) + c.max(0))[:2] / 2 - center[:2]) < (c.max(0) - c.min(0))[:2] / 2)
        and c.max(0)[2] > pts[:, 2].max() - SOLID_TOP_M
        for c in boxes
    )
    toward = handle(world.hulls(instance)) if solid_top else None
    return None if toward is None else outer_part_grasp(world, instance, toward)


def handle(hulls: list[np.ndarray], prefer: np.ndarray | None = None) -> np.ndarray | None:
    """The horizontal direction of an object's handle (its collision geoms' hulls), at whatever yaw
    the object stands: of HANDLE_DIRECTIONS directions, the one whose outer part (`outer_part`) is
    thinnest across it, under HANDLE_MAX_M, and at least HANDLE_MIN_HEIGHT_M tall; of equals, the
    nearest `prefer`. None when no part is that thin."""
    best: tuple[float, float, np.ndarray] | None = None
    for ang in np.linspace(0.0, 2 * np.pi, HANDLE_DIRECTIONS, endpoint=False):
        d = np.array([np.cos(ang), np.sin(ang), 0.0])
        part = outer_part(hulls, d)
        across = float(np.ptp(part[:, :2] @ [-d[1], d[0]]))
        if across >= HANDLE_MAX_M or np.ptp(part[:, 2]) < HANDLE_MIN_HEIGHT_M:
            continue
        key = (round(across, 3), 0.0 if prefer is None else -float(d @ prefer))
        if best is None or key < best[:2]:
            best = (*key, d)
    return None if best is None else best[2]


def outer_part(hulls: list[np.ndarray], toward: np.ndarray) -> np.ndarray:
    """The points of an object (its collision geoms' hulls) within OUTER_BAND_M of its farthest
    point toward `toward` (a horizontal unit vector): the hulls cut there, not whole (a convex piece
    of a deformed moka pot bridges its lid and its handle: whole, it made the handle 4 cm wide)."""
    far = max(float((h @ toward).max()) for h in hulls)
    return beyond(hulls, toward, far - OUTER_BAND_M)


def _clear_pinch(world: World, instance: str, pts: np.ndarray, z: float) -> Grasp | None:
    """A pinch of the solid `pts` at height `z`: of the directions it is at most MAX_PINCH_M
    across, the one where the open hand comes down lowest (its palm is 21 cm long along the
    closing axis: beside a standing neighbour it turns away from it), the narrowest of equals.
    None when it is too wide every way."""
    dirs, across = widths(pts)
    fit = np.flatnonzero(across <= MAX_PINCH_M)
    if not len(fit):
        return None
    boxes = obstacle_boxes(world, (instance,))
    points = {int(k): extent_middle(pts, dirs[k], z) for k in fit}
    k = min(points, key=lambda k: (round(max(z, reach_height(boxes, points[k], dirs[k])), 3), across[k]))
    return Grasp(along_free(boxes, pts, points[k], dirs[k]), dirs[k], float(across[k]), rim=False)


def along_free(boxes: np.ndarray, pts: np.ndarray, point: np.ndarray, axis: np.ndarray) -> np.ndarray:
    """A pinch of a long object (a lying bottle: longer than LONG_M across the fingers) whose middle
    the open hand cannot come down to, moved along the object to where it comes down lowest (of
    equals, nearest the middle), at least END_M inside its ends; any other pinch as it is.
    libero_goal-09's lying bottle lies with its neck under the wine rack's front: the hand over its
    middle stopped on the rack's lower lip 5.6 cm over the pinch and closed on nothing (trial 1; moved
    2 cm toward its base, the hand comes down to the pinch)."""
    stop = max(point[2], reach_height(boxes, point, axis))
    along = np.array([-axis[1], axis[0], 0.0])
    proj = pts[:, :2] @ along[:2] - point[:2] @ along[:2]
    if np.ptp(proj) <= LONG_M or stop <= point[2] + BLOCKED_M:
        return point
    shifts = np.arange(proj.min() + END_M, proj.max() - END_M + 1e-9, SHIFT_STEP_M)
    best = min(shifts, key=lambda s: (round(max(point[2], reach_height(boxes, point + along * s, axis)), 3), abs(s)))
    return point + along * best


def narrow_top_grasp(world: World, instance: str) -> Grasp | None:
    """A solid object too wide to pinch whole but narrow toward its top (a tapered can): pinched as
    deep (down to NARROW_DEPTH_M) as the fingers' pads, coming down, still pass outside everything
    above them. None when even its top is too wide (an inverted bowl: its 5 cm foot stands 6 mm
    over 9 cm shoulders, so the pads meet the shoulders)."""
    top = narrow_top(world, instance)
    grasp = None if top is None else _clear_pinch(world, instance, *top)
    return None if grasp is None else replace(grasp, hung=True, part=top)


def narrow_top(world: World, instance: str) -> tuple[np.ndarray, float] | None:
    """(the points of the object's top that `narrow_top_grasp` pinches, the grip site's height): as
    deep as NARROW_DEPTH_M while the part the pads reach is at most MAX_PINCH_M across some way."""
    hulls = world.hulls(instance)
    top = max(float(h[:, 2].max()) for h in hulls)
    best = None
    for depth in np.arange(0.004, NARROW_DEPTH_M + 1e-9, 0.002):
        part = above(hulls, top - depth - FINGER_PAD_HALF_M)
        if narrowest(part)[1] > MAX_PINCH_M:
            break
        best = part, top - depth
    return best


def hand_stop(boxes: np.ndarray, pts: np.ndarray, z: float) -> float:
    """How far above the pinch height `z` the open hand stops, at best, over a pinch of the solid
    `pts` (as `_clear_pinch` ranks them; boxes: the obstacles' (N, 2, 3) world boxes): 0 when some
    direction it fits across lets the hand come down to `z`; inf when it fits across none."""
    dirs, across = widths(pts)
    fit = np.flatnonzero(across <= MAX_PINCH_M)
    return min(
        (max(z, reach_height(boxes, extent_middle(pts, dirs[k], z), dirs[k])) - z for k in fit), default=float("inf")
    )


def foot_grasp(world: World, instance: str) -> Grasp | None:
    """The foot of an upside-down object pinched gently (`foot.foot_pinch`): the fingers close to
    FOOT_SQUEEZE_M inside the foot and hold there (closed fully, their 20 N press them over its edge)."""
    pinch = foot_pinch(world.hulls(instance))
    if pinch is None:
        return None
    point, axis, width = pinch
    return Grasp(point, axis, width, rim=False, squeeze_to=width - FOOT_SQUEEZE_M)


def outer_part_grasp(world: World, instance: str, toward: np.ndarray) -> Grasp | None:
    """A grasp across the object's thin part that sticks out farthest toward `toward` (a handle,
    `outer_part`), when it is thinner than HANDLE_MAX_M across `toward`; the fingers close across
    it, at its middle."""
    part = outer_part(world.hulls(instance), toward)
    across = np.array([-toward[1], toward[0], 0.0])
    along, side = part[:, :2] @ toward[:2], part[:, :2] @ across[:2]
    if np.ptp(side) >= HANDLE_MAX_M:
        return None
    point = _pinch_across(part).point
    point[:2] = toward[:2] * (along.max() + along.min()) / 2 + across[:2] * (side.max() + side.min()) / 2
    return Grasp(point, across, float(np.ptp(side)), rim=False)


def _pinch_across(part: np.ndarray) -> Grasp:
    """A pinch across a thin part (its box corners) along its narrower world axis, 2 cm below its
    top or at 30% of its height."""
    lo, hi = part.min(0), part.max(0)
    size = hi - lo
    axis = np.array([1.0, 0.0, 0.0]) if size[0] < size[1] else np.array([0.0, 1.0, 0.0])
    point = (lo + hi) / 2
    point[2] = max(lo[2] + 0.3 * size[2], hi[2] - 0.02)
    return Grasp(point, axis, float(min(size[0], size[1])), rim=False)


def side_entry(boxes: np.ndarray, grasp: Grasp) -> np.ndarray:
    """Where the open hand comes down beside a wall pinch it cannot come straight down on (an opened
    drawer's front 10 cm over a bowl's rim, over the palm's inner end): the shortest shift along the
    wall (across the closing axis, so the wall stays between the fingers) where nothing stops the
    hand at the grasp's height, from which it slides in, the palm under the overhang. Zero when the
    hand comes straight down, or when no shift does."""
    none = np.zeros(3)
    if reach_height(boxes, grasp.point, grasp.axis, WITH_WRIST) <= grasp.point[2] or not grasp.rim:
        return none
    across = np.array([-grasp.axis[1], grasp.axis[0], 0.0])
    for dist in np.arange(ENTRY_STEP_M, ENTRY_MAX_M + 1e-9, ENTRY_STEP_M):
        for shift in (across * dist, -across * dist):
            point = grasp.point + shift
            clear = reach_height(boxes, point, grasp.axis, WITH_WRIST) <= grasp.point[2]
            if clear and hand_fits(boxes, point, grasp.axis):
                return shift
    return none


def blocked_spots(boxes: np.ndarray, grasp: Grasp) -> int:
    """Obstacle boxes in the way of the open fingertips coming down (boxes: (N, 2, 3) world boxes)."""
    across = np.array([-grasp.axis[1], grasp.axis[0], 0.0])
    hits = 0
    for offset, half_along, half_across, _ in HAND_PARTS[:2]:
        spot = grasp.point + grasp.axis * offset
        lo = spot - np.abs(grasp.axis) * half_along - np.abs(across) * half_across
        hi = spot + np.abs(grasp.axis) * half_along + np.abs(across) * half_across
        lo[2], hi[2] = spot[2] - 0.01, spot[2] + HOVER_M
        hits += int(np.sum(np.all(boxes[:, 0] < hi, axis=1) & np.all(boxes[:, 1] > lo, axis=1)))
    return hits


def sided_yaw(world: World, left: np.ndarray) -> float | None:
    """The yaw (`motion.down_with_yaw`) that puts the left finger toward `left` (the gripper's x axis
    points to the right finger), the turn from now the shortest; None when the wrist cannot turn there."""
    yaw = float(np.arctan2(-left[1], -left[0]))
    now = motion.yaw_of(world.eef_mat())
    yaw += 2 * np.pi * np.round((now - yaw) / (2 * np.pi))
    return yaw if motion.wrist_yaw_room(world, yaw - now) >= 0 else None


def grasp_orientation(world: World, axis: np.ndarray, sided: bool = False, at: np.ndarray | None = None) -> np.ndarray:
    """Gripper pointing down with the fingers closing along `axis`: the yaw nearest the current, or
    the other (half a turn away) when the nearer would turn the wrist past its limit. `sided`: the
    left finger toward `axis` (`sided_yaw`), where the wrist can turn so. `at`: where (xy) the hand
    will hold that yaw; the arm's base joint turns on the way there and the wrist takes the turn
    back (libero_object-09's lying carton, turned 42 degrees for the basket from the wrist 0.77 rad
    short of its limit, carried 34 cm across the base's bearing: the wrist hit its limit half way,
    the carry stalled and the carton was let go 18 cm short)."""
    yaw_sided = sided_yaw(world, axis) if sided else None
    if yaw_sided is not None:
        return motion.down_with_yaw(yaw_sided)
    yaw = float(np.arctan2(axis[1], axis[0]))
    now = motion.yaw_of(world.eef_mat())
    yaw += np.pi * np.round((now - yaw) / np.pi)
    base_turn = 0.0 if at is None else bearing(at) - bearing(world.eef()[:2])

    def room(y: float) -> float:
        return motion.wrist_yaw_room(world, y - now - base_turn)

    if room(yaw) < 0:
        yaw = max((yaw, yaw - np.pi * np.sign(yaw - now)), key=room)
    return motion.down_with_yaw(yaw)
