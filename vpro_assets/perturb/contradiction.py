"""Cross-View Contradiction: one camera draws an edited scene, the other the true one.

The edit is applied to the manipulated camera's `MjvScene` while robosuite renders it
(`rendering.RenderHook`), in the same render pass, so both views show the same time step and
the truthful view is byte-identical to a clean render. Edits by attribute:

- quantity (`duplicate_target`): a copy of the target drawn where the target stood at the first
  observation of the episode, shifted by `DUPLICATE_OFFSET_M` (at least 1.2 target widths) in a
  horizontal direction drawn per trial; it stays there while the real target is moved;
- existence (`hide_target`): the target's geoms are not drawn;
- position (`displace_target`): the target is drawn shifted horizontally so that it stays in the
  manipulated camera's view and is clearly elsewhere: its projected centre moved by at least
  `min_shift` of the image height (more, up to its own projected size, where that keeps it as
  visible), in view and not hidden behind the gripper or a fixture whenever the real target is
  (`displacement`: chosen per step, the direction drawn per trial first); it follows the real
  target;
- state (`other_state`): where the goal involves an articulated fixture, its moving parts (the
  joint the goal names, e.g. the top drawer) are drawn at the other end of their joint range
  (closed drawn open, off knob drawn on); otherwise the target is drawn upside down (rotated 180
  degrees about a horizontal axis through its centre). The stove's flame decal is not toggled.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import mujoco
import numpy as np

from vpro_assets.benchmark.taxonomy import CONTRADICTION_EDITS, CONTRADICTION_OFFSET_M, VIEWS
from vpro_assets.core.errors import InvalidParameterError, VProError
from vpro_assets.perturb import displacement as dp
from vpro_assets.perturb import scene_edits as se
from vpro_assets.perturb.base import Episode, Perturbation, param
from vpro_assets.perturb.entities import Entity, EntityIndex
from vpro_assets.perturb.rendering import render_context

DUPLICATE_OFFSET_M = CONTRADICTION_OFFSET_M
FLIP = np.diag([1.0, -1.0, -1.0])  # 180 degrees about the world x axis


class Contradiction(Perturbation):
    needs_extra_render = True

    def __init__(self, case_id: str, params: Mapping, task):
        self.case_id = case_id
        self.attribute = param(
            case_id,
            params,
            "attribute",
            str,
            lambda v: v in CONTRADICTION_EDITS,
            f"one of {', '.join(CONTRADICTION_EDITS)}",
        )
        edit = param(case_id, params, "edit", str)
        if edit != CONTRADICTION_EDITS[self.attribute]:
            raise InvalidParameterError(
                f"case {case_id}: edit={edit!r} does not match attribute "
                f"{self.attribute!r} (expected {CONTRADICTION_EDITS[self.attribute]!r})"
            )
        self.camera = param(case_id, params, "camera", str, lambda v: v in VIEWS.values())
        if self.attribute == "position":
            self.min_shift = float(
                param(
                    case_id, params, "min_shift", (int, float), lambda v: 0 < v < 0.5, "a fraction of the image height"
                )
            )
        self.use_articulation = self.attribute == "state" and bool(task.articulations)
        if task.target is None and not self.use_articulation:
            raise InvalidParameterError(
                f"case {case_id}: task {task.key} has no target (and no articulated fixture) to contradict"
            )
        self.direction = np.zeros(3)
        self.angle = 0.0
        self.entities: EntityIndex | None = None
        self.sim: Any = None  # robosuite's MjSim of the episode
        self._anchor: list[dict] | None = None
        self._scratch: mujoco.MjData | None = None
        self._joints: list[tuple[int, float, float]] = []
        self._samples: dp.Samples | None = None
        self._shape: dp.TargetShape | None = None
        self._geomgroup = np.ones(6, dtype=np.uint8)
        self._previous: int | None = None  # the direction the displaced target was drawn in last
        self.last_choice: dp.Choice | None = None  # where it was drawn last (read by tests)

    def reset(self, episode: Episode) -> None:
        self.angle = float(episode.rng("contradiction-direction").uniform(0, 2 * np.pi))
        self.direction = np.array([np.cos(self.angle), np.sin(self.angle), 0.0])
        self._anchor = None
        self._previous, self.last_choice = None, None

    def attach(self, sim, entities: EntityIndex) -> None:
        self.sim, self.entities = sim, entities
        self._anchor = None
        if self.use_articulation:
            self._scratch = mujoco.MjData(sim.model._model)
            self._joints = entities.articulation_joints()
        if self.attribute == "position":
            drawn = self.target.visual_geoms or self.target.geoms
            self._samples = dp.target_samples(entities.model, drawn)
            self._shape = dp.TargetShape(entities.model, drawn)
            self._geomgroup = render_context(sim).vopt.geomgroup.copy()  # what the cameras draw
            self._previous, self.last_choice = None, None

    @property
    def index(self) -> EntityIndex:
        """The entities of the attached sim (a contradiction draws nothing before `attach`)."""
        if self.entities is None:
            raise VProError(f"case {self.case_id}: contradiction used before attach()")
        return self.entities

    @property
    def target(self) -> Entity:
        target = self.index.target
        if target is None:  # __init__ refused a task without target unless it contradicts a fixture's state
            raise VProError(f"case {self.case_id}: the scene has no target to contradict")
        return target

    @property
    def edited_entity(self) -> Entity:
        """The entity whose drawing differs in the manipulated view."""
        if self.use_articulation:
            return (
                self.index.articulations[0]
                if len(self.index.articulations) == 1
                else Entity(
                    "articulations",
                    tuple(b for a in self.index.articulations for b in a.bodies),
                    tuple(g for a in self.index.articulations for g in a.geoms),
                    (),
                )
            )
        return self.target

    def render_edits(self):
        return {self.camera: self.edit}

    def apply(self, frames, step) -> None:
        # The frame was drawn edited by the env's own render pass; only record it.
        if self.camera in frames:
            step.note(self.camera, f"scene edit: {CONTRADICTION_EDITS[self.attribute]}")

    def _target_width(self) -> float:
        m = self.index.model
        return max(float(np.linalg.norm(m.geom_aabb[g][3:5])) * 2 for g in self.target.geoms)

    def edit(self, scn: mujoco.MjvScene) -> None:
        model = self.index.model
        if self.use_articulation:
            self._other_state(scn)
            return
        idx = se.find(scn, self.target.geoms)
        if not idx:
            return
        if self.attribute == "existence":
            se.remove(scn, idx)
        elif self.attribute == "position":
            se.transform(scn, idx, offset=self.displacement())
        elif self.attribute == "state":
            se.transform(scn, idx, rotation=FLIP, center=se.visual_center(scn, idx, model))
        else:
            if self._anchor is None:
                self._anchor = [se.snapshot(scn.geoms[i]) for i in idx]
            shift = max(DUPLICATE_OFFSET_M, 1.2 * self._target_width())
            se.append(scn, self._anchor, offset=self.direction * shift)

    def displacement(self) -> np.ndarray:
        """Where to draw the target in this step (`displacement.choose_offset`): at least
        `min_shift` of the image away, further (up to its own projected size) where it stays as
        visible as the real target."""
        if self._samples is None or self._shape is None:
            raise VProError(f"case {self.case_id}: position contradiction used before attach()")
        model, data = self.index.model, self.sim.data._data
        camera = dp.Camera.of(model, data, model.camera(self.camera).id)
        points = self._samples.world(data)
        visibility = dp.Visibility(model, data, camera, self._geomgroup, self.target.geoms, self._shape)
        choice = dp.choose_offset(visibility, points, self.shifts(camera, points), self.angle, self._previous)
        self._previous, self.last_choice = choice.direction, choice
        return choice.offset

    def shifts(self, camera: dp.Camera, points: np.ndarray) -> tuple[float, float]:
        """The shifts tried, of the image height: the target's own projected size (at most
        `MAX_SHIFT`), then `min_shift`."""
        return max(self.min_shift, min(dp.projected_size(camera, points), dp.MAX_SHIFT)), self.min_shift

    def _other_state(self, scn: mujoco.MjvScene) -> None:
        model, data, scratch = self.index.model, self.sim.data._data, self._scratch
        if scratch is None:
            raise VProError(f"case {self.case_id}: state contradiction without an articulated fixture")
        scratch.qpos[:] = data.qpos
        for j, lo, hi in self._joints:
            adr = model.jnt_qposadr[j]
            q = data.qpos[adr]
            scratch.qpos[adr] = hi if (q - lo) < (hi - q) else lo
        mujoco.mj_kinematics(model, scratch)
        geoms = [g for ent in self.index.articulations for g in ent.geoms]
        se.set_poses(scn, se.find(scn, geoms), scratch.geom_xpos, scratch.geom_xmat)
