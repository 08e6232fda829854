"""Two objects onto one region (`room`) and a held object turned back upright before it is set down
(`level`), on libero_10-08 ("put both moka pots on the stove").

The stove's plate is 19 x 19 cm; LIBERO's `On` wants each pot's body position inside the cook
region's 15 x 15 cm box. A pot pinched by its handle turns in the fingers about their axis.
"""

import numpy as np
import pytest
from conftest import build_scene_case
from scipy.spatial.transform import Rotation

from vpro_assets.rollout.policies.oracle import level, motion, room
from vpro_assets.rollout.policies.oracle.motion import OPEN
from vpro_assets.rollout.policies.oracle.pick import pick
from vpro_assets.rollout.policies.oracle.pick_place import carry, lower_and_release, resolve

CASE = "libero_10-08/normal"
MULTIPEAK_S2 = "libero_10-08/target_geometry_variation/multipeak-s2-v1"
STOVE, REGION = "flat_stove_1", "flat_stove_1_cook_region"


def test_first_of_two_pots_leaves_the_plate_room_for_the_second(scene):
    """Alone, the first pot goes to the region's centre (as before); with the second still to come,
    it goes against one side of the plate, inside LIBERO's box, leaving a strip of plate beside it
    wider than the second pot and the gap between them (9.4 cm against 8.1 + 1)."""
    s = scene(CASE)
    w = s.world
    center = w.site_pos(REGION)[:2]
    alone = resolve(w, "on", REGION, "moka_pot_1")
    np.testing.assert_allclose(alone.xy, center)
    first = resolve(w, "on", REGION, "moka_pot_1", coming=("moka_pot_2",))
    half = np.abs(w.site_size(REGION))[:2]
    assert np.all(np.abs(first.xy - center) < half), first.xy - center
    lo, hi = room.plate(w, STOVE, REGION, first.surface_z)
    assert np.all(hi - lo > 0.18), (lo, hi)  # the plate, not only the pieces under the region's box
    box, body = w.box("moka_pot_1"), w.body_pos("moka_pot_1")[:2]
    f_lo, f_hi = box.lo[:2] - body + first.xy, box.hi[:2] - body + first.xy
    assert np.all(f_lo >= lo) and np.all(f_hi <= hi), (f_lo, f_hi, lo, hi)
    strip = max(np.max(f_lo - lo), np.max(hi - f_hi))
    second = w.box("moka_pot_2")
    assert strip > np.min(second.size[:2]) + room.GAP_M, strip


def test_pot_turned_in_the_fingers_is_turned_back_upright(scene):
    """The pot, lifted by its handle, is turned 30 degrees with the hand about the fingers' axis (as
    the deformed pot of multipeak-s1 swung when the carry set off); `level.upright` turns the hand
    until the pot stands within 5 degrees of upright again. Turned less than `max_tilt`, it is left."""
    s = scene(CASE)
    w = s.world
    taken, limit = w.body_mat("moka_pot_1"), level.max_tilt(w.box("moka_pot_1").size)
    s.run(pick(w, "moka_pot_1"), limit=150)
    assert level.correction(w, "moka_pot_1", taken).magnitude() < limit
    assert not list(level.upright(w, "moka_pot_1", taken, limit))  # hangs near upright: nothing to do
    turn = Rotation.from_rotvec(np.radians(30.0) * w.finger_axis()).as_matrix()
    s.run(motion.move_to(w, w.eef(), w.hold_grip, turn @ w.eef_mat(), tol=0.02, max_steps=60), limit=61)
    assert level.correction(w, "moka_pot_1", taken).magnitude() > np.radians(20.0)
    s.run(level.upright(w, "moka_pot_1", taken, limit), limit=level.TURN_STEPS + 1)
    s.run(motion.hold_still(w, w.hold_grip, 10), limit=11)
    assert level.correction(w, "moka_pot_1", taken).magnitude() < np.radians(5.0)
    assert w.held("moka_pot_1")


def test_a_region_of_the_table_has_no_plate(scene):
    """A region of the table (libero_10-06's right of the plate) has no plate of its own: `plate` is
    None and the spot falls back to `free_spot`. Its owner, the table, has no `_main` body: asking
    for one raised inside every trial whose region centre was taken (libero_10-06's lying mug)."""
    w = scene("libero_10-06/normal").world
    region = "living_room_table_plate_right_region"
    assert room.plate(w, "living_room_table", region, w.table_z) is None
    assert room.spot(w, region, "chocolate_pudding_1", "living_room_table", w.table_z, [], True) is None


@pytest.mark.slow
def test_pot_hanging_twelve_degrees_off_upright_is_set_down_upright(scene):
    """multipeak-s2's first pot (trial 4), pinched by its handle, hangs 12-13 degrees off upright
    over the stove: under the old 15 degrees it was let go so, 1.8 cm over the burner, landed on its
    edge and toppled off the stove (4 of 10 trials). Its box tips over at 21 degrees, so `max_tilt`
    lets it hang 10.7 at most: it is turned back, set down and stands upright on the stove. A bowl
    (flat and wide: its box tips over at 58 degrees) may hang 29."""
    build_scene_case(MULTIPEAK_S2)  # a deformed pot (coacd): a no-op when the case is current
    s = scene(MULTIPEAK_S2, 4)
    w = s.world
    taken, limit = w.body_mat("moka_pot_1"), level.max_tilt(w.box("moka_pot_1").size)
    assert np.radians(10.0) < limit < np.radians(11.5), np.degrees(limit)
    assert level.max_tilt(np.array([0.16, 0.16, 0.05])) > np.radians(28.0)
    s.run(pick(w, "moka_pot_1"), limit=150)
    dest = resolve(w, "on", REGION, "moka_pot_1", coming=("moka_pot_2",))
    s.run(carry(w, "moka_pot_1", dest.xy), limit=300)
    tilt = level.correction(w, "moka_pot_1", taken).magnitude()
    assert limit < tilt < np.radians(15.0), np.degrees(tilt)  # let go so before max_tilt
    s.run(level.upright(w, "moka_pot_1", taken, limit), limit=level.TURN_STEPS + 1)
    assert level.correction(w, "moka_pot_1", taken).magnitude() < np.radians(5.0)
    s.run(lower_and_release(w, "moka_pot_1", dest), limit=300)
    s.run(motion.hold_still(w, OPEN, 30), limit=31)
    assert level.correction(w, "moka_pot_1", taken).magnitude() < np.radians(5.0)
    assert STOVE in w.touching("moka_pot_1")
