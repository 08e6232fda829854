"""Standing a flat book on its end before it goes into the caddy (`pivot`, `plan`).

libero_10-05's book (2.9 cm thick, 11 x 13.5 cm) goes into the desk caddy's back compartment. Lying
flat (object_pose-v1-lying), it is wider than the open fingers every way: the pick found no pinch
(0/10). It is pinched across a corner of its top end and turned a quarter turn about its bottom
end's lower edge, then picked as it stands in Normal.
"""

import numpy as np
import pytest
from conftest import oracle_episode

from vpro_assets.rollout.policies.oracle import lay, pivot, turn_over
from vpro_assets.rollout.policies.oracle.shape import MAX_PINCH_M

BOOK, BACK = "black_book_1", "desk_caddy_1_back_contain_region"
LYING = "libero_10-05/task_precondition_variation/object_pose-v1-lying"
# object_pose-v1-lying's trial 0 lays the book so: its cover on the table, its top end toward -y,
# its side 6 mm from the caddy's wall (body position and rotation matrix, row-major).
FLAT_POS = np.array([-0.257, 0.164, 0.8993])
FLAT_MAT = np.array([[0.0, 1.0, 0.0], [0.0, 0.0, -1.0], [-1.0, 0.0, 0.0]])


def _lay_flat(s) -> None:
    """Lay the scene's book flat as object_pose-v1-lying's trial 0 does, and let it settle."""
    s.set_pose(BOOK, FLAT_POS, FLAT_MAT)


def test_upright_book_is_not_pivoted(scene):
    """Normal's book stands upright: it goes into the compartment as it is."""
    s = scene("libero_10-05/normal")
    assert not pivot.lies_flat(s.world, BOOK)
    assert not pivot.needs_pivot(s.world, BOOK, BACK)
    assert s.plan() == [f"pick_place(in {BOOK} {BACK})"]


def test_flat_book_is_stood_up_first(scene):
    """Lying flat, the book is too wide every way to pinch and thin enough for a pad at its edge:
    the plan stands it on its end first, and only for an `In` of a fixture's region."""
    s = scene("libero_10-05/normal")
    _lay_flat(s)
    w = s.world
    assert lay.lying(w, BOOK) and pivot.lies_flat(w, BOOK)
    assert pivot.needs_pivot(w, BOOK, BACK)
    assert not turn_over.needs_turning_over(w, BOOK, BACK)
    assert not pivot.needs_pivot(w, BOOK, "white_yellow_mug_1")  # not a region
    assert s.plan() == [f"pivot(upright {BOOK})", f"pick_place(in {BOOK} {BACK})"]


def test_corner_pinch_is_taken_away_from_the_caddy(scene):
    """The pinch's contacts lie on the top end's face and the side face away from the caddy, 5 cm
    apart along a line 55 degrees off the side face's normal (inside the pads' 63-degree friction
    cones), at the book's mid-thickness; the fingers' opening is under MAX_PINCH_M."""
    s = scene("libero_10-05/normal")
    _lay_flat(s)
    w = s.world
    point, axis = pivot.corner_pinch(w, BOOK)
    pts = w.points(BOOK)
    up = lay.up_axis(w, BOOK)
    assert up is not None and up[1] < -0.99  # top end toward -y
    side = np.array([1.0, 0.0, 0.0])  # the caddy stands at -x
    assert abs(float(axis @ side) - np.cos(pivot.ANGLE_RAD)) < 1e-6
    assert abs(float(axis @ up) + np.sin(pivot.ANGLE_RAD)) < 1e-3
    ends = [point - axis * pivot.CHORD_M / 2, point + axis * pivot.CHORD_M / 2]
    assert abs(ends[0][1] - pts[:, 1].min()) < 0.002  # on the top end's face
    assert abs(ends[1][0] - pts[:, 0].max()) < 0.002  # on the side face away from the caddy
    assert abs(point[2] - (pts[:, 2].min() + pts[:, 2].max()) / 2) < 0.002
    assert pivot.CHORD_M < MAX_PINCH_M


def test_flat_book_is_stood_on_its_end(scene):
    """Pinched at a corner and turned a quarter turn about its bottom edge, the book stands upright
    (its up axis within 10 degrees of the vertical), let go, in under 200 steps (about 155 here)."""
    s = scene("libero_10-05/normal")
    _lay_flat(s)
    w = s.world
    s.run(pivot.stand_up(w, BOOK), 200)
    s.wait(20)
    up = lay.up_axis(w, BOOK)
    assert up is not None and up[2] > np.cos(np.radians(10.0)), up
    assert not w.held(BOOK)


@pytest.mark.slow
@pytest.mark.parametrize("trial", [2, 7])
def test_flat_book_stood_up_goes_into_the_caddy(trial):
    """object_pose-v1-lying: 0/10 before the pivot, 10/10 after (278 to 292 steps of 520); trial 2
    is the one whose wrist ran into its limit turning from pointing sideways, trial 7 the one with
    the mug nearest the book (2.6 cm)."""
    row = oracle_episode(LYING, trial, build=True)
    assert row["success"], row
