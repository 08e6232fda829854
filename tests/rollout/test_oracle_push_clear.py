"""Two oracle fixes of issue 13 on real LIBERO scenes (render-free; the default run needs no built
scene case): a drawer part open is opened before something goes in (libero_10-03's
receptacle-openness `-open75`), and a target held by its narrow top whose neighbour stops the hand
is pushed clear first (`nudge`: the twisted cream cheese of libero_object-01 and libero_10-01).
"""

import numpy as np
import pytest
from conftest import build_scene_case

from vpro_assets.rollout.policies.oracle import nudge
from vpro_assets.rollout.policies.oracle.clearance import obstacle_boxes
from vpro_assets.rollout.policies.oracle.grasp import hand_stop, narrow_top, plan_grasp
from vpro_assets.rollout.policies.oracle.pick import pick

PUT_IN = "pick_place(in akita_black_bowl_1 white_cabinet_1_bottom_region)"
CLOSE = "drawer(close white_cabinet_1_bottom_region)"
OPEN = "drawer(open white_cabinet_1_bottom_region)"


def test_plan_opens_a_part_open_drawer_before_the_bowl_goes_in(scene):
    """libero_10-03 ("put the black bowl in the bottom drawer and close it"): its Normal start has the
    drawer open past LIBERO's `Open` (-0.14), so the bowl goes straight in. Three quarters open
    (-0.105, as trial 0 of the `-open75` case starts it) the 10.7 cm bowl does not fit between the
    drawer's front and the middle drawer's handle over it: the drawer is opened first."""
    s = scene("libero_10-03/normal")
    assert s.plan() == [PUT_IN, CLOSE]
    s.set_joint(s.world.joint("white_cabinet_1_bottom_level"), -0.105)
    assert not s.holds(("open", "white_cabinet_1_bottom_region"))
    assert s.plan() == [OPEN, PUT_IN, CLOSE]


def test_bowl_goes_into_the_part_open_drawer_and_it_closes(scene):
    """The whole task from the three-quarters-open drawer within libero_10's 520 steps (before the
    fix the bowl rested on the middle drawer's handle and the close stalled at -0.04)."""
    s = scene("libero_10-03/normal")
    s.set_joint(s.world.joint("white_cabinet_1_bottom_level"), -0.105)
    assert s.oracle_until_success(limit=520)


def _block(center, half, top):
    """A box standing on the table (z 0) as (1, 2, 3) world boxes."""
    c, h = np.asarray(center, float), np.asarray(half, float)
    return np.array([[[*(c - h), 0.0], [*(c + h), top]]])


def test_hand_stop_over_a_pinch_and_when_it_is_too_high():
    """A solid 7 cm across x and 12 cm across y, 2 cm tall, fits the open fingers only across x, so
    the palm (21 cm along the closing axis) lies along x: a 10 cm tall neighbour 12 cm away along x
    stops the hand (the palm's bottom 2.6 cm over the grip site) 5.8 cm over the pinch; 12 cm away
    along y, nothing does; a solid too wide every way has no pinch. A stop of 2.5 cm is too high over
    a pinch 4 mm under a low object's top, 2 cm is not over one 3 cm under a can's."""
    xs, ys, zs = np.meshgrid([-0.035, 0.035], [-0.06, 0.06], [0.0, 0.02], indexing="ij")
    solid = np.c_[xs.ravel(), ys.ravel(), zs.ravel()]
    z = 0.016
    along_x = _block([0.12, 0.0], [0.03, 0.03], 0.10)
    assert hand_stop(along_x, solid, z) == pytest.approx(0.10 - 0.026 - z)
    assert hand_stop(_block([0.0, 0.12], [0.03, 0.03], 0.10), solid, z) == 0.0
    assert hand_stop(along_x, solid * [1.3, 1.0, 1.0], z) == float("inf")  # 9.1 x 12 cm: no pinch
    assert nudge._too_high(0.025, z, 0.02) and not nudge._too_high(0.002, z, 0.02)
    assert not nudge._too_high(0.02, 0.09, 0.12)


def test_a_whole_pinch_is_not_pushed_clear(scene):
    """libero_10-01/normal, trial 0: the cream cheese fits the open fingers whole, and in the hand
    model the palm over its best pinch lies over the milk carton 8.5 cm up; the Normal task is solved
    so (9 of 10 trials in the certificate), so only a pinch by the narrow top (a grasp with a `part`)
    is pushed clear."""
    s = scene("libero_10-01/normal", 0)
    obj = "cream_cheese_1"
    pts = s.world.points(obj)
    z = float(pts[:, 2].max()) - 0.01
    assert hand_stop(obstacle_boxes(s.world, (obj,)), pts, z) > 0.05
    grasp = plan_grasp(s.world, obj)
    assert grasp.part is None and not grasp.hung and not nudge.blocked(s.world, obj)


@pytest.mark.slow
@pytest.mark.parametrize("case_id", ["libero_object-01/target_geometry_variation/twist-s3-v2"])
def test_twisted_cream_cheese_pushed_clear_of_its_neighbour_then_lifted(scene, case_id):
    """The twisted cream cheese (too wide to pinch whole, its top 7.3 cm across in three directions)
    stands where every pinch of its top puts the palm over the tomato sauce: it is pushed away from
    it first, and the pick lifts it (trial 1 failed before the push). Here the box stops after 2.5 of
    the 4 cm planned and the hand model still puts the palm 3.5 cm over the pinch, yet the pick
    holds: the model (the palm's box) is conservative. The scene is built first (a no-op when it is
    current)."""
    build_scene_case(case_id)
    s = scene(case_id, 1)
    obj = "cream_cheese_1"
    assert nudge.blocked(s.world, obj)
    grasp = plan_grasp(s.world, obj)
    assert grasp.hung and grasp.part is not None
    pts, z = grasp.part
    top = narrow_top(s.world, obj)  # the part the grasp is planned across
    assert top is not None and np.array_equal(pts, top[0]) and z == top[1]
    before = hand_stop(obstacle_boxes(s.world, (obj,)), pts, z)
    shift = nudge.clearing_shift(s.world, obj)
    assert shift is not None and shift.dist <= nudge.MAX_M
    start = s.world.body_pos(obj)[:2].copy()
    s.run(nudge.clear_for_pick(s.world, obj, plan_grasp(s.world, obj)), limit=260)
    moved = s.world.body_pos(obj)[:2] - start
    assert float(moved @ shift.direction[:2]) > shift.dist / 2  # 2.5 of the 4 cm planned here
    pts, z = plan_grasp(s.world, obj).part
    assert hand_stop(obstacle_boxes(s.world, (obj,)), pts, z) <= before + 1e-6
    z0 = s.world.body_pos(obj)[2]
    s.run(pick(s.world, obj), limit=200)
    assert s.world.body_pos(obj)[2] - z0 > 0.05 and s.world.held(obj)
