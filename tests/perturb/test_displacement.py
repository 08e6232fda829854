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


def test_geoms_beyond_a_distance_are_set_aside_only_where_no_nearer_hit_changes(scene):
    """`beyond_set_aside`: the plate (its bounding sphere 0.73-1.36 m from the camera) is cast
    against by rays that need hits nearer than 0.99 m or more, not by those that stop before 0.7;
    a hit nearer than the distance is the full scene's, any other is none or past the distance;
    the model's groups are restored."""
    visibility, _ = scene
    model, data, camera = visibility.model, visibility.data, visibility.camera
    groups = model.geom_group.copy()
    xy = np.stack(np.meshgrid(np.linspace(0.05, 0.95, 12), np.linspace(0.05, 0.95, 12)), axis=-1).reshape(-1, 2)
    units = camera.rays(xy)
    full = dp.every_geom_multi_ray(model, data, camera.position, units, visibility.geomgroup, -1)
    plate = model.geom("plate").id
    assert (full[0] == plate).any() and (full[0] == 0).any()  # some rays meet the plate, some the target
    for within in (0.5, 0.7, 0.99, 1.2, 1.6, np.inf):
        with dp.beyond_set_aside(model, data, camera.position, visibility.geomgroup, within) as group:
            geom, dist = dp.every_geom_multi_ray(model, data, camera.position, units, group, -1)
        near = (full[0] >= 0) & (full[1] < within)
        assert np.array_equal(geom[near], full[0][near]) and np.array_equal(dist[near], full[1][near])
        assert np.all((geom[~near] < 0) | (dist[~near] >= within))
        assert ((geom == plate).any()) == (within > 0.73)
        assert np.array_equal(model.geom_group, groups)


def test_places_chosen_with_far_geoms_set_aside_are_the_full_scenes(monkeypatch):
    """The scene's rays set aside the geoms beyond the target's farthest point (`Visibility._clear`;
    on agentview the robot's 33k-face pedestal behind the bowl took most of their time): the place
    chosen, its share and the real target's share are identical, bit for bit, to those with every
    geom cast against, on both cameras along an oracle episode of libero_spatial-02 (the setting's
    benchmark task), steps 0-44: the bowl settling, the approach and the grasp."""
    from vpro_assets.libero.env import CAMERAS, libero_init_states, make_env
    from vpro_assets.libero.tasks import get_task
    from vpro_assets.perturb.entities import EntityIndex
    from vpro_assets.rollout.policies.oracle.policy import OracleController

    task = get_task("libero_spatial-02")
    env = make_env(task, render=False)
    try:
        env.seed(0)
        env.reset()
        env.set_init_state(libero_init_states(task)[0])
        entities = EntityIndex(env.sim, task)
        model, data = entities.model, env.sim.data._data
        drawn = entities.target.visual_geoms or entities.target.geoms
        samples, shape = dp.target_samples(model, drawn), dp.TargetShape(model, drawn)
        geomgroup = np.array([0, 1, 1, 0, 0, 0], np.uint8)  # the groups LIBERO's cameras draw
        set_aside: list[int] = []
        beyond = dp.beyond

        def far(model, data, origin, within):
            out = beyond(model, data, origin, within)
            set_aside.append(int(out.sum()))
            return out

        previous: dict[tuple[str, bool], int | None] = {}
        oracle, compared = OracleController(env, task), 0
        for step in range(45):
            if step % 3 == 0:
                points = samples.world(data)
                for name in CAMERAS:
                    camera = dp.Camera.of(model, data, model.camera(name).id)
                    shifts = (max(0.25, min(dp.projected_size(camera, points), dp.MAX_SHIFT)), 0.25)
                    choices = []
                    for cull in (True, False):
                        monkeypatch.setattr(
                            dp, "beyond", far if cull else lambda m, d, o, w: np.zeros(m.ngeom, dtype=bool)
                        )
                        visibility = dp.Visibility(model, data, camera, geomgroup, entities.target.geoms, shape)
                        choice = dp.choose_offset(visibility, points, shifts, 0.7, previous.get((name, cull)))
                        previous[(name, cull)] = choice.direction
                        choices.append(choice)
                    kept, every = choices
                    assert np.array_equal(kept.offset, every.offset), (name, step, kept, every)
                    assert kept.direction == every.direction and kept.share == every.share
                    assert kept.real_share == every.real_share
                    compared += 1
            env.step(oracle.action())
    finally:
        env.close()
    assert compared == 30 and min(set_aside) > 0  # every call left something out
