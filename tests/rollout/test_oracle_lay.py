"""Laying a held object on its side onto a region it stands too tall for (`lay`, `pick_place.lay_down`).

LIBERO's `On` of a region wants the object's body position at most 10 cm over the region's top;
libero_goal-02's precondition case stands the wine bottle upside down, its body position (the
bottle's base) 15.8 cm over the cap it stands on.
"""

import numpy as np
from conftest import build_scene_case

from vpro_assets.rollout.policies.oracle import lay, motion
from vpro_assets.rollout.policies.oracle.pick_place import pick_place, resolve

INVERTED_BOTTLE = "libero_goal-02/task_precondition_variation/object_pose-v1"
BOTTLE, CABINET_TOP = "wine_bottle_1", "wooden_cabinet_1_top_side"


def test_what_stands_too_tall_for_a_region(scene):
    """The upright bottle fits under the cabinet top's limit (10 cm over it), and the moka pots on
    the stove with 1.1 cm to spare; onto an object (LIBERO's `On` of two objects) there is no limit."""
    for case_id, held, dest in (
        ("libero_goal-02/normal", BOTTLE, CABINET_TOP),
        ("libero_10-08/normal", "moka_pot_1", "flat_stove_1_cook_region"),
    ):
        s = scene(case_id)
        d = resolve(s.world, "on", dest, held)
        headroom = d.max_body_z - d.surface_z - lay.rise(s.world, held)
        assert 0.005 < headroom <= lay.LIBERO_ON_HEIGHT_M + 0.002, (case_id, headroom)
    assert resolve(s.world, "on", "moka_pot_2", "moka_pot_1").max_body_z == np.inf


def test_inverted_bottle_laid_on_the_cabinet_top(scene):
    """Upside down, the bottle is 5.8 cm too tall for the cabinet's top. Laid on its side by
    `pick_place` (carried with the fingers across the line from the arm's base, tipped forward over
    the top, let go), it lies there: LIBERO's `On` holds and still holds once it has come to rest.
    The scene is built first (a no-op when it is current)."""
    build_scene_case(INVERTED_BOTTLE)
    s = scene(INVERTED_BOTTLE)
    w = s.world
    dest = resolve(w, "on", CABINET_TOP, BOTTLE)
    assert dest.surface_z + lay.rise(w, BOTTLE) > dest.max_body_z + 0.05  # standing, it cannot satisfy On
    steps = s.run(pick_place(w, BOTTLE, "on", CABINET_TOP), limit=260)
    s.run(motion.hold_still(w, motion.OPEN, 40), limit=45)
    pts = w.points(BOTTLE)
    assert np.ptp(pts[:, 2]) < 0.06, steps  # lying: its 4.4 cm girth is its height
    assert s.holds(("on", BOTTLE, CABINET_TOP)) and s.cenv.success(), steps


INVERTED_ON_RACK = "libero_goal-09/task_precondition_variation/object_pose-v1"
RACK_REGION = "wine_rack_1_top_region"


def test_inverted_bottle_laid_along_the_wine_rack_shelf(scene):
    """The wine rack's region is a box tilted with its shelf (31 degrees, rising toward the back
    from a lip): the inverted bottle is laid along the shelf's contour line (world x) in the middle
    of the box, up the shelf from the lip, not across the line from the arm's base at the lip (where
    one end hung off the shelf's front and the bottle fell to the table, 10 of 10 trials). It rolls
    against the lip and LIBERO's goal holds. The scene is built first (a no-op when it is current)."""
    build_scene_case(INVERTED_ON_RACK)
    s = scene(INVERTED_ON_RACK)
    w = s.world
    lip = w.site_pos(RACK_REGION)[:2]
    dest = resolve(w, "on", RACK_REGION, BOTTLE)
    assert dest.surface_z + lay.rise(w, BOTTLE) > dest.max_body_z + 0.04  # standing, it is too tall
    xy, along = lay.spot(w, RACK_REGION, dest.xy)
    assert abs(along[0]) > 0.99 and xy[1] < lip[1] - 0.03, (along, xy - lip)
    steps = s.run(pick_place(w, BOTTLE, "on", RACK_REGION), limit=230)
    s.run(motion.hold_still(w, motion.OPEN, 30), limit=35)
    assert np.ptp(w.points(BOTTLE)[:, 2]) < 0.06, steps  # lying on the shelf (4.4 cm across), not standing
    assert s.holds(("on", BOTTLE, RACK_REGION)) and s.cenv.success(), steps


def test_lying_bottle_pinched_where_the_hand_comes_down_beside_the_rack(scene):
    """libero_goal-09's lying bottle (trial 1) lies with its neck under the wine rack's front: over
    its middle the open hand stops on the rack's lower lip, 5.6 cm over the pinch. The pinch moves
    along the bottle (`grasp.along_free`) to where the hand comes down to it."""
    from vpro_assets.rollout.policies.oracle.clearance import obstacle_boxes
    from vpro_assets.rollout.policies.oracle.grasp import BLOCKED_M, plan_grasp
    from vpro_assets.rollout.policies.oracle.hand import reach_height
    from vpro_assets.rollout.policies.oracle.shape import extent_middle

    case = "libero_goal-09/task_precondition_variation/object_pose-v1-lying"
    build_scene_case(case)
    w = scene(case, 1).world
    grasp = plan_grasp(w, BOTTLE)
    boxes = obstacle_boxes(w, (BOTTLE,))
    middle = extent_middle(w.points(BOTTLE), grasp.axis, grasp.point[2])
    assert reach_height(boxes, middle, grasp.axis) > middle[2] + 0.04  # over the middle: on the rack
    assert reach_height(boxes, grasp.point, grasp.axis) <= grasp.point[2] + BLOCKED_M
    assert 0.01 <= np.linalg.norm(grasp.point - middle) <= 0.05


def test_pot_held_by_its_handle_laid_down_toward_the_grip(scene):
    """A moka pot held by its handle, laid down where it must end lower than it stands (libero_10-08's
    inverted pot stands 0.9 cm too tall for the stove): tipped out along the line from the arm's
    base it hangs over the grip, too tall still; tipped toward the grip it hangs under it. The hand
    rises first so the tipping pot clears the stove (tipped at the carry's height, it struck the
    plate and slipped out of the fingers). Here the upright pot of libero_10-08/normal is given a
    limit 5 mm under its standing height; laid, it ends under it, on its side on the stove."""
    from vpro_assets.rollout.policies.oracle.pick import pick
    from vpro_assets.rollout.policies.oracle.pick_place import Destination, lay_down

    s = scene("libero_10-08/normal")
    w = s.world
    pot, region = "moka_pot_1", "flat_stove_1_cook_region"
    d = resolve(w, "on", region, pot)
    limit = d.surface_z + lay.rise(w, pot) - 0.005
    s.run(pick(w, pot), limit=150)
    dest = Destination(d.xy, d.surface_z, d.instance, d.relation, limit)
    s.run(lay_down(w, pot, dest, region), limit=260)
    s.run(motion.hold_still(w, motion.OPEN, 30), limit=31)
    up = w.body_mat(pot)[:, 2]
    assert abs(up[2]) < 0.5, up  # on its side
    assert w.body_pos(pot)[2] < limit and "flat_stove_1" in w.touching(pot)


LYING_MUG = "libero_10-06/task_precondition_variation/object_pose-v1-lying"
MUG, PLATE = "porcelain_mug_1", "plate_1"


def test_lying_mug_is_set_down_on_the_plate_before_it_is_let_go(scene):
    """libero_10-06's precondition case lays the mug on its side (`lay.lying`: its up axis level;
    Normal's mug stands). Pinched 6 cm off its middle and let go 1.2 cm over the plate's rim, it
    rolled off the plate (trial 1, and 5 more of 10); set down on the plate before the fingers open,
    it stays there: LIBERO's `On` holds once it has come to rest. The scene is built first (a no-op
    when it is current)."""
    assert not lay.lying(scene("libero_10-06/normal").world, MUG)
    build_scene_case(LYING_MUG)
    s = scene(LYING_MUG, trial=1)
    w = s.world
    assert lay.lying(w, MUG)
    steps = s.run(pick_place(w, MUG, "on", PLATE), limit=200)
    s.run(motion.hold_still(w, motion.OPEN, 40), limit=45)
    assert s.holds(("on", MUG, PLATE)), (steps, w.body_pos(MUG) - w.body_pos(PLATE))
