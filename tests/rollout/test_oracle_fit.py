"""Turning a held object to fit into a narrow region (`fit`, `pick_place`).

libero_10-05 puts the book (2.9 x 11 cm in plan) into the desk caddy's back compartment, whose
LIBERO box is 5.6 x 12.4 cm; the book stands turned 40 degrees off the compartment at trial 0.
"""

import numpy as np

from vpro_assets.rollout.policies.oracle import fit
from vpro_assets.rollout.policies.oracle.lay import turned
from vpro_assets.rollout.policies.oracle.pick_place import pick_place

BOOK, BACK = "black_book_1", "desk_caddy_1_back_contain_region"


def test_overflow_of_a_footprint():
    """Positive: the worse axis's excess over the box; negative: the room left on the tighter axis."""
    square = np.array([[0.0, 0.0, 0.0], [0.04, 0.1, 0.0]])
    assert np.isclose(fit.overflow(square, np.array([0.01, 0.1])), 0.02)
    assert np.isclose(fit.overflow(square, np.array([0.01, 0.03])), 0.04)
    assert np.isclose(fit.overflow(square, np.array([0.03, 0.07])), -0.02)


def test_book_turned_into_the_caddy_back_compartment(scene):
    """As taken, the book's footprint overflows the compartment's box; turned by `fit_turn` it fits
    with the body position inside the box, and `pick_place` lowers it in held upright: LIBERO's
    `In` holds while the book goes down, without letting it tip over the walls."""
    s = scene("libero_10-05/normal")
    w = s.world
    half = w.region_half(BACK)[:2]
    assert fit.overflow(w.points(BOOK), half) > 0.03
    for n, action in enumerate(pick_place(w, BOOK, "in", BACK), 1):
        s.cenv.step(action)
        if s.cenv.success():
            break
        assert n < 200, "book not in the back compartment after 200 steps"
    assert fit.overflow(w.points(BOOK), half) < 0  # went in turned to fit
    up = w.body_mat(BOOK)[:, 2]
    assert up[2] > 0.95, up  # held upright, not tipped in


def test_book_too_wide_for_the_box_leaned_in_over_one_wall(scene):
    """Against a box 10 cm long (the book is 11 cm wide), no turn fits: `lean` turns the book's
    thickness across the box's short axis and aims its footprint so that one end lies LEAN_INSIDE_M
    inside the box and the other beyond the far wall, the body position inside the box
    (libero_10-05 taper-s3's book: 14.5 cm wide at its foot against the 12.4 cm box)."""
    s = scene("libero_10-05/normal")
    w = s.world
    half = np.array([w.region_half(BACK)[:2][0], 0.05])
    center = w.site_pos(BACK)[:2]
    spin = [np.array([[np.cos(t), -np.sin(t), 0.0], [np.sin(t), np.cos(t), 0.0], [0.0, 0.0, 1.0]]) for t in fit.TURNS]
    orient, xy = fit.lean(w, BOOK, half, center, w.eef_mat(), spin)
    pts, body = turned(w, BOOK, orient)
    foot = pts[:, :2] - body[:2] + xy  # the footprint where the carry brings it
    inside_lo, inside_hi = foot.min(0) - (center - half), (center + half) - foot.max(0)
    assert inside_lo[0] > 0 and inside_hi[0] > 0  # the thickness across the short axis
    assert np.isclose(max(inside_lo[1], inside_hi[1]), fit.LEAN_INSIDE_M, atol=1e-3)  # one end just in
    assert min(inside_lo[1], inside_hi[1]) < -0.01  # the other out over the wall
    assert np.all(np.abs(xy - center) <= half)
