"""Pick an object and put it on or into a destination: an object (plate, bowl, basket), a fixture
region (a stove's cook region, a cabinet's top, a drawer, a rack) or a named table region ("to the
right of the plate").

LIBERO's checks decide where the object must end: `On` an object wants the two bodies' positions
within 3 cm horizontally and in contact; `On` or `In` a region wants the object's body position in
the region's box. So the carry aims the held object's *body position* (not its box centre) at the
destination's centre. The carry rises to clear every obstacle in the corridor between the object
and the destination (the boxes of their pieces; not what the object only moves away from), and
comes down on its way once nothing ahead stands higher than what is at the destination; where the
arm, stretched far out, stops below the height asked, it carries on at the height it reached. The
object is lowered until it touches something or reaches the destination's surface, then released.
An object held standing taller than LIBERO's `On` of a region allows (an inverted wine bottle) is
laid on its side there (`lay`). An object that turned in the fingers on the way is turned back to
how it stood before it is lowered (`level`); the first of several objects for one region goes where
it leaves room for the others (`room`).
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from vpro_assets.rollout.policies.oracle import lay, level, motion, nudge, reach, room
from vpro_assets.rollout.policies.oracle.articulation import is_drawer, joint_for
from vpro_assets.rollout.policies.oracle.clearance import object_boxes, obstacle_boxes
from vpro_assets.rollout.policies.oracle.drawer import handle_point, open_direction
from vpro_assets.rollout.policies.oracle.fit import fit_turn
from vpro_assets.rollout.policies.oracle.grasp import plan_grasp
from vpro_assets.rollout.policies.oracle.motion import OPEN, Actions
from vpro_assets.rollout.policies.oracle.pick import pick
from vpro_assets.rollout.policies.oracle.world import SkillFailed, World

CLEAR_M = 0.04  # the held object's bottom this far above every obstacle on the way
# An object held by its narrow top only (a twisted cream cheese pinched across its top 4 mm, `hung`)
# tilts in the fingers as it is carried; its bottom then clears obstacles by SWAY of its half width more.
SWAY = 0.5
MAX_CARRY_ABOVE_TABLE_M = 0.45  # highest grip site the arm reaches comfortably, above the table
RELEASE_ABOVE_M = 0.012  # release when the object's bottom is this close to the destination surface
RETREAT_M = 0.10
# A released object that hangs on the open hand is set down, then the hand moves this far toward the
# object's middle along the fingers' axis before it rises (the inner finger out of where it jammed).
FREE_M = 0.03
CARRY_SPEED = 0.6  # a held object (a bowl pinched at its wall) slips under full-speed jerks
CARRY_STALL_STEPS = 6  # a carry move has stalled (the arm stretched to its reach) after so many steps
AWAY_GAP_M = 0.005  # an obstacle this far beside the carried object that the path leads away from is passed
CARRY_DESCENT_M = 0.02  # the carry comes down on its way when that saves at least this much lowering
CARRY_WAY_TOL_M = 0.02  # passing the way point where it may start coming down
CARRY_END_TOL_M = 0.01  # over the destination
# A carry that ends at most this much nearer the shoulder than a wrong-bent elbow reaches is not unbent first.
UNBEND_SLACK_M = 0.03
DRAWER_FRONT_M = 0.03  # a drawer's front panel lies this far behind its handle
GAP_CHUNK = 8  # `_passed` measures the gaps along the way this many shifts at a time
STALL_STEPS, STALL_DROP_M = 8, 0.002  # lowering has stalled when the hand sank less than this in so many steps


@dataclass(frozen=True)
class Destination:
    xy: np.ndarray  # where the held object's body position should come down
    surface_z: float  # top of what it rests on
    instance: str  # the object or fixture that receives it
    relation: str  # "on" or "in"
    # The highest LIBERO's check lets the object's body position end (`On` a region: `lay`).
    max_body_z: float = np.inf


def _instances(world: World) -> list[str]:
    return [inst for inst, _ in world.task.objects + world.task.fixtures]


def resolve(world: World, relation: str, arg: str, held: str, coming: tuple[str, ...] = ()) -> Destination:
    """Where `held` must go for the goal predicate (relation held arg); `coming`: the other objects
    still to go onto the same region after it (`room`)."""
    instances = _instances(world)
    if arg in instances:
        box = world.box(arg)
        return Destination(world.body_pos(arg)[:2], float(box.hi[2]), arg, relation)
    if not world.has_site(arg):
        raise SkillFailed(f"goal names {arg!r}: neither an object nor a region of the scene")
    owner = max((i for i in instances if arg.startswith(i + "_")), key=len, default=arg)
    center = world.site_pos(arg)
    xy = center[:2].copy()
    if relation == "in" and is_drawer(world, arg):
        # Into an open drawer: just behind its front panel, where the drawer is out of the cabinet.
        joint = joint_for(world, arg)
        axis = open_direction(world, joint)
        radius = float(np.max(world.box(held).size[:2])) / 2
        xy = (handle_point(world, joint) - axis * (DRAWER_FRONT_M + radius + 0.015))[:2]
    else:  # beside what is there already: a second can set on the first (a wider deformed one) stays on it
        xy = _shared_spot(world, arg, held, owner, xy, coming)
    surface = support_height(world, xy, exclude=(held,))
    top = world.site_pos(arg)[2] + world.region_half(arg)[2]
    limit = top + lay.LIBERO_ON_HEIGHT_M if relation == "on" else np.inf
    return Destination(xy, surface, owner, relation, limit)


def _shared_spot(
    world: World, region: str, held: str, owner: str, center: np.ndarray, coming: tuple[str, ...]
) -> np.ndarray:
    """`free_spot`, or where others still come or one stands at the centre, `room.spot`."""
    xy = free_spot(world, region, (held, owner), center)
    if not coming and np.array_equal(xy, center):
        return xy
    objects = [o for o, _ in world.task.objects]
    surface = support_height(world, center, exclude=tuple(objects))
    half = world.region_half(region)[:2]
    others = [o for o in objects if o != held and np.all(np.abs(world.box(o).center[:2] - center) < half + 0.1)]
    spot = room.spot(world, region, held, owner, surface, others, bool(coming))
    return xy if spot is None else spot


def free_spot(world: World, region: str, skip: tuple[str, str], center: np.ndarray) -> np.ndarray:
    """The point of a region nearest its centre where the held object does not land on another
    movable object already there (libero_10's second moka pot on the stove). `skip`: the held
    object and the region's owner."""
    radius = float(np.max(world.box(skip[0]).size[:2])) / 2
    others = [world.box(o) for o, _ in world.task.objects if o not in skip]
    half = world.region_half(region)[:2]

    def clearance(p: np.ndarray) -> float:
        gaps = [
            float(np.linalg.norm(np.maximum(np.maximum(b.lo[:2] - p, p - b.hi[:2]), 0.0)))
            for b in others
            if np.all(np.abs(b.center[:2] - center) < half + 0.1)
        ]
        return min(gaps, default=float("inf"))

    if clearance(center) >= radius:
        return center
    steps = np.linspace(-1.0, 1.0, 9)
    grid = [center + half * np.array([u, v]) * 0.8 for u in steps for v in steps]
    fits = [p for p in grid if clearance(p) >= radius]
    if fits:
        return min(fits, key=lambda p: float(np.linalg.norm(p - center)))
    return max(grid, key=clearance)


def support_height(world: World, xy: np.ndarray, exclude: tuple[str, ...] = (), radius: float = 0.02) -> float:
    """Top of the highest collision geom whose world box covers `xy` (the table if none)."""
    boxes = obstacle_boxes(world, exclude)
    under = np.all(boxes[:, 0, :2] - radius <= xy, axis=1) & np.all(xy <= boxes[:, 1, :2] + radius, axis=1)
    return float(boxes[under, 1, 2].max(initial=world.table_z))


def corridor_tops(
    world: World,
    a: np.ndarray,
    b: np.ndarray,
    margin: float,
    exclude: tuple[str, ...],
    own: np.ndarray | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """(points 2 cm apart along the segment a-b (xy), the highest obstacle top whose box comes
    within `margin` of each). With `own` (the boxes of the carried object's pieces, at `a`): not an
    obstacle that stands beside the object, at least AWAY_GAP_M from it, and that the path only
    leads away from (the second bowl on the cabinet beside the one lifted out of its drawer:
    counted, it set the carry higher than the arm reaches over the plate)."""
    ab = b - a
    n = max(2, int(np.linalg.norm(ab) / 0.02) + 1)
    samples = a + np.linspace(0, 1, n)[:, None] * ab
    boxes = obstacle_boxes(world, exclude)
    lo, hi = boxes[:, None, 0, :2], boxes[:, None, 1, :2]  # (N, 1, 2) against (n, 2)
    near = np.all((samples >= lo - margin) & (samples <= hi + margin), axis=2)  # (N, n)
    if own is not None:
        near[_passed(boxes, own, samples - a, near.any(axis=1))] = False
    tops = np.where(near, boxes[:, 1, 2][:, None], world.table_z).max(axis=0, initial=world.table_z)
    return samples, tops


def _passed(boxes: np.ndarray, own: np.ndarray, shifts: np.ndarray, near: np.ndarray) -> np.ndarray:
    """The indices of the boxes among `near` (N,) that stand at least AWAY_GAP_M beside the boxes
    `own` and that the shifted boxes never come nearer in plan (`_plan_gaps` at every shift, to
    within 1e-9). The gaps are measured only for the boxes still in question, GAP_CHUNK shifts at
    a time: each box's gaps are its own sums and comparisons, whichever boxes and shifts are
    measured with it, so the answer is that of every gap measured."""
    rows = np.flatnonzero(near)
    first = _plan_gaps(boxes[rows], own, shifts[:1])[:, 0]
    away = first >= AWAY_GAP_M
    rows, first = rows[away], first[away]
    for k in range(0, len(shifts), GAP_CHUNK):
        if not len(rows):
            break
        kept = np.all(_plan_gaps(boxes[rows], own, shifts[k : k + GAP_CHUNK]) >= first[:, None] - 1e-9, axis=1)
        rows, first = rows[kept], first[kept]
    return rows


def _plan_gaps(boxes: np.ndarray, own: np.ndarray, shifts: np.ndarray) -> np.ndarray:
    """(N, n) distance in plan from each of `boxes` to the nearest of the boxes `own` shifted by
    each of `shifts` (n, 2)."""
    olo = own[None, :, 0, :2] + shifts[:, None]  # (n, M, 2)
    ohi = own[None, :, 1, :2] + shifts[:, None]
    lo, hi = boxes[:, None, None, 0, :2], boxes[:, None, None, 1, :2]  # (N, 1, 1, 2)
    apart = np.maximum(np.maximum(lo - ohi, olo - hi), 0.0)  # (N, n, M, 2)
    return np.linalg.norm(apart, axis=3).min(axis=2)


def carry(
    world: World, held: str, xy: np.ndarray, exclude: tuple[str, ...] = (), orient: np.ndarray | None = None
) -> Actions:
    """Move the held object's body position over `xy`: up high enough to clear the corridor (or
    as high as the arm reaches: far out, stretched, it stalls below the height asked), along it
    past the last obstacle higher than what stands at `xy`, then on over `xy` while coming down to
    clear only that. The hand keeps its orientation, or turns to `orient` (pointing down) as it rises."""
    box = world.box(held)
    hang = world.eef()[2] - box.lo[2]  # grip site height above the object's bottom
    radius = float(np.max(box.size[:2])) / 2
    start = world.body_pos(held)[:2]
    samples, tops = corridor_tops(world, start, xy, radius + 0.02, (held, *exclude), object_boxes(world, held))
    above = CLEAR_M + (SWAY * radius if world.hung else 0.0) + hang
    z = min(max(float(tops.max()) + above, world.eef()[2]), world.table_z + MAX_CARRY_ABOVE_TABLE_M)
    rest = np.maximum.accumulate(tops[::-1])[::-1]  # the highest top from each point on
    low = int(np.argmax(rest <= rest[-1] + 1e-9))  # the first point past everything higher than the end's
    orient = world.eef_mat() if orient is None else orient
    # An elbow past straight brings the wrist no nearer the shoulder than `wrong_way_shortest`: unbent
    # first where the carry ends more than UNBEND_SLACK_M nearer (into libero_10-03's drawer from 0.8 m
    # out, 0.11 m nearer; not onto libero_spatial-04's far plate, at most 2 mm nearer, where the arm,
    # straightened 1.2 m high out of the drawer, bent the wrong way again as the carry set off: 37
    # steps for nothing). Rising where it stands, far out, the wrist would pass the arm's reach: it
    # rises toward the base.
    end = np.array([*(xy + world.eef()[:2] - world.body_pos(held)[:2]), z])
    if reach.past_straight(world) > 0 and reach.stretch(world, end) < reach.wrong_way_shortest(world) - UNBEND_SLACK_M:
        yield from reach.unbend(world, world.hold_grip, world.eef_mat())
    yield from _carry_leg(world, reach.within(world, [*world.eef()[:2], z]), orient, 0.015)
    z = min(z, world.eef()[2] + 0.015)  # stalled below it: carry on at the height reached
    end_z = min(z, float(rest[-1]) + above)
    if end_z < z - CARRY_DESCENT_M:
        if low > 0:
            check_held(world, held, hang)
            way = samples[min(low + 1, len(samples) - 1)]
            offset = world.eef()[:2] - world.body_pos(held)[:2]
            yield from _carry_leg(world, [*(way + offset), z], orient, CARRY_WAY_TOL_M)
        z = end_z
    aimed: np.ndarray | None = None
    for _ in range(3):  # re-aim as the held object swings
        check_held(world, held, hang)
        offset = world.eef()[:2] - world.body_pos(held)[:2]
        goal = np.array([*(xy + offset), z])
        if aimed is not None and np.linalg.norm(goal - aimed) < CARRY_END_TOL_M:
            break  # the last leg stalled short of a goal that has not moved: the same leg would again
        yield from _carry_leg(world, goal, orient, CARRY_END_TOL_M)
        aimed = goal if np.linalg.norm(goal - world.eef()) >= CARRY_END_TOL_M else None
        z = min(z, world.eef()[2] + CARRY_END_TOL_M)
    check_held(world, held, hang)


def _carry_leg(world: World, goal, orient: np.ndarray, tol: float) -> Actions:
    """One move of the held object, ended early when the arm stalls (CARRY_STALL_STEPS)."""
    yield from motion.move_to(
        world,
        goal,
        world.hold_grip,
        orient,
        tol=tol,
        max_steps=120,
        speed=CARRY_SPEED,
        stall_steps=CARRY_STALL_STEPS,
    )


def check_held(world: World, held: str, hang: float) -> None:
    """SkillFailed when the object has slipped out of the fingers: they closed on nothing, or it
    hangs lower than it was taken and no longer between both fingers (a bowl pinched at its rim
    that tilts in them hangs lower too, and is still carried and set down)."""
    if world.finger_gap() < 0.002 or (world.eef()[2] - world.box(held).lo[2] > hang + 0.03 and not world.held(held)):
        raise SkillFailed(f"{held} slipped out of the gripper")


def lower_and_release(world: World, held: str, dest: Destination, above: float = RELEASE_ABOVE_M) -> Actions:
    """Lower until the held object touches something other than the gripper or its bottom is within
    `above` of the surface; open and move up. An object that still hangs on the open hand, touching it and nothing else, is
    set down (`_lower`, the fingers open) and the hand moves FREE_M toward its middle before it
    rises: a deformed bowl pinched at its wall can hold on to the inner finger jammed between its
    hull pieces (libero_spatial-09 multipeak-s3, released 1 cm over the plate's rim: it came up
    with the hand; set down only, it still did as the hand rose)."""
    orient = world.eef_mat()
    yield from _lower(world, held, dest, orient, world.hold_grip, above)
    yield from motion.gripper(world, OPEN, orient=orient)
    if world.touching(held) == {"gripper"}:
        yield from _lower(world, held, dest, orient, OPEN, -np.inf)
        axis = world.finger_axis()
        inward = axis * np.sign(axis[:2] @ (world.body_pos(held) - world.eef())[:2])
        yield from motion.move_to(world, world.eef() + inward * FREE_M, OPEN, orient, tol=0.005, max_steps=20)
    yield from motion.move_to(world, world.eef() + [0, 0, RETREAT_M], OPEN, orient, tol=0.02, max_steps=40)


def _lower(world: World, held: str, dest: Destination, orient: np.ndarray, grip: float, above: float) -> Actions:
    """Lower the hand, the held object's body position over the destination, until the object
    touches something other than the gripper, its bottom is within `above` of the surface, or the
    hand stops sinking."""
    heights: list[float] = []
    for _ in range(160):
        box = world.box(held)
        touching = world.touching(held) - {"gripper"}
        if touching or box.lo[2] - dest.surface_z < above:
            break
        heights.append(float(world.eef()[2]))
        if len(heights) > STALL_STEPS and heights[-STALL_STEPS - 1] - heights[-1] < STALL_DROP_M:
            break  # the hand rests on something (a basket's rim under its palm): let go here
        offset = world.eef()[:2] - world.body_pos(held)[:2]
        goal = np.array([*(dest.xy + offset), world.eef()[2] - 0.03])
        yield motion.action_to(world, goal, grip, orient, speed=0.5)


def pick_place(world: World, held: str, relation: str, dest_arg: str, coming: tuple[str, ...] = ()) -> Actions:
    """Pick `held` and put it (relation) `dest_arg`; first push it clear of a neighbour that stops
    the hand over its pinch (`nudge`). The grasp is planned once: what the nudge tests is the pinch
    the pick then makes (planned anew only after a push moved the object). `coming`: the objects
    still to go onto the same region after this one (`room`)."""
    # Whether it stands too tall is read from the pose it stands in, not the one it hangs in once
    # lifted: libero_goal-02's lying bottle, pinched near its neck, swings in the fingers, its base
    # up to 11 cm over its neck; laid down, 1 of its 7 solved trials was lost. (libero_10's moka
    # pots stand 1.1 cm under the stove's limit: a margin here would lay them down.)
    rise, lying = lay.rise(world, held), lay.lying(world, held)
    grasp = plan_grasp(world, held)
    pushed = yield from nudge.clear_for_pick(world, held, grasp)
    taken, tilt = world.body_mat(held), level.max_tilt(world.box(held).size)
    yield from pick(world, held, planned=None if pushed else grasp)
    dest = resolve(world, relation, dest_arg, held, coming)
    # Onto a slope, also what hangs too tall once lifted: libero_goal-09's lying bottle, pinched off
    # its middle (its neck under the rack, `grasp.along_free`), hangs neck down; let go over the
    # rack's lip, it fell to the table.
    hangs_tall = dest.surface_z + lay.rise(world, held) > dest.max_body_z and lay.sloped(world, dest_arg)
    if dest.surface_z + rise > dest.max_body_z or hangs_tall:
        yield from lay_down(world, held, dest, dest_arg)
        return
    # Into a region narrower than the object as held (a caddy's compartment): turned to fit (`fit`).
    fit = (
        fit_turn(world, held, dest_arg)
        if relation == "in" and world.has_site(dest_arg) and not is_drawer(world, dest_arg)
        else None
    )
    orient = None
    if fit is not None:
        orient, xy = fit
        dest = replace(dest, xy=xy)
    yield from carry(world, held, dest.xy, orient=orient)
    yield from level.upright(world, held, taken, tilt)
    # What lies on its side is set down before it is let go: libero_10-06's lying mug, pinched 6 cm
    # off its middle and let go 1.2 cm over the plate's rim, rolled off the plate (6 of 10 trials).
    yield from lower_and_release(world, held, dest, above=-np.inf if lying else RELEASE_ABOVE_M)


def lay_down(world: World, held: str, dest: Destination, region: str) -> Actions:
    """Carry the held object to `dest` (on `region`) and lay it on its side there (`lay`): carried
    with the fingers across the direction it will lie along, tipped forward over the destination,
    its extent centred at the region's spot for it (`lay.spot`), lowered and let go."""
    xy, along = lay.spot(world, region, dest.xy)
    down, tipped = lay.orientations(world, along)
    if dest.surface_z + lay.laid_rise(world, held, tipped) > dest.max_body_z and not lay.sloped(world, region):
        # Held off its middle (a moka pot by its handle), tipped toward the grip: the object then
        # hangs under the grip, not over it (libero_10-08's inverted pot, tipped out along the line
        # from the base, was too tall still: 10 of 10 trials failed).
        along = lay.toward_grip(world, held)
        down, tipped = lay.orientations(world, along)
    if dest.surface_z + lay.laid_rise(world, held, tipped) > dest.max_body_z:
        raise SkillFailed(f"{held} stands too tall for {dest.instance} even laid on its side")
    yield from carry(world, held, lay.carry_target(world, held, xy, down, tipped), orient=down)
    yield from lay.clear_tip(world, held, tipped, dest.surface_z)
    yield from lay.tip(world, tipped)
    yield from lay.centre_over(world, held, xy)
    here = Destination(world.body_pos(held)[:2], dest.surface_z, dest.instance, dest.relation, dest.max_body_z)
    yield from lower_and_release(world, held, here)
