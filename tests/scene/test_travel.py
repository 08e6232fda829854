"""A part set open is taken to have come from closed: the objects its travel passes through start out
of it, in their own LIBERO init region (`scene.travel`, precondition receptacle openness travel1).

libero_10-09's microwave door set 75% open (-0.976 rad) passes through where LIBERO puts the
yellow and white mug in 9 of 10 trials; the v2 build set the door there at once and settled, which
moved the mug 11 cm (trial 3), knocked it over (trials 8, 9) or left it against the microwave.
"""

from __future__ import annotations

import math

import mujoco
import numpy as np
import pytest
from conftest import OracleScene, scene_variant, start_trial, variant_env

from vpro_assets.benchmark.catalog import find_case, load_catalog
from vpro_assets.core import paths
from vpro_assets.core.mjgeom import subtree

OPEN75 = "libero_10-09/task_precondition_variation/receptacle_openness-v1-open75"
MUG, DOOR, MICROWAVE = "white_yellow_mug_1", "microwave_1_microjoint", "microwave_1"
MUG_REGION = (-0.025, -0.025, 0.025, 0.025)  # LIBERO's white_yellow_mug_init_region (table origin at 0, 0)
UPRIGHT_DEG = 5.0  # LIBERO stands the mug upright; the knocked-over v2 starts were 83 degrees off


def _touching(model, data, a: set[int], b: set[int]) -> bool:
    """Whether bodies `a` and `b` are in contact: MuJoCo reports a pair only within its margin (1 mm
    on the microwave's door), and with no gap set every reported contact pushes."""
    for i in range(data.ncon):
        c = data.contact[i]
        b1, b2 = int(model.geom_bodyid[c.geom1]), int(model.geom_bodyid[c.geom2])
        if (b1 in a and b2 in b) or (b2 in a and b1 in b):
            return True
    return False


def _bodies(model, name: str) -> set[int]:
    return set(subtree(model, mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, name)))


def test_a_part_set_open_comes_from_its_closed_end_and_table_objects_keep_their_libero_regions():
    ctx, v = scene_variant(OPEN75)
    (joint,) = v.joints
    assert joint.low == joint.high == -0.97625  # 75% of the way from -0.005 to LIBERO's Open, -1.3
    assert joint.travel_from == -0.005  # the edge of LIBERO's closed range, [-0.005, 0]
    regions = {k.instance: k.box for k in v.keep_clear}
    assert regions == {MUG: MUG_REGION, "porcelain_mug_1": (-0.125, -0.275, -0.075, -0.225)}


def test_the_mug_in_the_door_travel_starts_clear_of_it_in_its_own_region(tmp_path):
    """Trials 3 and 8 (the v2 starts that moved the mug 11 cm and knocked it over): the mug stands in
    its LIBERO region, upright, and the door swung from closed to its set value in 1 mrad steps
    never touches it. Trial 4 (the one LIBERO spot the travel leaves clear) keeps LIBERO's spot."""
    from vpro_assets.scene import sim

    with variant_env(OPEN75, tmp_path) as (ctx, v, env):
        raw = sim.raw(env)
        model, data = raw.sim.model._model, raw.sim.data._data
        mug = _bodies(model, raw.objects_dict[MUG].root_body)
        door = set(subtree(model, int(model.jnt_bodyid[raw.sim.model.joint_name2id(DOOR)])))
        for trial in (3, 8, 4):
            start_trial(env, ctx, v, trial)
            qpos, _ = sim.free_object_state(env)[MUG]
            libero = ctx.base.layouts[trial][MUG]["pos"]
            x0, y0, x1, y1 = MUG_REGION
            assert x0 <= qpos[0] <= x1 and y0 <= qpos[1] <= y1, (trial, qpos[:2])
            up = data.xmat[min(mug)].reshape(3, 3)[:, 2]
            assert math.degrees(math.acos(min(1.0, up[2]))) < UPRIGHT_DEG, (trial, up)
            if trial == 4:
                assert np.linalg.norm(qpos[:2] - libero[:2]) < 0.001
            else:
                assert np.linalg.norm(qpos[:2] - libero[:2]) > 0.01
            hinge = float(data.qpos[model.jnt_qposadr[raw.sim.model.joint_name2id(DOOR)]])
            for q in np.arange(-0.005, hinge, -0.001):
                raw.sim.data.set_joint_qpos(DOOR, q)
                mujoco.mj_forward(model, data)
                assert not _touching(model, data, door, mug), (trial, q)


def test_a_start_that_settling_tipped_or_pushed_against_the_microwave_is_refused(tmp_path):
    from vpro_assets.scene import sim, travel

    with variant_env(OPEN75, tmp_path) as (ctx, v, env):
        start_trial(env, ctx, v, 4)
        placed = travel.poses(env, v)
        assert travel.disturbed(env, v, placed) == []
        raw = sim.raw(env)
        joint = raw.objects_dict[MUG].joints[-1]
        tipped = placed[MUG].copy()
        tipped[3:] = [math.cos(math.pi / 4), math.sin(math.pi / 4), 0.0, 0.0]  # 90 degrees about x
        raw.sim.data.set_joint_qpos(joint, tipped)
        raw.sim.forward()
        (problem,) = travel.disturbed(env, v, placed)
        assert problem.startswith(f"{MUG} moved 0.0 mm and tilted 9") and problem.endswith("degrees while settling")
        against = placed[MUG].copy()
        against[:2] = (-0.013, 0.016)  # LIBERO's spot of trial 5, where the door panel cuts 20 mm into it
        raw.sim.data.set_joint_qpos(joint, against)
        raw.sim.forward()
        assert f"{MUG} touches the fixture of a part the variant sets" in travel.disturbed(env, v, placed)


@pytest.fixture(scope="module")
def open75_built(tmp_path_factory):
    """The case built into its own out/ (VPRO_OUT) by this tree, as `vpro build` makes it."""
    from vpro_assets.scene import build

    out = tmp_path_factory.mktemp("vpro-out-open75")
    with pytest.MonkeyPatch.context() as mp:
        mp.setenv("VPRO_OUT", str(out))
        case = find_case(load_catalog(paths.catalog_path()), OPEN75)
        result = build.build_case(case)
        assert result.status == "built", result.error
        # Built again, the same bytes the committed catalog records.
        assert result.files == {path.rsplit("/", 1)[-1]: digest for path, digest in case["artifacts"].items()}
        yield out


def test_every_start_of_the_built_open75_case_has_the_mug_upright_at_rest_and_off_the_microwave(
    open75_built, monkeypatch
):
    """The 10 frozen initial states as a policy gets them (the rollout's env of the built case, after
    LIBERO's wait steps): the door 75% open; the mug in its LIBERO region, upright, at rest, and
    touching neither the door nor the rest of the microwave."""
    monkeypatch.setenv("VPRO_OUT", str(open75_built))
    for trial in range(10):
        s = OracleScene(OPEN75, trial)
        try:
            model, data = s.cenv.sim.model._model, s.cenv.sim.data._data
            mug = _bodies(model, f"{MUG}_main")
            root = model.body_rootid[mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, f"{MICROWAVE}_main")]
            microwave = {b for b in range(model.nbody) if model.body_rootid[b] == root}  # door included
            hinge = float(data.qpos[model.jnt_qposadr[mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, DOOR)]])
            assert abs(hinge - -0.97625) < 0.01, (trial, hinge)
            pos, up = data.xpos[min(mug)], data.xmat[min(mug)].reshape(3, 3)[:, 2]
            x0, y0, x1, y1 = MUG_REGION
            assert x0 - 0.002 <= pos[0] <= x1 + 0.002 and y0 - 0.002 <= pos[1] <= y1 + 0.002, (trial, pos)
            assert math.degrees(math.acos(min(1.0, up[2]))) < UPRIGHT_DEG, (trial, up)
            mujoco.mj_forward(model, data)
            assert not _touching(model, data, mug, microwave), trial
            before = pos.copy()
            s.wait(20)  # one more second of zero actions: it stays where it is
            assert np.linalg.norm(data.xpos[min(mug)] - before) < 0.002, trial
            speed = np.linalg.norm(data.cvel[min(mug)][3:])
            assert speed < 0.01, (trial, speed)
        finally:
            s.cenv.close()
