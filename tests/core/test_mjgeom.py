"""World boxes of geoms and the mju_* rotation helpers of vpro_assets.core.mjgeom."""

from __future__ import annotations

import math

import mujoco
import numpy as np
import pytest

from vpro_assets.core.mjgeom import (
    axis_angle_quat,
    colliding,
    geom_corners,
    geom_pieces,
    quat_matrix,
    quat_mul,
    world_aabb,
)

XML = """
<mujoco>
  <worldbody>
    <body pos="1 2 3" quat="0.70710678 0 0 0.70710678">
      <geom name="box" type="box" size="0.1 0.2 0.3"/>
      <geom name="ghost" type="sphere" size="0.05" pos="0 0 1" contype="0" conaffinity="0"/>
    </body>
  </worldbody>
</mujoco>
"""


@pytest.fixture(scope="module")
def scene():
    model = mujoco.MjModel.from_xml_string(XML)
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    return model, data


def test_world_aabb_of_a_turned_box_swaps_its_x_and_y_extents(scene):
    model, data = scene
    lo, hi = world_aabb(model, data, [0])
    np.testing.assert_allclose(lo, [0.8, 1.9, 2.7], atol=1e-9)
    np.testing.assert_allclose(hi, [1.2, 2.1, 3.3], atol=1e-9)


def test_corners_cover_every_geom_and_colliding_skips_visual_ones(scene):
    model, data = scene
    assert geom_corners(model, data, range(model.ngeom)).shape == (16, 3)
    assert colliding(model, range(model.ngeom)) == [0]
    lo, hi = world_aabb(model, data, range(model.ngeom))
    assert hi[2] == pytest.approx(4.05)  # the sphere 1 m above the box centre
    with pytest.raises(ValueError):
        world_aabb(model, data, [])


def test_pieces_of_a_plate_turned_45_degrees_hug_it_where_its_world_box_does_not():
    """A 40 x 2 cm plate turned 45 degrees about z: its world box is a 30 cm square, 95% empty;
    its 2 cm pieces' boxes cover the plate and stay within about 2 cm of it."""
    xml = """<mujoco><worldbody><body quat="0.92387953 0 0 0.38268343">
      <geom type="box" size="0.2 0.01 0.005"/></body></worldbody></mujoco>"""
    model = mujoco.MjModel.from_xml_string(xml)
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    lo, hi = world_aabb(model, data, [0])
    pieces = geom_pieces(model, data, 0, 0.02)
    assert pieces.shape == (20, 2, 3)  # 20 x 1 x 1 cells of at most 2 cm
    corner = np.array([lo[0] + 0.01, hi[1] - 0.01])  # inside the world box, 20 cm from the plate
    covers = np.all((pieces[:, 0, :2] <= corner) & (corner <= pieces[:, 1, :2]), axis=1)
    assert not covers.any()
    along = np.array([np.cos(np.pi / 4), np.sin(np.pi / 4)])
    for t in np.linspace(-0.19, 0.19, 9):  # every point of the plate's axis is in some piece
        p = along * t
        assert np.any(np.all((pieces[:, 0, :2] <= p) & (p <= pieces[:, 1, :2]), axis=1))
    area = np.prod(pieces[:, 1, :2] - pieces[:, 0, :2], axis=1).sum()
    assert area < 0.2 * np.prod((hi - lo)[:2])


def test_rotation_helpers_agree_with_each_other_and_the_right_hand_rule():
    quarter_z = axis_angle_quat([0, 0, 2.0], math.pi / 2)  # the axis is normalised first
    np.testing.assert_allclose(quat_matrix(quarter_z) @ [1, 0, 0], [0, 1, 0], atol=1e-12)
    half_z = quat_mul(quarter_z, quarter_z)
    np.testing.assert_allclose(quat_matrix(half_z) @ [1, 0, 0], [-1, 0, 0], atol=1e-12)
    rng = np.random.default_rng(0)
    q = rng.normal(size=4)  # not unit length: quat_matrix normalises
    r = quat_matrix(q)
    np.testing.assert_allclose(r @ r.T, np.eye(3), atol=1e-12)
    assert np.linalg.det(r) == pytest.approx(1.0)
