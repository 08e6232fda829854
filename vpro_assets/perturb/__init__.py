"""Closed-loop observation perturbations: the 74 observation-level settings of LIBERO-VPro.

Layout (one concept per module, in pipeline order):
- `rendering`    one camera frame from robosuite's render context, optionally with a scene edit;
                 `RenderHook` routes robosuite's own camera renders through it
- `occluders`    the geoms that can cover an entity in a camera, and the pixel window it can occupy
- `capture`      the entities' part of the scene the env drew, drawn again as a segmentation mask
- `entities`     target, receptacle, gripper and articulated parts as MuJoCo ids of one sim
- `phases`       manipulation phase tracker (approach, grasp, transport, pre_placement, placed)
- `schedules`    when a perturbation is on (mask schedules, corruption bursts, stale indices)
- `imageops`     pure image operations (partial masks, contact regions, occluders, noise)
- `base`         the `Perturbation` interface, per-step context, on-demand semantic masks
- `masking`, `corruption`, `views`, `staleness`, `contradiction` (+ `scene_edits`),
  `prediction`   one module per family of settings
- `pipeline`     `ObservationPipeline` and the registry category -> family; `build_pipeline`
- `wrapper`      `PerturbedEnv`, a Gymnasium-style wrapper that owns reset and step
- `observer`     `wrap_case_env`: the same pipeline as an observer of an env driven elsewhere
                 (the interface `vpro_assets.rollout.case_env` calls)

API for the rollout layer:

    from vpro_assets.perturb import PerturbedEnv
    env = PerturbedEnv(make_env(task, 256), case, task)          # case: catalog dict or setting id
    obs = env.reset(trial=k, init_state=states[k])               # step 0, already perturbed
    obs, r, done, info = env.step(action, predicted_frames=None)  # info["vpro"]: step, phase, applied
    env.available_cameras                                         # cameras the policy receives
    env.phase_timeline()                                          # phase changes and onsets

or, without the wrapper, `build_pipeline(case, task)` then `pipeline.reset(trial, sim)` after each env
reset and `pipeline.observe(raw_obs, sim, predicted_frames)` per observation.

Guarantees: frames are perturbed in the raw (bottom-up) orientation before any adapter; every
random draw comes from `seeding.rng(case_id, trial, component)`; the physics is never touched
(masks are segmentation renders of the entities and what can cover them, captured from the
scene the env drew; contradictions edit one camera's `MjvScene` only);
staleness, view unavailability, corruption and prediction feedback render nothing extra.
"""

from vpro_assets.perturb.observer import CaseObserver, wrap_case_env
from vpro_assets.perturb.pipeline import FAMILIES, ObservationPipeline, build_pipeline, register
from vpro_assets.perturb.prediction import EchoPredictor, FramePredictingPolicy, PolicyOutput
from vpro_assets.perturb.wrapper import PerturbedEnv

__all__ = [
    "CaseObserver",
    "wrap_case_env",
    "FAMILIES",
    "ObservationPipeline",
    "build_pipeline",
    "register",
    "PerturbedEnv",
    "PolicyOutput",
    "FramePredictingPolicy",
    "EchoPredictor",
]
