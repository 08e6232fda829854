"""Frozen initial states of a scene case: sampled with the case's seeds, settled, accepted.

Trial k of a scene case starts from LIBERO's initial state k of the base task (so it differs from
the Normal trial k only by the variation), carried into the variant's model by joint name. Where
LIBERO's own state k is unsound (an object falls off the table in one second of zero actions:
libero_10-00 row 2 under MuJoCo 3.8.1; none under the pinned 3.3.7), the next sound row after the
first 10 is used instead and meta.json lists the rows (`BaseScene.trial_rows`). The
generator's placements and joint settings are then applied with the random stream
`seeding.rng(case_id, k, "scene-init-<attempt>")` (a joint value is drawn again while its part cuts
into the rest of its own fixture), every moved object is lowered onto its support,
and the scene is settled for one second of zero actions (up to EXTRA_SETTLE more while an object
still moves, e.g. a deformed target rocking on an uneven base). The state is accepted only if
- every movable object rests (speed below 2 cm/s and 0.5 rad/s),
- no two scene bodies interpenetrate deeper than 5 mm,
- no object's lowest point ends more than 5 cm below the surface most objects stand on (it
  left the table),
- the task's goal is not already satisfied, and
- one more second of zero actions from the stored state moves no object more than 1 cm (the
  check `vpro validate` repeats), and
- an object the variant keeps clear of a set part's travel (`scene.travel`: moved, where the
  travel from the part's closed end passes through it, to a clear spot of its own LIBERO region)
  was not moved more than 5 mm or tilted more than 5 degrees by the settling, and touches no set
  part's fixture, and
- every part the variant's joints set moves when pushed gently toward the middle of its range
  (`start_checks.jammed_parts`: a drawer drawn a few millimetres into LIBERO's closed range can run under its
  cabinet's base plate, where MuJoCo holds the overlap with kilonewtons: libero_10-03's bottom
  drawer, which no policy could then open), and
- every object the variant places comes up under a gentle pull (`start_checks.stuck_objects`: a deformed bowl
  dropped from LIBERO's height through libero_spatial-07's stove's 1 mm top plate rested locked
  under it), and
- no object turned upside down came down over an object within its footprint (`start_checks.enclosing`:
  libero_spatial-05's bowl over the ramekin it stood on); the next attempts stand it beside it.
A rejected draw is redrawn (next attempt) up to MAX_ATTEMPTS times; then InitStateError names the
case, the trial and the reasons. An object that keeps its LIBERO place first keeps LIBERO's height;
from the second attempt on it is lowered onto whatever is below it instead: LIBERO's rows hold some
objects centimetres above the table, and a deformed target dropped from there can bounce off its
support (MuJoCo 3.2.3's convex collision of thin hull pieces: libero_spatial-01's taper-s2 bowl);
and an object that a part set by the variant's joints cuts into (a door set half open swinging
through the mug in front of it) is slid out of that part.
"""

from __future__ import annotations

import contextlib
import dataclasses
import logging
import math

import mujoco
import numpy as np

from vpro_assets.core import seeding
from vpro_assets.core.errors import VProError
from vpro_assets.core.mjgeom import quat_mul, subtree
from vpro_assets.scene import sim, start_checks, travel
from vpro_assets.scene.pose import INVERT, class_quat
from vpro_assets.scene.variant import JointSetting, Placement, SceneVariant

log = logging.getLogger(__name__)

MAX_ATTEMPTS = 6
EXTRA_SETTLE = 3  # seconds of further settling for objects still moving after the first
CUT_TOL_M = 0.0001  # a part may touch its fixture; deeper than this it cuts into it
MAX_DRAWS = 200  # position draws per placement and attempt
SUPPORT_GAP = 0.002  # m: a lowered object starts this far above its support
# Room between an object's footprint and the ground a part the policy opens covers, for the hand
# to come down to it from above: the Panda's palm reaches 10.5 cm to each side of its grip site
# along its closing axis (`oracle.hand.HAND_PARTS`), so gripping an upside-down bowl (10.7 cm
# across) at its foot it ends 5 cm outside the footprint, whichever way the hand is turned; the
# wrist, 4.4 cm to each side across, stays within it. libero_goal-03's upside-down bowl, its
# footprint 3 cm under the opened top drawer and its foot 2.4 cm beside the drawer front, could
# not be picked with the drawer open (the wrist hit the cabinet).
HAND_ROOM_M = 0.05
SPOT_REACH_M = 0.25  # how far from its place such an object may start (`_nearest_spot`)
SPOT_DRAWS = 400  # spots drawn there (libero_goal-03: about 6% of the disc is clear)


class InitStateError(VProError):
    """No acceptable initial state for a trial of a case."""


def _support_height(layout: dict) -> float:
    """Height of the surface the scene's objects stand on: the median of their lowest points."""
    lows = [v["lo"][2] for v in layout.values() if v["kind"] == "object"]
    return float(np.median(lows))


def _clear(xy: np.ndarray, radius: float, others: list[tuple[np.ndarray, np.ndarray]], margin: float) -> bool:
    for lo, hi in others:
        dx = max(lo[0] - xy[0], 0.0, xy[0] - hi[0])
        dy = max(lo[1] - xy[1], 0.0, xy[1] - hi[1])
        if math.hypot(dx, dy) < radius + margin:
            return False
    return True


def _ring_spot(
    p,
    anchor: np.ndarray,
    rng: np.random.Generator,
    offset: np.ndarray,
    radius: float,
    others: list[tuple[np.ndarray, np.ndarray]],
) -> np.ndarray:
    """An origin xy on a ring around `anchor` whose footprint centre (origin + `offset`: the
    origin need not be the centre) is clear of `others`. The ring widens by 1 cm every 20 draws
    when the trial's own layout crowds the spot."""
    for draw in range(MAX_DRAWS):
        r = rng.uniform(p.r_min, p.r_max + 0.01 * (draw // 20))
        theta = rng.uniform(0, 2 * math.pi)
        xy = anchor + r * np.array([math.cos(theta), math.sin(theta)])
        if _clear(xy + offset, radius, others, p.margin):
            return xy
    raise InitStateError(
        f"no free spot for {p.instance} within {p.r_max + 0.01 * (MAX_DRAWS // 20):.2f} m of "
        f"({anchor[0]:.3f}, {anchor[1]:.3f})"
    )


def _nearest_spot(
    p: Placement,
    anchor: np.ndarray,
    rng: np.random.Generator,
    offset: np.ndarray,
    radius: float,
    others: list[tuple[np.ndarray, np.ndarray]],
) -> np.ndarray:
    """Of SPOT_DRAWS origins drawn uniformly in the disc of radius SPOT_REACH_M around `anchor`,
    the nearest to it whose footprint is clear of `others` (a ring widening from the anchor finds
    none within 11 cm in libero_goal-03's crowded layout; the nearest clear spot is 19 cm away)."""
    r = SPOT_REACH_M * np.sqrt(rng.uniform(0.0, 1.0, SPOT_DRAWS))
    theta = rng.uniform(0.0, 2 * math.pi, SPOT_DRAWS)
    spots = anchor + np.stack([r * np.cos(theta), r * np.sin(theta)], axis=1)
    clear = [i for i in np.argsort(r) if _clear(spots[i] + offset, radius, others, p.margin)]
    if not clear:
        raise InitStateError(
            f"no spot for {p.instance} within {SPOT_REACH_M:.2f} m of ({anchor[0]:.3f}, {anchor[1]:.3f}) is clear "
            f"of its neighbours and of the ground a part the task opens covers ({SPOT_DRAWS} drawn)"
        )
    return spots[clear[0]]


def _place(
    env,
    variant: SceneVariant,
    rng: np.random.Generator,
    added: set[str],
    base_layout: dict,
    onto_support: bool = False,
    beside_covered: bool = False,
    lower_taken: bool = False,
) -> None:
    """Apply the variant's placements to the loaded state (positions, poses, heights). An object
    that keeps its LIBERO place (a turned or replaced target) keeps its lowest point where LIBERO's
    object had it (on the table, in a drawer), or with `onto_support` rests on what is below it;
    a moved or added one goes onto the table surface. `beside_covered`: an inverted object that
    came down over what it stood on (`start_checks.enclosing`) stands beside it instead; `lower_taken`: one that
    takes another's place rests on what is below it (`start_checks.stuck_objects`: libero_spatial-07's ramekin in
    the bowl's place on the stove, dropped from the bowl's height, fell through the stove's top plate)."""
    data = sim.raw(env).sim.data
    raw = sim.raw(env)
    layout = sim.body_layout(env)
    support = _support_height({k: v for k, v in layout.items() if k not in added})
    pending = {p.instance for p in variant.placements}
    for p in variant.placements:
        obj = raw.objects_dict[p.instance]
        joint = obj.joints[-1]
        qpos = np.array(data.get_joint_qpos(joint))
        if p.instance in added:
            qpos[3:] = class_quat(obj, rng)
        if p.invert:
            qpos[3:] = quat_mul(INVERT, qpos[3:])
        if p.turn is not None:
            qpos[3:] = quat_mul(np.asarray(p.turn, dtype=float), qpos[3:])
        data.set_joint_qpos(joint, qpos)
        raw.sim.forward()
        now = sim.body_layout(env)
        own = now[p.instance]
        # Half its longer side plus 10%, as the spot planning measures it (PoolObject.footprint_radius).
        radius = 0.55 * max(own["hi"][0] - own["lo"][0], own["hi"][1] - own["lo"][1])
        centre = (own["lo"][:2] + own["hi"][:2]) / 2
        offset = centre - qpos[:2]  # the object's origin need not be its footprint's centre
        others = {k: v for k, v in now.items() if k != p.instance and k not in pending}
        if p.keep_xy:
            opened = [box for joint, to in p.clear_of_opened for box in travel.opened_sweep(env, joint, to)]
            xy = _kept_spot(p, qpos[:2].copy(), rng, own, offset, radius, others, base_layout, beside_covered, opened)
        elif p.take_place_of:
            was = base_layout[p.take_place_of]
            xy = (was["lo"][:2] + was["hi"][:2]) / 2 - offset  # footprint centre on the other's
        else:
            xy = _ring_spot(
                p, np.asarray(p.anchor, dtype=float), rng, offset, radius, [(v["lo"], v["hi"]) for v in others.values()]
            )
        qpos[:2] = xy
        data.set_joint_qpos(joint, qpos)
        raw.sim.forward()
        lo = sim.body_layout(env)[p.instance]["lo"][2]
        if p.take_place_of:
            floor = float(base_layout[p.take_place_of]["lo"][2])
            if lower_taken:  # from the other's height down onto what is below it there
                qpos[2] += floor - lo
                data.set_joint_qpos(joint, qpos)
                raw.sim.forward()
                lo, floor = floor, _top_below(env, p.instance, floor)
        elif p.keep_xy and p.instance in base_layout:
            floor = float(base_layout[p.instance]["lo"][2])
            if onto_support:
                floor = _top_below(env, p.instance, lo)
        else:
            floor = support
        qpos[2] += floor + SUPPORT_GAP - lo
        data.set_joint_qpos(joint, qpos)
        data.set_joint_qvel(joint, np.zeros(6))
        raw.sim.forward()
        pending.discard(p.instance)


def _clear_of_set_parts(env, variant: SceneVariant, margin: float = 0.003, rounds: int = 40) -> None:
    """Slide every movable object that a part moved by the variant's joint settings now cuts into
    (a microwave door set half open swings through the mug LIBERO placed in front of it) out of
    that part, horizontally along the contact normal, until no such contact is left."""
    if not variant.joints:
        return
    raw = sim.raw(env)
    m, d = raw.sim.model._model, raw.sim.data._data
    parts: set[int] = set()
    for js in variant.joints:
        root = int(m.jnt_bodyid[raw.sim.model.joint_name2id(js.joint)])
        parts |= set(subtree(m, root))
    objects = {
        int(m.body_rootid[raw.sim.model.body_name2id(obj.root_body)]): obj.joints[-1]
        for obj in raw.objects_dict.values()
        if obj.joints
    }
    for _ in range(rounds):
        # Per object: away from its contacts with the part, towards its own centre (a thin door panel
        # cutting through a mug has contacts with normals both ways; the centre says which side it is on).
        away: dict[int, list[np.ndarray]] = {}
        depth: dict[int, float] = {}
        for i in range(d.ncon):
            c = d.contact[i]
            b1, b2 = int(m.geom_bodyid[c.geom1]), int(m.geom_bodyid[c.geom2])
            other = b2 if b1 in parts else b1 if b2 in parts else -1
            root = int(m.body_rootid[other]) if other >= 0 else -1
            if root not in objects or c.dist >= 0:
                continue
            way = (d.xipos[root] - c.pos)[:2]
            if np.linalg.norm(way) > 1e-6:
                away.setdefault(root, []).append(way / np.linalg.norm(way))
                depth[root] = max(depth.get(root, 0.0), -float(c.dist))
        if not away:
            return
        for root, ways in away.items():
            way = np.mean(ways, axis=0)
            qpos = np.array(raw.sim.data.get_joint_qpos(objects[root]))
            qpos[:2] += way / max(np.linalg.norm(way), 1e-9) * (depth[root] + margin)
            raw.sim.data.set_joint_qpos(objects[root], qpos)
        raw.sim.forward()


def _draw_joint(env, js: JointSetting, rng: np.random.Generator) -> None:
    """Set a part's joint to a value drawn from [low, high], drawn again while the part cuts into
    the rest of its own fixture: LIBERO's closed range of its cabinets reaches 5 mm in, and from
    2 mm on the white cabinet's drawer fronts run into its base and top plates, where MuJoCo holds
    them with kilonewtons (libero_10-03's bottom drawer: no gripper could open it). The first draw
    is the stream's first number, as before, so a part that is free keeps its value."""
    raw = sim.raw(env)
    model, data = raw.sim.model._model, raw.sim.data._data
    part = int(model.jnt_bodyid[raw.sim.model.joint_name2id(js.joint)])
    moving = set(subtree(model, part))
    fixture = int(model.body_rootid[part])
    for _ in range(MAX_DRAWS):
        raw.sim.data.set_joint_qpos(js.joint, rng.uniform(js.low, js.high))
        mujoco.mj_forward(model, data)
        if not any(_cuts(model, data.contact[i], moving, fixture) for i in range(data.ncon)):
            return
    raise InitStateError(
        f"{js.joint} cuts into its own fixture at each of {MAX_DRAWS} values drawn from [{js.low}, {js.high}]"
    )


def _cuts(model, contact, moving: set[int], fixture: int) -> bool:
    """Whether a contact is a part (`moving` bodies) cutting into the rest of its fixture."""
    if contact.dist >= -CUT_TOL_M:
        return False
    b1, b2 = int(model.geom_bodyid[contact.geom1]), int(model.geom_bodyid[contact.geom2])
    for inside, other in ((b1, b2), (b2, b1)):
        if inside in moving and other not in moving and int(model.body_rootid[other]) == fixture:
            return True
    return False


def _top_below(env, instance: str, lo: float) -> float:
    """Height of the highest surface under `instance`'s footprint (rays cast down from its lowest
    point at the footprint's centre and 4 points halfway to its corners, the object excluded)."""
    raw = sim.raw(env)
    model, data = raw.sim.model._model, raw.sim.data._data
    own = sim.body_layout(env)[instance]
    body = raw.sim.model.body_name2id(raw.objects_dict[instance].root_body)
    centre, half = (own["lo"][:2] + own["hi"][:2]) / 2, (own["hi"][:2] - own["lo"][:2]) / 2
    geom = np.array([-1], dtype=np.int32)
    tops = []
    for dx, dy in ((0, 0), (0.5, 0.5), (0.5, -0.5), (-0.5, 0.5), (-0.5, -0.5)):
        start = np.array([centre[0] + dx * half[0], centre[1] + dy * half[1], lo - 1e-4])
        # flg_static 1, bodyexclude: the object itself (its own lower hull pieces).
        dist = mujoco.mj_ray(model, data, start, np.array([0.0, 0.0, -1.0]), None, 1, body, geom)
        if dist >= 0:
            tops.append(start[2] - dist)
    return max(tops) if tops else lo


def _kept_spot(
    p: Placement,
    xy: np.ndarray,
    rng: np.random.Generator,
    own: dict,
    offset: np.ndarray,
    radius: float,
    others: dict[str, dict],
    base_layout: dict,
    beside_covered: bool = False,
    opened: list[tuple[np.ndarray, np.ndarray]] | None = None,
) -> np.ndarray:
    """LIBERO's xy of the trial for an object that keeps its place, or (`clear_of_neighbours`)
    a clear spot nearby where it would touch a neighbour there (with `beside_covered`, the object
    it stands on and covers upside down counts as one). `opened`: the ground parts the policy
    opens cover (`Placement.clear_of_opened`); a footprint closer to it than HAND_ROOM_M moves to
    the nearest spot clear of it and of the neighbours (`_nearest_spot`); where there is none the
    attempt fails."""
    opened = opened or []
    # What the ring must also keep clear of: the opened ground, grown so that _clear's margin
    # (p.margin) comes to HAND_ROOM_M from it.
    grow = HAND_ROOM_M - p.margin
    sweep = [(lo - grow, hi + grow) for lo, hi in opened]
    centre = (own["lo"][:2] + own["hi"][:2]) / 2
    under_opened = not _clear(centre, radius, sweep, p.margin)
    if not (p.clear_of_neighbours and p.instance in base_layout):
        return xy
    # What it stands on (a drawer, a rack, a cookie box) does not count: it stays there.
    floor = base_layout[p.instance]["lo"][2] + start_checks.SUPPORT_TOL
    covered = [
        v
        for v in others.values()
        if beside_covered and p.invert and v["kind"] == "object" and start_checks.within_footprint(v, own)
    ]
    neighbours = [
        (v["lo"], v["hi"])
        for v in others.values()
        if v["hi"][2] > floor and (v["kind"] == "object" or _clear(centre, 0.0, [(v["lo"], v["hi"])], 0.0))
    ] + [(v["lo"], v["hi"]) for v in covered]
    if covered:  # the ring starts where the footprint clears what it would cover
        reach = max(float(np.max(v["hi"][:2] - v["lo"][:2])) for v in covered) / 2 + radius + p.margin
        p = dataclasses.replace(p, r_min=reach, r_max=reach + p.r_max)
    if under_opened:  # out from under it, or no start: the task could not be done from there
        # Farther away, every object and fixture counts but what it stands on (whose box holds its
        # footprint's centre): the low ones too (an upside-down bowl came down over the cream cheese).
        around = [(v["lo"], v["hi"]) for v in others.values() if _clear(centre, 0.0, [(v["lo"], v["hi"])], 0.0)]
        return _nearest_spot(p, xy, rng, offset, radius, around + sweep)
    if not _clear(centre, radius, neighbours, p.margin):
        # No room nearby in a crowded layout: LIBERO's spot, if it settles.
        with contextlib.suppress(InitStateError):
            xy = _ring_spot(p, xy, rng, offset, radius, neighbours)
    return xy


def trial_state(
    env,
    variant: SceneVariant,
    base_row: np.ndarray,
    base_slots: dict,
    trial: int,
    base_layout: dict | None = None,
    fixture_seed: int = 0,
) -> np.ndarray:
    """One accepted, settled initial state (a LIBERO state row) for `trial` of the case.
    `base_layout`: instance -> {lo, hi} of its geometry in LIBERO's state of this trial;
    `fixture_seed`: the trial's seed, which places the fixtures as the rollout will."""
    added = set(variant.added)
    reasons: list[str] = []
    beside_covered = lower_taken = False  # what earlier attempts of the trial found (`_place`)
    for attempt in range(MAX_ATTEMPTS):
        rng = seeding.rng(variant.case_id, trial, f"scene-init-{attempt}")
        sim.place_fixtures(env, fixture_seed)
        row = sim.map_state(base_row, base_slots, env)
        sim.load_state(env, row)
        raw = sim.raw(env)
        try:
            for js in variant.joints:
                _draw_joint(env, js, rng)
            raw.sim.forward()
            _place(
                env,
                variant,
                rng,
                added,
                base_layout or {},
                onto_support=attempt > 0,
                beside_covered=beside_covered,
                lower_taken=lower_taken,
            )
            # Its own stream, so the draws of the variants without it stay as they were.
            travel.keep_clear_of_travel(env, variant, seeding.rng(variant.case_id, trial, f"scene-travel-{attempt}"))
        except (InitStateError, travel.NoClearSpot) as exc:
            reasons.append(f"attempt {attempt}: {exc}")
            continue
        if attempt > 0:
            _clear_of_set_parts(env, variant)
        placed = travel.poses(env, variant)
        sim.settle(env)
        # An object still rocking (a deformed target on an uneven base) gets up to EXTRA_SETTLE more
        # seconds; a state at rest after the first second is never stepped further.
        for _ in range(EXTRA_SETTLE):
            if not sim.moving_objects(env):
                break
            sim.settle(env)
        enclosing = start_checks.enclosing(env, variant)
        beside_covered = beside_covered or bool(enclosing)
        problems = (
            start_checks.settle_problems(env, bool(raw._check_success()))
            + travel.disturbed(env, variant, placed)
            + enclosing
        )
        if not problems:
            state = sim.flattened_state(env)
            sim.load_state(env, state)
            problems = [f"after storing: {p}" for p in start_checks.drift(env)]
            if not problems:
                problems = start_checks.jammed_parts(env, variant, state)
            if not problems:
                problems = start_checks.stuck_objects(env, [p.instance for p in variant.placements], state)
                lower_taken = lower_taken or bool(problems)
            if not problems:
                return state
        reasons.append(f"attempt {attempt}: " + "; ".join(problems[:4]))
    raise InitStateError(
        f"case {variant.case_id}: trial {trial} has no initial state that settles after "
        f"{MAX_ATTEMPTS} attempts ({' | '.join(reasons[-3:])})"
    )
