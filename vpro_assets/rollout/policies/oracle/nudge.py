"""Push an object clear of a neighbour that stops the hand coming down to pinch it.

A solid too wide to pinch whole may fit the open fingers only across a few directions, near its
top (libero_object-01's and libero_10-01's twisted cream cheese: 1.9 cm tall, at least 8.0 cm
across at its base, its top 7.27-7.38 cm across in three directions 94-96 degrees). The pinch turns
the hand away from standing neighbours (`grasp._clear_pinch`), but when every direction that fits
puts the palm (21 cm along the closing axis) over a neighbour, the hand stops on it (3.5 cm over the
pinch on the tomato sauce in libero_object-01, 9-12 cm on the milk in libero_10-01) and the fingers
close on nothing. Then (only for an object held by its narrow top: in Normal scenes the hand model
puts the palm over a neighbour above some whole pinches, libero_10-01's cream cheese among them,
and those pinches hold) the object is first pushed along the table: of 16 directions, the shortest
push that lets the open hand come down to the pinch, takes the object clear of its neighbours all
the way and leaves it on what it stands on, and along which the pushing hand meets nothing. The
push is `push`'s: the hand pointing down with its closed fingertips low behind the object, the
fingers closing along the push, so the palm (6.6 cm wide across it) passes over the low object and
not across its neighbours (a hand tilted with its palm across the push, as `swing` pushes a mug,
met the cans standing 5-10 cm behind libero_10-01's cream cheese in every direction that clears).
"""

from __future__ import annotations

from collections.abc import Generator, Iterator
from dataclasses import dataclass

import numpy as np

from vpro_assets.rollout.policies.oracle import motion, push
from vpro_assets.rollout.policies.oracle.clearance import object_boxes, obstacle_boxes
from vpro_assets.rollout.policies.oracle.grasp import Grasp, grasp_orientation, hand_stop, plan_grasp
from vpro_assets.rollout.policies.oracle.motion import CLOSE
from vpro_assets.rollout.policies.oracle.world import World

DIRECTIONS = 16
STEP_M, MAX_M = 0.01, 0.12
# The hand stops too high when it stops more than STOP_M over the pinch and its grip site then stands
# less than GRIP_BELOW_TOP_M under the object's top (a tall can pinched 3 cm under its top may stop 2.5 cm high).
STOP_M, GRIP_BELOW_TOP_M = 0.003, 0.005
SUPPORT_M = 0.005  # the object stays over boxes whose top is this close to its bottom
MARGIN_M = 0.01  # pushed this much past the shortest shift that clears the hand
# The grip site (between the closed fingers) starts this far behind the object: 2 cm, else 1 cm
# (libero_10-01 twist-s3 trial 0: 2 cm back, the palm's far end came down 1.3 cm into the alphabet soup).
BEHIND_M = (0.02, 0.01)
HOVER_M = 0.10  # the hand comes down onto the push's start from this far over it (`push.push_leg`)
WAY_M, WAY_ABOVE_M = 0.15, 0.05  # the hand goes to the push's start this high over what stands this near its way
NEAR_M = 0.3  # obstacle boxes this close to the push's start (in x and y) may meet the hand
PATH_MARGIN_M = 0.003  # on its way the object passes this close to its neighbours (it starts 8 mm from one)
# The fingers' closing axis from the push direction, in order of preference: along it (the palm, 21 cm
# along the closing axis, then trails over the low object), diagonal, across.
YAWS_DEG = (0.0, 15.0, -15.0, 30.0, -30.0, 45.0, -45.0, 60.0, -60.0, 90.0)


def blocked(world: World, instance: str, grasp: Grasp | None = None) -> bool:
    """Whether the open hand stops too high (`_too_high`) over the pinch `grasp` takes across
    `instance` because something stands where it comes down; False when the object is not taken by
    a pinch of its narrow top (the grasp's `part`). `grasp`: `grasp.plan_grasp`'s, in this state
    (planned here when not given)."""
    part = (plan_grasp(world, instance) if grasp is None else grasp).part
    if part is None:
        return False
    pts, z = part
    return _too_high(
        hand_stop(obstacle_boxes(world, (instance,)), pts, z), z, float(world.points(instance)[:, 2].max())
    )


def _too_high(stop: float, z: float, top: float) -> bool:
    """Whether a hand stopping `stop` over a pinch at grip height `z` of an object whose top is at
    `top` stops too high to pinch it."""
    return z + stop > max(z + STOP_M, top - GRIP_BELOW_TOP_M)


def _supported(boxes: np.ndarray, own: np.ndarray) -> bool:
    """Whether every corner of the object's footprint (its boxes `own`) lies over a box whose top
    is within SUPPORT_M of the object's bottom (the table it stands on)."""
    bottom = float(own[:, 0, 2].min())
    floor = boxes[np.abs(boxes[:, 1, 2] - bottom) < SUPPORT_M]
    lo, hi = own[:, 0, :2], own[:, 1, :2]
    corners = np.concatenate([lo, hi, np.c_[lo[:, 0], hi[:, 1]], np.c_[hi[:, 0], lo[:, 1]]])
    inside = np.all((corners[:, None] >= floor[None, :, 0, :2]) & (corners[:, None] <= floor[None, :, 1, :2]), axis=2)
    return bool(inside.any(axis=1).all())


def _on_support(boxes: np.ndarray, own: np.ndarray, shifted: np.ndarray) -> bool:
    """Whether the object moved to `shifted` (its boxes) still stands on what it stands on at `own`:
    on a box (a table's top), all of it over a box of that height; on the floor (a plane, not a
    box: libero_object's scenes), anywhere."""
    return _supported(boxes, shifted) or not _supported(boxes, own)


@dataclass(frozen=True)
class Push:
    direction: np.ndarray  # horizontal unit vector
    dist: float
    orient: np.ndarray  # the hand's orientation, pointing down
    behind: float  # the grip site starts this far behind the object


def clearing_shift(world: World, instance: str, grasp: Grasp | None = None) -> Push | None:
    """The shortest push after which the open hand comes
    down to the pinch (`blocked` no longer holds), the object on the way clear of its neighbours
    and over what it stands on, and the pushing hand (at the first of YAWS_DEG that fits), coming
    down behind it and following it, clear of everything; None when none within MAX_M does.
    `grasp`: as `blocked`'s."""
    part = (plan_grasp(world, instance) if grasp is None else grasp).part
    if part is None:
        return None
    pts, z = part
    whole = world.points(instance)
    top = float(whole[:, 2].max())
    boxes = obstacle_boxes(world, (instance,))
    own = object_boxes(world, instance)
    hand = closed_hand(world)
    dirs = [np.array([np.cos(a), np.sin(a), 0.0]) for a in np.linspace(0, 2 * np.pi, DIRECTIONS, endpoint=False)]

    def candidates() -> Iterator[tuple[np.ndarray, float]]:
        """(direction, distance) that clear the hand over the pinch, shortest first."""
        for dist in np.arange(STEP_M, MAX_M + 1e-9, STEP_M):
            for d in dirs:
                if _too_high(hand_stop(boxes, pts + d * dist, z), z, top):
                    continue
                path = [d * s for s in np.arange(STEP_M, dist + MARGIN_M + 1e-9, STEP_M)]
                if not any(_meets(boxes, own + p) for p in path) and _on_support(boxes, own, own + path[-1]):
                    yield d, float(dist + MARGIN_M)

    def fitting(d: np.ndarray, dist: float, behind: float) -> Push | None:
        for yaw in YAWS_DEG:
            orient = grasp_orientation(world, _turn(d, yaw))
            if not _hand_meets(world, instance, boxes, hand, orient, d, dist, behind):
                return Push(d, dist, orient, behind)
        return None

    # Every candidate with the first of BEHIND_M, then with the next: the candidates are made as the
    # first pass needs them (the measure of each is the hand's stop over the shifted pinch, a sweep
    # of 180 widths), so a short push that fits ends the search before the longer ones are made.
    made: list[tuple[np.ndarray, float]] = []
    for d, dist in candidates():
        made.append((d, dist))
        if (push_ := fitting(d, dist, BEHIND_M[0])) is not None:
            return push_
    for behind in BEHIND_M[1:]:
        for d, dist in made:
            if (push_ := fitting(d, dist, behind)) is not None:
                return push_
    return None


def closed_hand(world: World) -> list[np.ndarray]:
    """`push.hand_points` with the fingers closed (the push closes them on its way down): each
    finger's points moved along the closing axis until its inner face is at the grip site."""
    parts = []
    for pts in push.hand_points(world):
        lo, hi = pts[:, 0].min(), pts[:, 0].max()
        if lo > 0.0 or hi < 0.0:  # a finger, wholly on one side of the grip site
            pts = pts - [lo if lo > 0.0 else hi, 0.0, 0.0]
        parts.append(pts)
    return parts


def _turn(v: np.ndarray, deg: float) -> np.ndarray:
    c, s = np.cos(np.radians(deg)), np.sin(np.radians(deg))
    return np.array([c * v[0] - s * v[1], s * v[0] + c * v[1], 0.0])


def _meets(boxes: np.ndarray, own: np.ndarray) -> bool:
    """Whether any of the object's boxes `own` comes within PATH_MARGIN_M of an obstacle box (in
    plan, at heights they share; not what it stands on)."""
    if not len(own):
        return False
    lo, hi = own[None, :, 0] - PATH_MARGIN_M, own[None, :, 1] + PATH_MARGIN_M
    lo[..., 2], hi[..., 2] = own[None, :, 0, 2] + 0.005, own[None, :, 1, 2]
    # Only a box reaching into the box around all of `own`'s can meet one of them: the pairs are
    # compared for those few (the same comparisons of the same numbers).
    near = boxes[np.all(boxes[:, 0] < hi[0].max(0), axis=1) & np.all(boxes[:, 1] > lo[0].min(0), axis=1)]
    return bool(np.any(np.all(near[:, None, 0] < hi, axis=2) & np.all(near[:, None, 1] > lo, axis=2)))


def _hand_meets(
    world: World,
    instance: str,
    boxes: np.ndarray,
    hand: list[np.ndarray],
    orient: np.ndarray,
    direction: np.ndarray,
    dist: float,
    behind: float,
) -> bool:
    """Whether the hand (its gripper geoms' corners `hand`, in the grip frame), pointing down at
    `orient`, meets an obstacle box coming down onto the push's start (`push.push_leg`'s, `behind`
    the object) or following it `dist` along `direction`. Each part is its box in the grip
    frame, turned with the hand (not its world box: turned 15 degrees, the palm's world box reaches
    3 cm further to the side), and meets a box when a corner of either lies in the other."""
    xy = world.body_pos(instance)[:2] - direction[:2] * push.back_reach(world, instance, direction[:2], -behind)
    start = np.array([*xy, world.box(instance).lo[2] + push.CONTACT_Z_M])
    near = boxes[np.all(np.abs((boxes[:, 0, :2] + boxes[:, 1, :2]) / 2 - xy) < NEAR_M, axis=1)]
    if not len(near):
        return False
    corners = np.stack(np.meshgrid([0, 1], [0, 1], [0, 1], indexing="ij"), -1).reshape(-1, 3)
    obstacle = near[:, 0][:, None] + corners[None] * (near[:, 1] - near[:, 0])[:, None]  # (N, 8, 3)
    down = [start + [0.0, 0.0, h] for h in np.linspace(0.0, HOVER_M, 6)]
    along = [start + direction * s for s in np.linspace(0.0, dist, max(2, int(dist / STEP_M) + 1))]
    if not hand:
        return False
    lo, hi = np.array([part.min(0) for part in hand]), np.array([part.max(0) for part in hand])  # (P, 3)
    # The parts' box corners turned with the hand, the same at every pose: (P * 8, 3).
    turned = np.concatenate([(lo_ + corners * (hi_ - lo_)) @ orient.T for lo_, hi_ in zip(lo, hi, strict=True)])
    for pose in down + along:  # every part at once: whether any meets a box, as part by part
        local = (obstacle.reshape(-1, 3) - pose) @ orient  # obstacle corners in the grip frame
        if np.any(np.all((local[None] > lo[:, None]) & (local[None] < hi[:, None]), axis=2)):
            return True
        world_pts = pose + turned
        if np.any(np.all((world_pts[:, None] > near[None, :, 0]) & (world_pts[:, None] < near[None, :, 1]), axis=2)):
            return True
    return False


def clear_for_pick(world: World, instance: str, grasp: Grasp) -> Generator[np.ndarray, None, bool]:
    """Push `instance` clear (`clearing_shift`) when a neighbour stops the hand over its pinch;
    nothing otherwise, or when no push clears it. `grasp`: `grasp.plan_grasp`'s in this state.
    Returns whether it pushed (else the state is unchanged and `grasp` still holds)."""
    if not blocked(world, instance, grasp):
        return False
    shift = clearing_shift(world, instance, grasp)
    if shift is None:
        return False
    direction = shift.direction[:2]
    goal = world.body_pos(instance)[:2] + direction * shift.dist
    # `push`'s leg: `inside` negative puts the fingertips behind the object's back, not inside its rim.
    leg = push.Leg(goal, shift.orient, -shift.behind)
    depth = float(goal @ direction)
    # Over the push's start above everything near the way there first (from the home pose straight
    # to `push`'s hover point, libero_10-01's hand caught on the milk carton's top).
    start = world.body_pos(instance)[:2] - direction * push.back_reach(world, instance, direction, -shift.behind)
    boxes = obstacle_boxes(world, (instance,))
    way = np.linspace(world.eef()[:2], start, 10)
    near = np.any(
        np.all(np.abs((boxes[:, None, 0, :2] + boxes[:, None, 1, :2]) / 2 - way[None]) < WAY_M, axis=2), axis=1
    )
    z = max(float(world.eef()[2]), float(boxes[near, 1, 2].max(initial=world.table_z)) + WAY_ABOVE_M)
    yield from motion.move_to(world, [*world.eef()[:2], z], CLOSE, shift.orient, tol=0.02, max_steps=60)
    yield from motion.move_to(world, [*start, z], CLOSE, shift.orient, tol=0.015, max_steps=120)
    yield from push.push_leg(world, instance, leg, lambda: float(world.body_pos(instance)[:2] @ direction) >= depth)
    return True
