"""The position contradiction's visibility score (`displacement.Visibility.share`) on a scene small
enough to reason about: a target of a mesh and a box under a camera looking straight down."""

import mujoco
import numpy as np
import pytest

from vpro_assets.perturb import displacement as dp

# A 10 cm mesh tetrahedron and a 4 cm box 20 cm beside it (one body, the target, at height 0.5), a
# camera 1.5 m above it at x = 0.1 looking down (vertical field of view 45 degrees: x = -0.52..0.72 in
# view at the target's height), and a plate 1 m under the camera over x = 0.3..0.5, which hides
# x = 0.4..0.7 at the target's height.
SCENE = """
<mujoco>
  <asset><mesh name="tet" vertex="0 0 0  .1 0 0  0 .1 0  0 0 .1"/></asset>
  <worldbody>
    <body name="target" pos="0 0 .5">
      <geom type="mesh" mesh="tet" contype="0" conaffinity="0" group="1"/>
      <geom type="box" size=".02 .02 .02" pos=".2 0 0" group="1"/>
    </body>
    <geom name="plate" type="box" size=".1 .3 .005" pos=".4 0 1" group="1"/>
    <camera name="top" pos="0.1 0 2" xyaxes="1 0 0 0 1 0" fovy="45"/>
  </worldbody>
</mujoco>
"""


@pytest.fixture(scope="module")
def scene():
    model = mujoco.MjModel.from_xml_string(SCENE)
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    geoms = tuple(int(g) for g in np.flatnonzero(model.geom_bodyid == model.body("target").id))
    camera = dp.Camera.of(model, data, 0)
    visibility = dp.Visibility(model, data, camera, np.ones(6, np.uint8), geoms, dp.TargetShape(model, geoms))
    return visibility, dp.target_samples(model, geoms).world(data)


def test_target_in_the_open_is_seen_whole(scene):
    visibility, points = scene
    assert visibility.share(points, np.zeros(3)) == 1.0


def test_target_under_the_plate_is_hidden(scene):
    visibility, points = scene
    assert visibility.share(points, np.array([0.45, 0.0, 0.0])) == 0.0  # x = 0.45..0.67: all under it


def test_the_box_hidden_leaves_the_mesh_seen(scene):
    """Shifted by 0.25 m the box (x = 0.43..0.47) is under the plate and the tetrahedron (0.25..0.35)
    is not: the share is the tetrahedron's part of the silhouette (its 50 cm^2 triangle against the
    box's 16 cm^2 top and, off the camera's axis, one of its sides: 0.73 on the 24 x 24 grid, 0.68
    on the 48 x 48)."""
    visibility, points = scene
    for grid in (dp.GRID, dp.REFINE_GRID):
        assert 0.6 < visibility.share(points, np.array([0.25, 0.0, 0.0]), grid) < 0.76


def test_target_out_of_the_frame_is_unseen(scene):
    visibility, points = scene
    assert visibility.share(points, np.array([-0.8, 0.0, 0.0])) == 0.0  # x = -0.8..-0.58
