"""Push a flat object (libero_goal's plate) along the table onto a table region.

The closed fingers come down inside the object's far rim (the side away from where it goes), just
above its floor, then move toward the goal, re-aiming from the object's current body position each
step. Pushing from inside keeps the hand over the object: behind it there may be no room
(libero_goal's plate lies 4 cm in front of the cabinet).

The way there avoids obstacles: the hand is about 20 cm wide along its fingers and reaches down to
4 cm above the fingertips, so a hand sweeping beside the plate meets what stands there (libero_goal-05's
bowl beside the plate's straight path to the stove's front). Of three paths (straight; along y, then
x; along x, then y) and a few hand yaws per leg (fingers across the push first: a wider pusher), the
push takes the one whose hand and object sweep through the fewest obstacles (objects, then their geoms; each gripper geom's box
swept on its own), preferring the
straight path on a tie. LIBERO's `On` check ends the last leg.

Far out, the arm's reach decides first (libero_goal-05 familiar_position: the plate 0.84-0.86 m from
the arm's base, its far rim 0.92 m; the hand pointing down, driven at full action toward the far
rim, stops 0.84-0.85 m out and the plate does not move). Routes whose pushing hand (at the leading rim's inside) stays within PUSH_REACH_M come
before the others; the fingers come down no farther out than that, anywhere inside the object before
its leading rim (they push that rim wherever they start); and beyond `grasp.REACH_M` the hand tips
outward, which brings the grip site 1-2 cm farther at the table's height.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from vpro_assets.core.mjgeom import axis_angle_quat, geom_corners, quat_matrix
from vpro_assets.rollout.policies.oracle import motion
from vpro_assets.rollout.policies.oracle.clearance import obstacle_pieces
from vpro_assets.rollout.policies.oracle.grasp import REACH_M, ROBOT_BASE_XY, grasp_orientation
from vpro_assets.rollout.policies.oracle.motion import CLOSE, Actions
from vpro_assets.rollout.policies.oracle.world import SkillFailed, World

CONTACT_Z_M = 0.012  # fingertips this high above the object's bottom while pushing
INSIDE_M = 0.03  # fingertips this far inside the object's far edge
PUSH_STEPS = 200
STEP_AHEAD_M = 0.03
LEG_TOL_M = 0.015  # an intermediate leg ends with the object this close to its waypoint
MIN_LEG_M = 0.02
STALL_M, STALL_STEPS = 0.005, 30  # a leg ends when the object moved less than this in that many steps
YAWS_DEG = (0.0, 90.0, 45.0, -45.0)  # finger axis relative to across the push, in order of preference
PATH_SAMPLES = 10
INSIDE_CHOICES_M = (INSIDE_M, 0.05, 0.07, 0.09)  # deeper starts keep a hand along the push off what is behind
RIM_M = 0.015  # a hand pushing from inside reaches at most this far inside the object's leading edge
# A push from inside starts at most PUSH_REACH_M from the arm's base, else farther along the push, at
# most to START_BEFORE_RIM_M before the leading rim's inside: the fingers push that rim whatever their
# start inside the object. A start beyond the reach of a hand pointing down (`grasp.REACH_M`) is
# pushed from with the hand tipped REACH_PITCH_DEG outward, away from the arm's base: pointing down,
# the grip site sagged to 0.84-0.85 m 1 cm over the table; tipped 20 degrees it came to 0.86 m within
# 3 mm at 2.5 cm over it, its lowest point 2 cm under the grip site as pointing down. Started 0.85 m
# out, the tipped hand straightened the elbow (joint 4 at its limit) and stuck there.
PUSH_REACH_M, START_BEFORE_RIM_M, REACH_PITCH_DEG = 0.83, 0.02, 20.0


@dataclass(frozen=True)
class Leg:
    to: np.ndarray  # where the object's body position goes (xy)
    orient: np.ndarray  # the hand's orientation while pushing
    inside: float  # the fingertips start this far inside the object's far edge


def hand_points(world: World) -> list[np.ndarray]:
    """Corners of each of the gripper's collision geoms in the grip site's frame (8 x 3 each): the
    narrow fingers reach lower than the wide hand."""
    return [(geom_corners(world.m, world.d, [g]) - world.eef()) @ world.eef_mat() for g in sorted(world.gripper_geoms)]


def _sweep(boxes: np.ndarray, local: np.ndarray, path: np.ndarray) -> set[int]:
    """Obstacle boxes met by the point set `local` translated along `path`: by the box around the
    points at some point of the path. All points of the path at once, and only for the obstacles
    that reach the box around the whole sweep (the same sums and comparisons as one point at a time)."""
    pts = path[:, None, :] + local[None]  # (path, points, 3)
    lo, hi = pts.min(1), pts.max(1)
    near = np.flatnonzero(np.all(boxes[:, 0] < hi.max(0), axis=1) & np.all(boxes[:, 1] > lo.min(0), axis=1))
    cand = boxes[near]
    met = np.any(np.all(cand[:, None, 0] < hi[None], axis=2) & np.all(cand[:, None, 1] > lo[None], axis=2), axis=1)
    return set(near[met].tolist())


def _reaching(boxes: np.ndarray, sweeps: list[tuple[np.ndarray, np.ndarray]]) -> np.ndarray:
    """The indices of the boxes that reach the box around all the point sets `local` translated
    along `path` of `sweeps` ((local, path) pairs, as `_sweep` takes them)."""
    pts = [(path[:, None, :] + local[None]).reshape(-1, 3) for local, path in sweeps]
    lo, hi = np.min([p.min(0) for p in pts], axis=0), np.max([p.max(0) for p in pts], axis=0)
    return np.flatnonzero(np.all(boxes[:, 0] < hi, axis=1) & np.all(boxes[:, 1] > lo, axis=1))


def back_reach(world: World, obj: str, direction: np.ndarray, inside: float = INSIDE_M) -> float:
    """From the object's body position back to the fingertips, for a push along `direction`."""
    proj = (world.points(obj)[:, :2] - world.body_pos(obj)[:2]) @ direction
    return float(-proj.min() - inside)


def _unit(v: np.ndarray) -> np.ndarray:
    n = float(np.linalg.norm(v))
    return v / n if n > 1e-6 else np.array([1.0, 0.0])


def _leg(
    world: World,
    obj: str,
    frm: np.ndarray,
    to: np.ndarray,
    boxes: np.ndarray,
    hand: list[np.ndarray],
    owners: list[str],
    geoms: np.ndarray,
) -> tuple[set, Leg]:
    """The obstacles a leg frm -> to meets (object and hand) with its best hand yaw and start inside
    the object, and the leg."""
    direction = _unit(to - frm)
    z = world.box(obj).lo[2] + CONTACT_Z_M
    t = np.linspace(0.0, 1.0, PATH_SAMPLES)[:, None]
    centres = np.column_stack([frm + t * (to - frm), np.full(PATH_SAMPLES, z)])
    obj_local = world.points(obj) - np.append(world.body_pos(obj)[:2], z)
    across = np.array([-direction[1], direction[0]])
    # Every sweep of the leg (the object's; each hand part's at each yaw and start inside), and the
    # boxes reaching the box around all of them: only those can reach the box around one sweep
    # (`_sweep`'s first test), so each sweep is tested against them alone (the same boxes met).
    legs = []
    for deg in YAWS_DEG:
        c, s = np.cos(np.radians(deg)), np.sin(np.radians(deg))
        axis = np.array([c * across[0] - s * across[1], s * across[0] + c * across[1], 0.0])
        orient = grasp_orientation(world, axis)
        for inside in INSIDE_CHOICES_M:
            grips = centres - np.append(direction * back_reach(world, obj, direction, inside), 0.0)
            legs.append((Leg(to, orient, inside), [(part @ orient.T, grips) for part in hand]))
    near = _reaching(boxes, [(obj_local, centres), *(sweep for _, parts in legs for sweep in parts)])
    reached = boxes[near]

    def met(local: np.ndarray, path: np.ndarray) -> set[int]:
        return set(near[sorted(_sweep(reached, local, path))].tolist())

    obj_hits = met(obj_local, centres)
    best: tuple[tuple[int, int], set, Leg] | None = None
    for leg, parts in legs:
        hits = set(obj_hits)
        for local, grips in parts:
            hits |= met(local, grips)
        score = (len({owners[h] for h in hits}), len({geoms[h] for h in hits}))
        if best is None or score < best[0]:
            best = (score, hits, leg)
    assert best is not None  # YAWS_DEG and INSIDE_CHOICES_M are not empty
    return best[1], best[2]


def beyond_reach(world: World, obj: str, frm: np.ndarray, to: np.ndarray) -> bool:
    """Whether a hand pushing the object's leading rim from inside (`push_leg`) along frm -> to goes
    farther than PUSH_REACH_M from the arm's base on the way. A plate 0.86 m out pushed first
    across the arm kept the stretched hand there, and stopped (libero_goal-05 familiar_position)."""
    direction = _unit(to - frm)
    pos = world.body_pos(obj)[:2]
    front = float(((world.points(obj)[:, :2] - pos) @ direction).max()) - RIM_M
    t = np.linspace(0.0, 1.0, PATH_SAMPLES)[:, None]
    hands = frm + t * (to - frm) + direction * front
    return bool(np.any(np.linalg.norm(hands - ROBOT_BASE_XY, axis=1) > PUSH_REACH_M))


def push_path(world: World, obj: str, target: np.ndarray) -> list[Leg]:
    """The legs of the push with the fewest obstacles on the way (the straight path on a tie), of
    those that keep the pushing hand within reach if any do."""
    boxes, geoms = obstacle_pieces(world, (obj,))
    owners = [world.root_name(g) for g in geoms]  # the object or fixture of each box
    hand = hand_points(world)
    pos = world.body_pos(obj)[:2]
    routes = [[target], [np.array([pos[0], target[1]]), target], [np.array([target[0], pos[1]]), target]]
    best: tuple[tuple[bool, int, int], list[Leg]] | None = None
    for route in routes:
        hits: set = set()
        legs, frm, out = [], pos, False
        for way in route:
            if np.linalg.norm(way - frm) < MIN_LEG_M:
                continue
            leg_hits, leg = _leg(world, obj, frm, way, boxes, hand, owners, geoms)
            hits |= leg_hits
            out = out or beyond_reach(world, obj, frm, way)
            legs.append(leg)
            frm = way
        # Within reach first, then objects met, then geoms met.
        score = (out, len({owners[h] for h in hits}), len({geoms[h] for h in hits}))
        if legs and (best is None or score < best[0]):
            best = (score, legs)
    return best[1] if best else [Leg(target, grasp_orientation(world, np.array([0.0, 1.0, 0.0])), INSIDE_M)]


def within_reach(start: np.ndarray, direction: np.ndarray, most: float) -> np.ndarray:
    """The push's start `start` (xy) moved along `direction` (a unit vector) until it is within
    PUSH_REACH_M of the arm's base, by at most `most`; as it is when already within. A plate 0.86 m
    out (libero_goal-05 familiar_position) has its far rim beyond the hand's reach and its leading rim
    within it, and the start that reaches nothing left the plate unmoved."""
    off = start - ROBOT_BASE_XY
    if float(np.linalg.norm(off)) <= PUSH_REACH_M or most <= 0.0:
        return start
    # The smallest s >= 0 with |off + s * direction| = PUSH_REACH_M (the nearer root), else the
    # point of the line nearest the base when the line passes outside.
    b = float(off @ direction)
    disc = b * b - (float(off @ off) - PUSH_REACH_M**2)
    s = -b - np.sqrt(disc) if disc >= 0.0 else -b
    return start + direction * float(np.clip(s, 0.0, most))


def tipped_out(orient: np.ndarray, xy: np.ndarray) -> np.ndarray:
    """`orient` (pointing down) tipped REACH_PITCH_DEG about the horizontal axis across the line from
    the arm's base to `xy`, the fingertips outward, where `xy` lies beyond REACH_M; else `orient`."""
    out = xy - ROBOT_BASE_XY
    dist = float(np.linalg.norm(out))
    if dist <= REACH_M:
        return orient
    axis = np.array([out[1], -out[0], 0.0]) / dist  # turning about it takes -z toward `out`
    return quat_matrix(axis_angle_quat(axis, np.radians(REACH_PITCH_DEG))) @ orient


def push_leg(world: World, obj: str, leg: Leg, done, lead_from_hand: bool = False) -> Actions:
    """Push the object's body position toward `leg.to` until `done()`.

    With `lead_from_hand` (a push from inside a plate) the hand's goal runs a step ahead of the hand
    itself, up to the leading rim's inside: a goal a step ahead of a nominal place behind the object
    shrinks with the distance left and stops the hand where its fingers rest on the floor and push
    nothing (libero_goal-05's deformed plates stopped 1-10 cm short, the hand pressing on them)."""
    pos = world.body_pos(obj)[:2]
    direction = _unit(leg.to - pos)
    reach = back_reach(world, obj, direction, leg.inside)
    start_xy = pos - direction * reach
    if lead_from_hand:
        front = float(((world.points(obj)[:, :2] - pos) @ direction).max()) - RIM_M - START_BEFORE_RIM_M
        start_xy = within_reach(start_xy, direction, reach + front)
    orient = tipped_out(leg.orient, start_xy) if lead_from_hand else leg.orient
    start = np.append(start_xy, world.box(obj).lo[2] + CONTACT_Z_M)
    yield from motion.move_to(world, start + [0, 0, 0.10], CLOSE, orient, tol=0.012, max_steps=150)
    yield from motion.move_to(world, start, CLOSE, orient, tol=0.008, max_steps=80, speed=0.6)
    moved_at, moved_from = 0, world.body_pos(obj)[:2]
    for k in range(PUSH_STEPS):
        if done():
            break
        pos = world.body_pos(obj)[:2]
        if np.linalg.norm(pos - moved_from) > STALL_M:
            moved_at, moved_from = k, pos
        elif k - moved_at > STALL_STEPS:
            break  # the object stopped following: on to the next leg (or a new plan)
        err = leg.to - pos
        # Keep the fingers behind the object's centre on the line to the waypoint.
        unit = _unit(err)
        # A goal a short step ahead of the fingers' place behind the object: the hand never runs
        # ahead of an object that stopped following.
        aim = np.append(pos - unit * reach + unit * min(float(np.linalg.norm(err)), STEP_AHEAD_M), start[2])
        if lead_from_hand:
            # The hand keeps on the line through the object to the waypoint, a step ahead of where
            # it is along it, never past the leading rim's inside.
            front = float(((world.points(obj)[:, :2] - pos) @ unit).max()) - RIM_M
            along = min(float((world.eef()[:2] - pos) @ unit) + STEP_AHEAD_M, front)
            aim = np.append(pos + unit * along, start[2])
        yield motion.action_to(world, aim, CLOSE, orient, speed=0.5)
    yield from motion.move_to(world, world.eef() + [0, 0, 0.08], CLOSE, orient, tol=0.02, max_steps=30)


def push_to(world: World, obj: str, region: str) -> Actions:
    goal = ("on", obj, region)
    if world.holds(goal):
        return
    target = world.site_pos(region)[:2]
    legs = push_path(world, obj, target)
    for i, leg in enumerate(legs):
        if i == len(legs) - 1:
            yield from push_leg(world, obj, leg, lambda: world.holds(goal), lead_from_hand=True)
        else:
            to = leg.to
            yield from push_leg(
                world,
                obj,
                leg,
                lambda to=to: world.holds(goal) or np.linalg.norm(world.body_pos(obj)[:2] - to) < LEG_TOL_M,
                lead_from_hand=True,
            )
        if world.holds(goal):
            break
    if not world.holds(goal):
        raise SkillFailed(f"{obj} not pushed onto {region} (at {np.round(world.body_pos(obj)[:2], 3).tolist()})")
