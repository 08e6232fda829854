"""The oracle's and the episode runner's shortcuts give exactly what the plain computation gives.

The certificate replays trials to their recorded final-state fingerprints, so a shortcut that
changed one comparison would change an action and, some steps later, a fingerprint: each is held
here to the computation it replaces (on random boxes, or on a real scene), bit for bit.
"""

from __future__ import annotations

from dataclasses import replace
from types import SimpleNamespace

import numpy as np
from conftest import catalog_case

from vpro_assets.core.mjgeom import geom_pieces, world_aabb
from vpro_assets.perturb.entities import EntityIndex
from vpro_assets.perturb.occluders import GeomHulls
from vpro_assets.perturb.phases import PhaseTracker
from vpro_assets.rollout.contacts import ContactTracker
from vpro_assets.rollout.episode import EpisodeSession, EpisodeSettings
from vpro_assets.rollout.policies.oracle import clearance, nudge, pick_place, push
from vpro_assets.rollout.policies.oracle.clearance import PIECE_M, obstacle_boxes
from vpro_assets.rollout.policies.oracle.grasp import hand_stop, narrow_top, plan_grasp
from vpro_assets.rollout.policies.oracle.pick import pick
from vpro_assets.rollout.policies.oracle.policy import OraclePolicy


class _IsinPhaseTracker(PhaseTracker):
    """The phase tracker as it was: the entities' geoms as id arrays, np.isin at every test."""

    def _geom_masks(self):
        ent, ids = self.entities, (lambda geoms: np.asarray(geoms, np.int32))
        obj = ids(ent.interaction.geoms)
        receptacle = ids(ent.receptacle.geoms if ent.receptacle is not None else [])
        left, right = ids(ent.left_finger_geoms), ids(ent.right_finger_geoms)
        return SimpleNamespace(
            obj_geoms=obj, obj=obj, gripper=ids(ent.gripper.geoms), left=left, right=right, receptacle=receptacle
        )

    @staticmethod
    def _touch(g1, g2, a, b) -> bool:
        if len(a) == 0 or len(b) == 0 or len(g1) == 0:
            return False
        return bool(np.any((np.isin(g1, a) & np.isin(g2, b)) | (np.isin(g1, b) & np.isin(g2, a))))


def _contacts_update_plain(tracker: ContactTracker, step: int) -> None:
    """`ContactTracker.update` as it was: contact by contact, every step."""
    data = tracker.sim.data
    for i in range(int(data.ncon)):
        a, b = int(data.contact[i].geom1), int(data.contact[i].geom2)
        other = b if a in tracker.gripper else a if b in tracker.gripper else None
        if other is None:
            continue
        if tracker.first_target is None and other in tracker.target:
            tracker.first_target = step
        if tracker.first_distractor is None and other in tracker.distractor:
            tracker.first_distractor = step


def test_the_runners_trackers_on_an_oracle_episode_agree_with_their_plain_forms():
    """The episode runner's phase tracker and contact tracker test contacts through boolean masks
    over the model's geoms (the contact tracker stops once it knows both first steps): on libero_10-00's
    whole oracle episode, not observed (as `vpro certify` runs it), with the second can counted as a
    distractor, the phase history, onsets and first contacts of the plain forms, step for step."""
    case = catalog_case("libero_10-00/normal")
    session = EpisodeSession(case, 0, EpisodeSettings(render=False), observe=False)
    policy = OraclePolicy()
    policy.reset(session.episode_info())
    plain: list[_IsinPhaseTracker] = []

    def on_reset(cenv) -> None:  # right after the reset's own tracker update: both trackers from here on
        policy.bind_env(cenv)
        plain.append(_IsinPhaseTracker(EntityIndex(cenv.sim, cenv.task)))
        plain[0].reset()
        plain[0].update(cenv.sim)
        tracker = cenv.tracker
        cenv.tracker = SimpleNamespace(update=lambda sim: (plain[0].update(sim), tracker.update(sim)), tracker=tracker)

    try:
        session.start(on_reset=on_reset)
        cenv = session.env
        pair = [ContactTracker(cenv.sim, "alphabet_soup_1", ["tomato_sauce_1"]) for _ in range(2)]
        while not session.finished:
            session.step(policy.next_action())
            pair[0].update(session.t)
            _contacts_update_plain(pair[1], session.t)
            assert (pair[0].first_target, pair[0].first_distractor) == (pair[1].first_target, pair[1].first_distractor)
        assert session.success
        tracker = cenv.tracker.tracker
        assert len(tracker.history) == session.t + 1 and tracker.history == plain[0].history
        assert tracker.timeline() == plain[0].timeline() and tracker.grasp_onset is not None
        assert pair[0].composition == "both" and pair[0].summary() == pair[1].summary()
    finally:
        session.close()


def _boxes(rng: np.random.Generator, n: int, spread: float) -> np.ndarray:
    lo = rng.uniform(-spread, spread, (n, 3))
    return np.stack([lo, lo + rng.uniform(0.001, 0.05, (n, 3))], axis=1)


def _overlap_xy_plain(boxes, own, margin):
    lo, hi = own[None, :, 0, :2] - margin, own[None, :, 1, :2] + margin
    return np.any(np.all(boxes[:, None, 0, :2] < hi, axis=2) & np.all(boxes[:, None, 1, :2] > lo, axis=2), axis=1)


def _meets_plain(boxes, own):
    lo, hi = own[None, :, 0] - nudge.PATH_MARGIN_M, own[None, :, 1] + nudge.PATH_MARGIN_M
    lo[..., 2], hi[..., 2] = own[None, :, 0, 2] + 0.005, own[None, :, 1, 2]
    return bool(np.any(np.all(boxes[:, None, 0] < hi, axis=2) & np.all(boxes[:, None, 1] > lo, axis=2)))


def test_box_overlaps_prefiltered_by_the_footprint_equal_the_pairwise_test():
    """`clearance._overlap_xy` and `nudge._meets` compare the pairs only for boxes reaching the box
    around the object's: the same answers as every pair compared, near, touching and far."""
    rng = np.random.default_rng(0)
    met = 0
    for trial in range(300):
        boxes = _boxes(rng, int(rng.integers(0, 60)), 0.3)
        own = _boxes(rng, int(rng.integers(1, 12)), 0.05 + 0.1 * (trial % 3))
        if trial % 5 == 0 and len(boxes):  # a box exactly at the margin of an object's box
            boxes[0, 0, :2] = own[0, 1, :2] + clearance.MARGIN_M
        margin = (clearance.MARGIN_M, clearance.BESIDE_M)[trial % 2]
        expected = _overlap_xy_plain(boxes, own, margin)
        np.testing.assert_array_equal(clearance._overlap_xy(boxes, own, margin), expected)
        met += _meets_plain(boxes, own)
        assert nudge._meets(boxes, own) == _meets_plain(boxes, own)
    assert 30 < met < 270  # both answers were tested
    assert not clearance._overlap_xy(_boxes(rng, 4, 0.1), np.zeros((0, 2, 3))).any()
    assert not nudge._meets(_boxes(rng, 4, 0.1), np.zeros((0, 2, 3)))


def _measured(w, obj: str) -> tuple:
    """An object's box, hulls and pieces as `core.mjgeom` and `GeomHulls` measure them now."""
    geoms = w.geoms(obj)
    return (
        world_aabb(w.m, w.d, geoms),
        GeomHulls().world(w.m, w.d, geoms),
        [geom_pieces(w.m, w.d, g, PIECE_M) for g in geoms],
    )


def _kept(w, obj: str) -> tuple:
    box = w.box(obj)
    return (box.lo, box.hi), w.hulls(obj), [w.pieces(g, PIECE_M) for g in w.geoms(obj)]


def _assert_equal(a, b) -> None:
    for x, y in zip(a, b, strict=True):
        if isinstance(x, np.ndarray):
            np.testing.assert_array_equal(x, y)
        else:
            _assert_equal(x, y)


def test_what_the_world_keeps_of_a_geom_is_what_is_measured_where_it_stands(scene):
    """`World` keeps each geom's pieces, hull and box corners while it stays put: an object's box,
    hulls and pieces are the same numbers as measured afresh, before and after it was lifted (when
    they are measured again); the kept arrays are read-only; the obstacles' geoms are the model's,
    found once."""
    s = scene("libero_goal-08/normal")
    w, bowl = s.world, "akita_black_bowl_1"
    before = _kept(w, bowl)
    _assert_equal(before, _measured(w, bowl))
    _assert_equal(_kept(w, bowl), before)
    assert w.hulls(bowl)[0] is before[1][0] and not before[1][0].flags.writeable
    assert w.pieces(w.geoms(bowl)[0], PIECE_M) is before[2][0] and not before[2][0].flags.writeable
    assert w.obstacle_geoms((bowl,)) == w._find_obstacle_geoms((bowl,))
    s.run(pick(w, bowl), limit=200)
    after = _kept(w, bowl)
    _assert_equal(after, _measured(w, bowl))
    assert not np.array_equal(after[2][0], before[2][0])  # the bowl was lifted: measured again
    _assert_equal(_kept(w, "plate_1"), _measured(w, "plate_1"))


def test_a_push_sweep_of_all_path_points_at_once_meets_what_one_at_a_time_met():
    """`push._sweep` (the boxes a hand part's points meet along a push path) for the whole path at
    once: the same set as the box of the points at each point of the path in turn."""
    rng = np.random.default_rng(1)
    for _ in range(200):
        boxes = _boxes(rng, int(rng.integers(0, 80)), 0.4)
        local = rng.uniform(-0.05, 0.05, (int(rng.integers(1, 9)), 3))
        path = np.linspace(rng.uniform(-0.3, 0.3, 3), rng.uniform(-0.3, 0.3, 3), 10)
        plain: set[int] = set()
        for p in path:
            lo, hi = (p + local).min(0), (p + local).max(0)
            plain |= set(np.flatnonzero(np.all(boxes[:, 0] < hi, axis=1) & np.all(boxes[:, 1] > lo, axis=1)).tolist())
        assert push._sweep(boxes, local, path) == plain


def _hand_meets_plain(world, instance, boxes, hand, orient, direction, dist, behind):
    """`nudge._hand_meets` part by part and pose by pose, as it was written first."""
    xy = world.body_pos(instance)[:2] - direction[:2] * push.back_reach(world, instance, direction[:2], -behind)
    start = np.array([*xy, world.box(instance).lo[2] + push.CONTACT_Z_M])
    near = boxes[np.all(np.abs((boxes[:, 0, :2] + boxes[:, 1, :2]) / 2 - xy) < nudge.NEAR_M, axis=1)]
    if not len(near):
        return False
    corners = np.stack(np.meshgrid([0, 1], [0, 1], [0, 1], indexing="ij"), -1).reshape(-1, 3)
    obstacle = near[:, 0][:, None] + corners[None] * (near[:, 1] - near[:, 0])[:, None]
    down = [start + [0.0, 0.0, h] for h in np.linspace(0.0, nudge.HOVER_M, 6)]
    along = [start + direction * s for s in np.linspace(0.0, dist, max(2, int(dist / nudge.STEP_M) + 1))]
    for pose in down + along:
        local = (obstacle.reshape(-1, 3) - pose) @ orient
        for part in hand:
            lo, hi = part.min(0), part.max(0)
            if np.any(np.all((local > lo) & (local < hi), axis=1)):
                return True
            world_pts = pose + (lo + corners * (hi - lo)) @ orient.T
            if np.any(
                np.all((world_pts[:, None] > near[None, :, 0]) & (world_pts[:, None] < near[None, :, 1]), axis=2)
            ):
                return True
    return False


def test_the_pushing_hand_meets_what_it_met_part_by_part(scene):
    """`nudge._hand_meets` tests every part of the hand at a pose at once: on libero_10-01's crowded
    cream cheese, for 16 directions, three distances and a few yaws, the answer part by part."""
    s = scene("libero_10-01/normal")
    w, obj = s.world, "cream_cheese_1"
    boxes, hand = obstacle_boxes(w, (obj,)), nudge.closed_hand(w)
    answers = []
    for a in np.linspace(0, 2 * np.pi, 16, endpoint=False):
        d = np.array([np.cos(a), np.sin(a), 0.0])
        for dist, behind, yaw in ((0.02, 0.02, 0.0), (0.06, 0.01, 45.0), (0.11, 0.02, -90.0)):
            orient = nudge.grasp_orientation(w, nudge._turn(d, yaw))
            got = nudge._hand_meets(w, obj, boxes, hand, orient, d, dist, behind)
            assert got == _hand_meets_plain(w, obj, boxes, hand, orient, d, dist, behind)
            answers.append(got)
    assert 0 < sum(answers) < len(answers)  # both answers were tested


def _clearing_shift_plain(world, instance, part):
    """`nudge.clearing_shift` with every candidate push made before any is tried, as first written."""
    pts, z = part
    top = float(world.points(instance)[:, 2].max())
    boxes, own = obstacle_boxes(world, (instance,)), clearance.object_boxes(world, instance)
    hand = nudge.closed_hand(world)
    dirs = [np.array([np.cos(a), np.sin(a), 0.0]) for a in np.linspace(0, 2 * np.pi, nudge.DIRECTIONS, endpoint=False)]
    candidates = []
    for dist in np.arange(nudge.STEP_M, nudge.MAX_M + 1e-9, nudge.STEP_M):
        for d in dirs:
            if nudge._too_high(hand_stop(boxes, pts + d * dist, z), z, top):
                continue
            path = [d * s for s in np.arange(nudge.STEP_M, dist + nudge.MARGIN_M + 1e-9, nudge.STEP_M)]
            if not any(nudge._meets(boxes, own + p) for p in path) and nudge._on_support(boxes, own, own + path[-1]):
                candidates.append((d, float(dist + nudge.MARGIN_M)))
    for behind in nudge.BEHIND_M:
        for d, dist in candidates:
            for yaw in nudge.YAWS_DEG:
                orient = nudge.grasp_orientation(world, nudge._turn(d, yaw))
                if not nudge._hand_meets(world, instance, boxes, hand, orient, d, dist, behind):
                    return nudge.Push(d, dist, orient, behind)
    return None


def test_the_clearing_push_made_as_needed_is_the_one_made_from_all_candidates(scene):
    """`nudge.clearing_shift` makes its candidate pushes as the search needs them: on libero_10-01's
    cream cheese (as if held by its narrow top, so the search runs; next to the milk carton), the
    push of the plain search that makes all of them first, for the top and for a pinch lower down."""
    s = scene("libero_10-01/normal")
    w, obj = s.world, "cream_cheese_1"
    top = narrow_top(w, obj)
    assert top is not None
    for part in (top, (top[0], top[1] - 0.01)):
        grasp = replace(plan_grasp(w, obj), hung=True, part=part)
        got, plain = nudge.clearing_shift(w, obj, grasp), _clearing_shift_plain(w, obj, part)
        assert got is not None and plain is not None  # a push found: the search ran its course
        assert np.array_equal(got.direction, plain.direction) and np.array_equal(got.orient, plain.orient)
        assert (got.dist, got.behind) == (plain.dist, plain.behind)


def _passed_plain(boxes, own, shifts, near):
    """`pick_place._passed` as `corridor_tops` wrote it: every box's gaps at every shift."""
    gap = pick_place._plan_gaps(boxes, own, shifts)
    away = (gap[:, 0] >= pick_place.AWAY_GAP_M) & np.all(gap >= gap[:, :1] - 1e-9, axis=1)
    return np.flatnonzero(near & away)


def test_corridor_gaps_measured_for_the_boxes_in_question_leave_out_what_all_gaps_did():
    """`pick_place._passed` (which obstacles the carry leads away from) measures the gaps only for
    the boxes near the corridor, AWAY_GAP_M beside the object, a few shifts at a time: the same
    boxes as every gap measured, with boxes exactly AWAY_GAP_M off and paths leading away and toward."""
    rng = np.random.default_rng(2)
    passed = 0
    for trial in range(300):
        boxes = _boxes(rng, int(rng.integers(0, 80)), 0.3)
        own = _boxes(rng, int(rng.integers(1, 12)), 0.05)
        if trial % 4 == 0 and len(boxes):  # a box exactly AWAY_GAP_M beside the object's
            boxes[0, 0, 0] = own[:, 1, 0].max() + pick_place.AWAY_GAP_M
        end = rng.uniform(-0.4, 0.4, 2)
        shifts = np.linspace(0, 1, int(rng.integers(2, 40)))[:, None] * end
        near = rng.random(len(boxes)) < 0.7
        got = pick_place._passed(boxes, own, shifts, near)
        np.testing.assert_array_equal(got, _passed_plain(boxes, own, shifts, near))
        passed += len(got)
    assert passed > 100  # boxes were left out


def _leg_plain(world, obj, frm, to, boxes, hand, owners, geoms):
    """`push._leg` as first written: every sweep tested against all the boxes."""
    direction = push._unit(to - frm)
    z = world.box(obj).lo[2] + push.CONTACT_Z_M
    t = np.linspace(0.0, 1.0, push.PATH_SAMPLES)[:, None]
    centres = np.column_stack([frm + t * (to - frm), np.full(push.PATH_SAMPLES, z)])
    obj_local = world.points(obj) - np.append(world.body_pos(obj)[:2], z)
    obj_hits = push._sweep(boxes, obj_local, centres)
    across = np.array([-direction[1], direction[0]])
    best = None
    for deg in push.YAWS_DEG:
        c, s = np.cos(np.radians(deg)), np.sin(np.radians(deg))
        axis = np.array([c * across[0] - s * across[1], s * across[0] + c * across[1], 0.0])
        orient = push.grasp_orientation(world, axis)
        for inside in push.INSIDE_CHOICES_M:
            grips = centres - np.append(direction * push.back_reach(world, obj, direction, inside), 0.0)
            hits = set(obj_hits)
            for part in hand:
                hits |= push._sweep(boxes, part @ orient.T, grips)
            score = (len({owners[h] for h in hits}), len({geoms[h] for h in hits}))
            if best is None or score < best[0]:
                best = (score, hits, push.Leg(to, orient, inside))
    return best[1], best[2]


def test_a_push_leg_tested_against_the_boxes_its_sweeps_reach_is_the_leg_tested_against_all(scene):
    """`push._leg` tests each sweep only against the boxes reaching the box around all the leg's
    sweeps: on libero_goal-05's plate, for legs toward 12 points around it (near the cabinet, the
    stove and the bowl), the same obstacles met and the same leg as every sweep against every box."""
    s = scene("libero_goal-05/normal")
    w, obj = s.world, "plate_1"
    boxes, geoms = clearance.obstacle_pieces(w, (obj,))
    owners = [w.root_name(g) for g in geoms]
    hand, pos = push.hand_points(w), w.body_pos(obj)[:2]
    met = 0
    for a in np.linspace(0, 2 * np.pi, 12, endpoint=False):
        to = pos + 0.25 * np.array([np.cos(a), np.sin(a)])
        got, leg = push._leg(w, obj, pos, to, boxes, hand, owners, geoms)
        plain, plain_leg = _leg_plain(w, obj, pos, to, boxes, hand, owners, geoms)
        assert got == plain and leg.inside == plain_leg.inside
        assert np.array_equal(leg.orient, plain_leg.orient) and np.array_equal(leg.to, plain_leg.to)
        met += bool(got)
    assert met > 0  # obstacles were met
