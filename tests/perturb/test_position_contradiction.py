"""A position contradiction shows the target somewhere else, in view (issue 12, point 5).

On an oracle episode of a task (LIBERO's first initial state, 128 px), every `EVERY` steps and in
both cameras, the case's own perturbation draws the target displaced (`Contradiction.edit`, as in
the env's render). Wherever the real target shows at least `MIN_VISIBLE_PX` pixels in that camera:

- the displaced target shows at least the same share of its silhouette as the real one (less
  `SHARE_TOLERANCE`): share = pixels seen in the frame / pixels of the target drawn alone in a
  frame `WIDE` times wider at the same pixel scale, so that a part cut off by the frame counts as
  unseen just like a part hidden behind the gripper or a fixture; where no place the
  contradiction may choose (`displacement.candidates`) shows that much, rendered (a close-up that
  fills the wrist view cannot move a quarter of the image and stay whole), at least the share of
  the best of them;
- the centres of the two silhouettes (drawn alone, in the wide frame) are at least
  `MIN_DISTANCE_PX` apart.

Figures: docs/perturbations.md, "Position contradiction". The default run takes two tasks; every
task with a target (38 of 40: libero_goal-00 and -07 have none, so no position case) is behind the
slow marker.
"""

from __future__ import annotations

import contextlib
import functools
from dataclasses import dataclass

import numpy as np
import pytest

from vpro_assets.benchmark import taxonomy as tx
from vpro_assets.libero.env import CAMERAS, libero_init_states, make_env
from vpro_assets.libero.tasks import get_task, load_tasks
from vpro_assets.perturb import displacement as dp
from vpro_assets.perturb import scene_edits as se
from vpro_assets.perturb.base import Episode
from vpro_assets.perturb.contradiction import Contradiction
from vpro_assets.perturb.entities import EntityIndex
from vpro_assets.perturb.rendering import render_geom_ids
from vpro_assets.rollout.policies.oracle.policy import OracleController

RES, WIDE = 128, 3
STEPS, EVERY = 160, 4
MIN_VISIBLE_PX = 50
SHARE_TOLERANCE = 0.05
MIN_DISTANCE_PX = 0.2 * RES  # the setting asks 0.25 of the image for the projected centre
DEFAULT_TASKS = ("libero_spatial-00", "libero_10-05")


@dataclass(frozen=True)
class Sample:
    task: str
    camera: str
    step: int
    real_px: int
    real_share: float
    shown_px: int
    shown_share: float
    distance_px: float
    best_share: float  # the most any candidate place shows, rendered (only where shown_share falls short)


def position_setting(camera: str) -> tx.Setting:
    return next(
        s
        for s in tx.settings_of("cross_view_contradiction")
        if s.param_dict["attribute"] == "position" and s.param_dict["camera"] == camera
    )


def alone(geoms: np.ndarray, offset: np.ndarray):
    """Scene edit: only the target, shifted by `offset`."""

    def edit(scn):
        keep = set(se.find(scn, geoms))
        se.remove(scn, [i for i in range(scn.ngeom) if i not in keep])
        se.transform(scn, se.find(scn, geoms), offset=offset)

    return edit


def silhouette(sim, camera: str, geoms: np.ndarray, offset: np.ndarray) -> np.ndarray:
    """The target drawn alone in a frame WIDE times wider at the same pixel scale (the frame is
    its middle RES x RES)."""
    model = sim.model._model
    cid = model.camera(camera).id
    fovy = float(model.cam_fovy[cid])
    model.cam_fovy[cid] = np.degrees(2 * np.arctan(WIDE * np.tan(np.radians(fovy) / 2)))
    try:
        return np.isin(render_geom_ids(sim, camera, WIDE * RES, WIDE * RES, edit=alone(geoms, offset)), geoms)
    finally:
        model.cam_fovy[cid] = fovy


def rendered_share(sim, camera: str, geoms: np.ndarray, offset: np.ndarray) -> tuple[int, np.ndarray]:
    """(pixels of the target drawn shifted by `offset` seen in the frame, its silhouette alone)."""

    def shifted(scn):
        se.transform(scn, se.find(scn, geoms), offset=offset)

    seen = int(np.isin(render_geom_ids(sim, camera, RES, RES, edit=shifted), geoms).sum())
    return seen, silhouette(sim, camera, geoms, offset)


def best_candidate_share(sim, pert: Contradiction) -> float:
    """The largest rendered share over every place the contradiction may choose: where none is
    as visible as the real target (a close-up filling the wrist view), the bar it can reach."""
    model, data = pert.index.model, sim.data._data
    camera = dp.Camera.of(model, data, model.camera(pert.camera).id)
    points = pert._samples.world(data)
    geoms = np.asarray(pert.target.geoms)
    best = 0.0
    for _, _, offset in dp.candidates(camera, points, pert.shifts(camera, points), pert.angle):
        seen, alone_px = rendered_share(sim, pert.camera, geoms, offset)
        best = max(best, seen / max(int(alone_px.sum()), 1))
    return best


def measure(sim, pert: Contradiction, task: str, step: int) -> Sample:
    camera, geoms = pert.camera, np.asarray(pert.target.geoms)
    real_px = int(np.isin(render_geom_ids(sim, camera, RES, RES), geoms).sum())
    shown_px = int(np.isin(render_geom_ids(sim, camera, RES, RES, edit=pert.edit), geoms).sum())
    assert pert.last_choice is not None
    real, shown = silhouette(sim, camera, geoms, np.zeros(3)), silhouette(sim, camera, geoms, pert.last_choice.offset)
    real_share, shown_share = real_px / max(int(real.sum()), 1), shown_px / max(int(shown.sum()), 1)
    short = real_px >= MIN_VISIBLE_PX and shown_share < real_share - SHARE_TOLERANCE
    best = best_candidate_share(sim, pert) if short else shown_share
    distance = (
        float(np.linalg.norm(np.argwhere(real).mean(axis=0) - np.argwhere(shown).mean(axis=0)))
        if real.any() and shown.any()
        else float("nan")
    )
    return Sample(
        task,
        camera,
        step,
        real_px,
        real_share,
        shown_px,
        shown_share,
        distance,
        best,
    )


@contextlib.contextmanager
def contradicted_env(key: str, cameras: tuple[str, ...]):
    """Task `key`'s env at its first initial state with one position contradiction per camera."""
    task = get_task(key)
    env = make_env(task, RES)
    try:
        env.seed(0)  # LIBERO places fixtures from numpy's global stream at reset (as the runner seeds it)
        env.reset()
        env.set_init_state(libero_init_states(task)[0])
        entities = EntityIndex(env.sim, task)
        perts = []
        for camera in cameras:
            setting = position_setting(camera)
            case_id = f"{key}/{setting.id.removeprefix('vpro/')}"
            pert = Contradiction(case_id, setting.param_dict, task)
            pert.reset(Episode(case_id, 0, task))
            pert.attach(env.sim, entities)
            perts.append(pert)
        yield env, OracleController(env, task), perts
    finally:
        env.close()


def episode_samples(key: str) -> list[Sample]:
    """Both cameras' samples along one oracle episode of task `key`."""
    with contradicted_env(key, CAMERAS) as (env, oracle, perts):
        samples = []
        for step in range(STEPS):
            if step % EVERY == 0:
                samples += [measure(env.sim, pert, key, step) for pert in perts]
            env.step(oracle.action())
        return samples


@functools.cache
def judged(key: str) -> tuple[Sample, ...]:
    """The samples of task `key` where the real target shows at least MIN_VISIBLE_PX pixels."""
    out = tuple(s for s in episode_samples(key) if s.real_px >= MIN_VISIBLE_PX)
    assert out, f"{key}: the real target never showed {MIN_VISIBLE_PX} pixels"
    return out


def check_distance(key: str) -> None:
    near = [s for s in judged(key) if not s.distance_px >= MIN_DISTANCE_PX]
    assert not near, f"displaced target too close to the real one: {near[:3]}"


def check_share(key: str) -> None:
    hidden = [s for s in judged(key) if s.shown_share < min(s.real_share, s.best_share) - SHARE_TOLERANCE]
    assert not hidden, f"displaced target less visible than the real one: {hidden[:3]}"


TARGET_TASKS = [t.key for t in load_tasks() if t.target is not None]


@pytest.mark.parametrize("key", DEFAULT_TASKS)
def test_displaced_target_is_elsewhere(key):
    check_distance(key)


@pytest.mark.parametrize("key", DEFAULT_TASKS)
def test_displaced_target_is_as_visible_as_the_real_one(key):
    check_share(key)


@pytest.mark.slow
@pytest.mark.parametrize("key", [k for k in TARGET_TASKS if k not in DEFAULT_TASKS])
def test_displaced_target_is_elsewhere_on_every_task(key):
    check_distance(key)


@pytest.mark.slow
@pytest.mark.parametrize("key", [k for k in TARGET_TASKS if k not in DEFAULT_TASKS])
def test_displaced_target_is_as_visible_on_every_task(key):
    check_share(key)


def test_share_scored_by_rays_matches_the_render_on_a_book_of_many_layers():
    """libero_10-05's wrist view at step 24: the book's pages put 3-10 layers of surface on a line
    of sight, which made version 3's point-area score read places up to 0.11 off their render. The
    ray-cast score (`Visibility.share`) of every candidate place and of the real one is within 0.07
    of the rendered share on the default grid (measured: at most 0.066, 25 of 33 within 0.03) and
    within 0.04 on the refining grid that decides between the best places (measured: 0.038)."""
    key, camera_name = "libero_10-05", "robot0_eye_in_hand"
    with contradicted_env(key, (camera_name,)) as (env, oracle, (pert,)):
        for _ in range(24):
            env.step(oracle.action())
        model, data = pert.index.model, env.sim.data._data
        camera = dp.Camera.of(model, data, model.camera(camera_name).id)
        visibility = dp.Visibility(model, data, camera, pert._geomgroup, pert.target.geoms, pert._shape)
        points, geoms = pert._samples.world(data), np.asarray(pert.target.geoms)
        places = [np.zeros(3)] + [
            o for _, _, o in dp.candidates(camera, points, pert.shifts(camera, points), pert.angle)
        ]
        errors = {}
        for offset in places:
            seen, alone_px = rendered_share(env.sim, camera_name, geoms, offset)
            rendered = seen / max(int(alone_px.sum()), 1)
            errors[tuple(np.round(offset, 3))] = (
                visibility.share(points, offset) - rendered,
                visibility.share(points, offset, dp.REFINE_GRID) - rendered,
            )
    assert len(places) >= 17
    assert max(abs(e) for e, _ in errors.values()) <= 0.07, errors
    assert max(abs(e) for _, e in errors.values()) <= 0.04, errors


def test_every_task_with_a_target_is_covered():
    assert len(TARGET_TASKS) == 38
    assert {t.key for t in load_tasks() if t.key not in TARGET_TASKS} == {"libero_goal-00", "libero_goal-07"}
