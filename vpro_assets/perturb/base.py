"""What every observation perturbation implements, and what it is given at each step.

A `Perturbation` is built once per case from the setting's parameters (validated there, with the
case id and the bad value in the error), reset at the start of every episode with the trial's
seeds, and then asked once per observation to transform the raw frames of the cameras. It keeps
its state in itself, clears it in `reset`, draws randomness only from `Episode.rng`, and never
touches the simulator's physical state: it reads the sim, and scene edits only change what one
camera draws (`render_edits`).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, field

import numpy as np

from vpro_assets.core.errors import InvalidParameterError
from vpro_assets.core.seeding import rng
from vpro_assets.libero.task_record import TaskRecord
from vpro_assets.perturb.capture import Capture, CaptureRenderer
from vpro_assets.perturb.entities import EntityIndex
from vpro_assets.perturb.occluders import windows_may_meet
from vpro_assets.perturb.phases import PhaseState
from vpro_assets.perturb.rendering import SceneEdit, render_context, render_geom_ids


@dataclass(frozen=True)
class Episode:
    case_id: str
    trial: int
    task: TaskRecord

    def rng(self, component: str) -> np.random.Generator:
        return rng(self.case_id, self.trial, component)


class MaskSource:
    """Semantic masks of one observation, rendered on demand and cached per camera.

    Where the env's render of a camera was captured (`captures`, camera -> `capture.Capture`,
    holding `captured_labels`), a mask of those labels is drawn from the capture: only the
    entities and what can cover them, in the exact state of the frame. Otherwise (the first
    observation of an observer-driven episode, another frame size, a label not captured) a
    full-scene segmentation pass is rendered, the reference path. Either is rendered only the
    first time a camera's mask is asked for in a step, so perturbations that are off in a step
    (outside their schedule) cost nothing.
    """

    def __init__(
        self,
        sim,
        entities: EntityIndex,
        shapes: Mapping[str, tuple[int, int]],
        captures: Mapping[str, Capture] | None = None,
        renderer: CaptureRenderer | None = None,
        captured_labels: frozenset[str] = frozenset(),
    ):
        self.sim, self.entities, self.shapes = sim, entities, shapes
        self.captures = dict(captures or {})
        self.renderer = renderer
        self.captured_labels = captured_labels
        self._geom_ids: dict[str, np.ndarray] = {}
        self._captured_ids: dict[str, np.ndarray] = {}
        self._masks: dict[tuple[str, str], np.ndarray] = {}
        self.renders = 0  # passes rendered (either kind)
        self.reference_renders = 0  # full-scene segmentation passes among them

    def geom_ids(self, camera: str) -> np.ndarray:
        """Full-scene segmentation of `camera` (the reference path)."""
        if camera not in self._geom_ids:
            h, w = self.shapes[camera]
            self._geom_ids[camera] = render_geom_ids(self.sim, camera, w, h)
            self.renders += 1
            self.reference_renders += 1
        return self._geom_ids[camera]

    def _ids_for(self, camera: str, label: str) -> np.ndarray:
        cap = self.captures.get(camera)
        usable = (
            cap is not None
            and self.renderer is not None
            and label in self.captured_labels
            and (cap.height, cap.width) == tuple(self.shapes[camera])
        )
        if not usable or cap is None or self.renderer is None:  # (the last two for the type checker)
            return self.geom_ids(camera)
        if camera not in self._captured_ids:
            self._captured_ids[camera] = self.renderer.draw_ids(render_context(self.sim), cap)
            self.renders += 1
        return self._captured_ids[camera]

    def may_meet(self, camera: str, a: str, b: str, radius: int) -> bool:
        """False only when the captured windows of entities `a` and `b` prove that no pixel lies
        within `radius` of both (their contact region is empty); True when unknown."""
        cap = self.captures.get(camera)
        if (
            cap is None
            or cap.label_windows is None
            or a not in cap.label_windows
            or b not in cap.label_windows
            or (cap.height, cap.width) != tuple(self.shapes[camera])
        ):
            return True
        return windows_may_meet(cap.label_windows[a], cap.label_windows[b], radius)

    def mask(self, camera: str, label: str) -> np.ndarray:
        """Boolean raw-frame mask of `label` (target, receptacle, gripper) in `camera`."""
        key = (camera, label)
        if key not in self._masks:
            entity = self.entities.entity(label)
            if entity is None:
                self._masks[key] = np.zeros(self.shapes[camera], dtype=bool)
            else:
                lut = np.zeros(self.entities.model.ngeom + 1, dtype=bool)
                lut[list(entity.geoms)] = True
                self._masks[key] = lut[self._ids_for(camera, label)]  # -1 (background) indexes the False at the end
        return self._masks[key]


@dataclass
class Step:
    """Everything a perturbation may read for one observation."""

    index: int  # 0 for the observation at reset, then one per env step
    phase: PhaseState
    clean: Mapping[str, np.ndarray]  # the rendered raw frames of this step, never to be modified
    masks: MaskSource
    predicted: Mapping[str, np.ndarray] | None = None
    notes: dict[str, list[str]] = field(default_factory=dict)  # camera -> what was applied

    def note(self, camera: str, what: str) -> None:
        self.notes.setdefault(camera, []).append(what)


class Perturbation:
    """Base class: the identity perturbation."""

    setting_id: str = ""
    #: True where the setting needs a segmentation render or per-camera scene edits.
    needs_extra_render: bool = False
    #: Entities (target, receptacle, gripper) whose masks the setting may ask for.
    mask_labels: tuple[str, ...] = ()

    def reset(self, episode: Episode) -> None:
        """Start an episode: clear all state, draw the trial's seeds."""

    def attach(self, sim, entities: EntityIndex) -> None:
        """Called after every (hard) reset of the sim, before its first observation is rendered."""

    def render_edits(self) -> Mapping[str, SceneEdit]:
        """Camera name -> scene edit applied while that camera renders."""
        return {}

    def cameras(self, cameras: tuple[str, ...]) -> tuple[str, ...]:
        """The cameras the policy receives (a view may be removed)."""
        return cameras

    def apply(self, frames: dict[str, np.ndarray], step: Step) -> None:
        """Replace (or delete) entries of `frames`, camera -> raw frame; never modify arrays in place."""


Builder = Callable[[str, Mapping, TaskRecord], Perturbation]


def param(case_id: str, params: Mapping, name: str, kinds, check: Callable | None = None, what: str = ""):
    """A validated parameter of a case: present, of the right type, and passing `check`."""
    if name not in params:
        raise InvalidParameterError(f"case {case_id}: missing parameter {name!r}")
    value = params[name]
    allowed = kinds if isinstance(kinds, tuple) else (kinds,)
    if not isinstance(value, allowed) or (isinstance(value, bool) and bool not in allowed):
        raise InvalidParameterError(f"case {case_id}: parameter {name}={value!r} has the wrong type")
    if check is not None and not check(value):
        raise InvalidParameterError(
            f"case {case_id}: parameter {name}={value!r} is invalid{': ' + what if what else ''}"
        )
    return value
