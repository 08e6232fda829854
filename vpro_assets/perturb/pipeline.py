"""The per-view observation pipeline of one case, and the registry of perturbation families.

`build_pipeline(case, task)` turns a catalog case (or a setting) into an `ObservationPipeline`:
a list of perturbations applied, in order, to the raw (bottom-up) frames of each camera after
rendering and before any policy adapter. Per episode: `reset(trial, sim)` (seeds from the case id
and trial, clears all state, attaches to the freshly built sim), then `observe(raw_obs, sim)`
once per observation. The phase tracker runs on every observation, whatever the setting, so
each episode can log its phase timeline.
"""

from __future__ import annotations

import logging
from collections.abc import Mapping, Sequence

import numpy as np

from vpro_assets.benchmark import taxonomy as tx
from vpro_assets.core.errors import InvalidParameterError, VProError
from vpro_assets.libero.names import CAMERAS
from vpro_assets.libero.task_record import TaskRecord
from vpro_assets.perturb.base import Builder, Episode, MaskSource, Perturbation, Step
from vpro_assets.perturb.capture import CaptureRenderer
from vpro_assets.perturb.contradiction import Contradiction
from vpro_assets.perturb.corruption import Corruption
from vpro_assets.perturb.entities import EntityIndex
from vpro_assets.perturb.masking import CueMasking, EntityMasking
from vpro_assets.perturb.phases import PhaseTracker
from vpro_assets.perturb.prediction import PredictionFeedback
from vpro_assets.perturb.rendering import RenderHook
from vpro_assets.perturb.staleness import Staleness
from vpro_assets.perturb.views import ViewUnavailability

log = logging.getLogger(__name__)

FAMILIES: dict[str, Builder] = {}


def register(category: str, builder: Builder) -> None:
    """Register the builder of an observation-level category; a second registration is an error."""
    if category in FAMILIES:
        raise VProError(f"perturbation family for category {category!r} is already registered")
    tx.category(category)  # unknown categories raise
    FAMILIES[category] = builder


for _cat, _builder in (
    ("target_object_masking", EntityMasking),
    ("target_receptacle_masking", EntityMasking),
    ("interaction_cue_masking", CueMasking),
    ("temporary_observation_corruption", Corruption),
    ("view_unavailability", ViewUnavailability),
    ("camera_staleness", Staleness),
    ("cross_view_contradiction", Contradiction),
    ("prediction_reality_divergence", PredictionFeedback),
):
    register(_cat, _builder)


def image_key(camera: str) -> str:
    return f"{camera}_image"


class ObservationPipeline:
    """Perturbations of one case, applied per camera to every observation of an episode."""

    def __init__(
        self,
        case_id: str,
        task: TaskRecord,
        perturbations: Sequence[Perturbation],
        cameras: Sequence[str] = CAMERAS,
        setting_id: str | None = None,
    ):
        self.case_id, self.task, self.setting_id = case_id, task, setting_id
        self.perturbations = tuple(perturbations)
        self.all_cameras = tuple(cameras)
        edits = {}
        for p in self.perturbations:
            for cam, edit in p.render_edits().items():
                if cam in edits:
                    raise VProError(f"case {case_id}: two scene edits for camera {cam}")
                edits[cam] = edit
        self.mask_labels = frozenset(label for p in self.perturbations for label in p.mask_labels)
        #: Masks from the scene the env drew (`capture`); False: full-scene segmentation renders only.
        self.capture_masks = True
        self.hook = RenderHook(edits) if edits or self.mask_labels else None
        self.capture_renderer: CaptureRenderer | None = None
        self.episode: Episode | None = None
        self.entities: EntityIndex | None = None
        self.tracker: PhaseTracker | None = None
        self.step_index = -1
        self.last_notes: dict[str, list[str]] = {}
        self.mask_renders = 0  # mask passes rendered this episode
        self.reference_mask_renders = 0  # of which full-scene segmentation passes

    @property
    def needs_extra_render(self) -> bool:
        return any(p.needs_extra_render for p in self.perturbations)

    @property
    def available_cameras(self) -> tuple[str, ...]:
        cams = self.all_cameras
        for p in self.perturbations:
            cams = p.cameras(cams)
        return cams

    def reset(self, trial: int, sim) -> None:
        """Start an episode of `trial` on `sim` (call after the env's reset, before its first obs)."""
        if not isinstance(trial, (int, np.integer)) or trial < 0:
            raise InvalidParameterError(f"case {self.case_id}: trial must be a non-negative integer, got {trial!r}")
        self.episode = Episode(self.case_id, int(trial), self.task)
        self.step_index = -1
        self.mask_renders = 0
        self.reference_mask_renders = 0
        for p in self.perturbations:
            p.reset(self.episode)
        self.attach(sim)

    def attach(self, sim) -> None:
        """Bind to a (re)built sim: entity ids, phase tracker, per-camera render hooks."""
        self.entities = EntityIndex(sim, self.task)
        if self.tracker is None:
            self.tracker = PhaseTracker(self.entities)
        self.tracker.reset(self.entities)
        for p in self.perturbations:
            p.attach(sim, self.entities)
        if self.hook is not None:
            if self.mask_labels and self.capture_masks:
                groups = {
                    label: np.array(e.geoms, dtype=np.int64)
                    for label in sorted(self.mask_labels)
                    if (e := self.entities.entity(label)) is not None
                }
                self.hook.capture_groups = groups
                self.hook.capture_geoms = np.unique(np.concatenate(list(groups.values()) or [np.zeros(0, np.int64)]))
                self.capture_renderer = CaptureRenderer(sim.model._model)
            else:
                self.hook.capture_geoms, self.capture_renderer = None, None
            self.hook.install(sim)

    def detach(self) -> None:
        if self.hook is not None:
            self.hook.uninstall()

    def observe(
        self, raw_obs: Mapping[str, np.ndarray], sim, predicted_frames: Mapping[str, np.ndarray] | None = None
    ) -> dict:
        """The observation the policy receives for the raw observation of the current step."""
        if self.episode is None or self.tracker is None or self.entities is None:
            raise VProError(f"case {self.case_id}: call reset(trial, sim) before observe()")
        self.step_index += 1
        phase = self.tracker.update(sim)
        clean = {cam: raw_obs[image_key(cam)] for cam in self.all_cameras if image_key(cam) in raw_obs}
        shapes = {cam: (frame.shape[0], frame.shape[1]) for cam, frame in clean.items()}
        captures = self.hook.take() if self.hook is not None else {}
        masks = MaskSource(sim, self.entities, shapes, captures, self.capture_renderer, self.mask_labels)
        step = Step(self.step_index, phase, clean, masks, predicted_frames)
        frames = dict(clean)
        for p in self.perturbations:
            p.apply(frames, step)
        self.mask_renders += masks.renders
        self.reference_mask_renders += masks.reference_renders
        self.last_notes = step.notes
        obs = dict(raw_obs)
        for cam in clean:
            if cam in frames:
                frame = frames[cam]
                # Never hand out a buffer the pipeline keeps (stale or predicted frames).
                obs[image_key(cam)] = frame if frame is clean[cam] or step.notes.get(cam) is None else frame.copy()
            else:
                del obs[image_key(cam)]
        return obs

    def info(self) -> dict:
        """What happened at the last observation (for the episode log)."""
        return {
            "step": self.step_index,
            "phase": self.tracker.phase if self.tracker else None,
            "applied": self.last_notes,
            "cameras": list(self.available_cameras),
        }

    def phase_timeline(self) -> dict:
        return self.tracker.timeline() if self.tracker else {}


def build_pipeline(case: Mapping | str, task: TaskRecord, cameras: Sequence[str] = CAMERAS) -> ObservationPipeline:
    """The pipeline of a catalog case (a dict with `id`, `setting`, `params`; `setting` None or a
    Normal case gives the identity pipeline), or of a setting id (case id = setting id)."""
    if isinstance(case, str):
        setting = tx.setting(case)
        case = {"id": case, "setting": setting.id, "params": setting.param_dict}
    case_id = case.get("id") or "<case>"
    setting_id = case.get("setting")
    if not setting_id:
        return ObservationPipeline(case_id, task, (), cameras)
    setting = tx.setting(setting_id)
    cat = tx.category(setting.category)
    if cat.level != tx.OBSERVATION:
        raise VProError(
            f"case {case_id}: setting {setting_id} changes the scene ({cat.title}); it has no "
            "observation perturbation (build its scene instead)"
        )
    builder = FAMILIES.get(setting.category)
    if builder is None:
        raise VProError(f"case {case_id}: no perturbation family registered for {setting.category}")
    params = case.get("params", setting.param_dict)
    return ObservationPipeline(case_id, task, (builder(case_id, params, task),), cameras, setting_id)
