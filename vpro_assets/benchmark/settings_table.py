"""The 96 settings as data: the parameter choices the paper leaves open (documented in
docs/taxonomy.md) and one builder per family of settings, in taxonomy order."""

from __future__ import annotations

import dataclasses

from vpro_assets.benchmark.taxonomy_types import PHASES, VIEWS, JSONScalar, Setting

# ---- parameter choices the paper leaves open -----------------------------------------------
MASK_RATIOS = (25, 50, 75, 100)  # percent of the entity's visible pixels
MASK_SCHEDULES = {
    "always": "every step",
    "before_grasp": "from the first step until grasp onset; visible afterwards",
    "after_grasp": "from grasp onset to the end; visible before",
    "around_placement": "during pre-placement and after placement onset (the placement transition)",
}
OCCLUDER_GRAY = 128  # flat mid-grey occluder, uint8
CONTACT_DILATION_PX = 6  # contact regions grown by this many pixels at 256 px (scaled with resolution)
CORRUPTION_FREQUENCIES = {"low": 0.02, "medium": 0.05, "high": 0.10}  # burst onset probability per step
CORRUPTION_BURST_STEPS = 5  # a burst covers 5 control steps (0.25 s)
NOISE_STD = 64.0  # additive Gaussian noise, uint8 units (0.25 of full scale), clipped
STALENESS_DELAYS = (5, 10, 20)  # control steps: 0.25 s, 0.5 s, 1 s (level 1 = one openpi replanning cycle)
FREEZE_STEP = 30  # the view keeps showing the frame of this step from then on
REPLAY_START, REPLAY_WINDOW = 40, 20  # from step 40 the view loops over its frames 20..39
CONTRADICTION_OFFSET_M = 0.10  # quantity: the duplicate drawn at least 10 cm from the target
# Position (version 4): the target drawn with its projected centre at least this share of the image
# height from the real one (32 px at 128), in view (version 1 shifted it 10 cm in the world, out
# of the wrist camera's view on most steps; version 3 scores candidate places by the image area
# their visible parts cover, where version 2 left out the off-axis widening; version 4 draws the
# scored points evenly over the surface and scores the best places again from more points before
# choosing among them: docs/perturbations.md).
CONTRADICTION_MIN_SHIFT = 0.25
CONTRADICTION_VERSIONS = {"quantity": 1, "existence": 1, "position": 4, "state": 1}
# Cross-view contradiction: the scene edit that makes each attribute disagree between the views.
CONTRADICTION_EDITS = {
    "quantity": "duplicate_target",
    "existence": "hide_target",
    "position": "displace_target",
    "state": "other_state",
}
GEOMETRY_SEVERITY = {  # deformation magnitude per severity level 1, 2, 3
    "taper": ("top_scale", (0.85, 0.70, 0.55)),  # cross-section scale at the top vs bottom
    "multipeak": ("peak_amplitude", (0.06, 0.12, 0.18)),  # bump height, fraction of radius
    "twist": ("twist_degrees", (20.0, 40.0, 60.0)),  # rotation of the top vs the bottom
    "asymmetric": ("bulge", (0.10, 0.20, 0.30)),  # one-sided bulge, fraction of radius
}
# Twist first makes each slice elliptical (r scaled by 1 + e cos 2 phi), so that round targets
# change shape too; version 2 (version 1 only rotated the slices: cans, bowls, plates unchanged).
TWIST_ELLIPTICITY = (0.06, 0.12, 0.18)
GEOMETRY_VERSIONS = {"taper": 1, "multipeak": 1, "twist": 2, "asymmetric": 1}
DISTRACTOR_RULES = {
    "same_category": "another instance of a LIBERO object of the target's category, different model or texture",
    "same_color": "a different LIBERO object recoloured with the target's dominant material colour",
    "same_shape": "a LIBERO object whose bounding box aspect ratios are closest to the target's",
    "same_affordance": "a LIBERO object grasped the same way (same grasp class: bowl, box, bottle, mug, can)",
    "familiar_position": "a competing object at the mean of the target's position over LIBERO's initial states; target displaced nearby",
    "trajectory_obstacle": "an object on the straight path from the target to its placement, leaving a collision-free detour",
}


def _setting(category_id: str, name: str, **params: JSONScalar) -> Setting:
    return Setting(category_id, name, tuple(sorted(params.items())))


def _masking_settings() -> list[Setting]:
    """Target Object, Target Receptacle and Interaction-Cue Masking."""
    out: list[Setting] = []
    for entity, cat in (("target", "target_object_masking"), ("receptacle", "target_receptacle_masking")):
        for ratio in MASK_RATIOS:
            for schedule in MASK_SCHEDULES:
                out.append(
                    _setting(
                        cat,
                        f"ratio{ratio}-{schedule}",
                        entity=entity,
                        ratio=ratio / 100,
                        schedule=schedule,
                        occluder_gray=OCCLUDER_GRAY,
                        views="both",
                    )
                )
    for region in ("gripper", "gripper_object_contact", "placement_contact"):
        out.append(
            _setting(
                "interaction_cue_masking",
                region,
                region=region,
                ratio=1.0,
                schedule="always",
                dilation_px=0 if region == "gripper" else CONTACT_DILATION_PX,
                occluder_gray=OCCLUDER_GRAY,
                views="both",
            )
        )
    return out


def _corruption_settings() -> list[Setting]:
    """Temporary Observation Corruption, frequency- and phase-triggered."""
    out: list[Setting] = []
    for mode in ("blackout", "noise"):
        noise = NOISE_STD if mode == "noise" else None
        for level, prob in CORRUPTION_FREQUENCIES.items():
            out.append(
                _setting(
                    "temporary_observation_corruption",
                    f"{mode}-frequency_{level}",
                    mode=mode,
                    trigger="frequency",
                    onset_prob=prob,
                    burst_steps=CORRUPTION_BURST_STEPS,
                    noise_std=noise,
                    views="both",
                )
            )
        for phase in PHASES:
            out.append(
                _setting(
                    "temporary_observation_corruption",
                    f"{mode}-phase_{phase}",
                    mode=mode,
                    trigger="phase",
                    phase=phase,
                    noise_std=noise,
                    views="both",
                )
            )
    return out


def _view_settings() -> list[Setting]:
    """View Unavailability and Camera Staleness."""
    out: list[Setting] = []
    for view in VIEWS:
        for replacement in ("single_view", "constant", "duplicate"):
            out.append(
                _setting(
                    "view_unavailability",
                    f"{view}-{replacement}",
                    view=view,
                    camera=VIEWS[view],
                    replacement=replacement,
                    constant_value=0 if replacement == "constant" else None,
                )
            )
    for view in VIEWS:
        for delay_level, delay in enumerate(STALENESS_DELAYS, start=1):
            out.append(
                _setting(
                    "camera_staleness",
                    f"{view}-delay{delay_level}",
                    view=view,
                    camera=VIEWS[view],
                    mode="delay",
                    delay_steps=delay,
                )
            )
        out.append(
            _setting(
                "camera_staleness",
                f"{view}-freeze",
                view=view,
                camera=VIEWS[view],
                mode="freeze",
                freeze_step=FREEZE_STEP,
            )
        )
        out.append(
            _setting(
                "camera_staleness",
                f"{view}-replay",
                view=view,
                camera=VIEWS[view],
                mode="replay",
                replay_start=REPLAY_START,
                replay_window=REPLAY_WINDOW,
            )
        )
    return out


def _evidence_settings() -> list[Setting]:
    """Cross-View Contradiction and Prediction-Reality Divergence."""
    out: list[Setting] = []
    for attribute, edit in CONTRADICTION_EDITS.items():
        for view in VIEWS:
            # (the other attributes keep the key offset_m=None of version 1, so their settings keep their bytes)
            extent = {"min_shift": CONTRADICTION_MIN_SHIFT} if attribute == "position" else {"offset_m": None}
            setting = _setting(
                "cross_view_contradiction",
                f"{attribute}-{view}",
                attribute=attribute,
                edit=edit,
                view=view,
                camera=VIEWS[view],
                **extent,
            )
            out.append(dataclasses.replace(setting, version=CONTRADICTION_VERSIONS[attribute]))
    out.append(
        _setting(
            "prediction_reality_divergence",
            "recursive_self_prediction",
            ground_truth_steps=1,
            requires_predicted_frames=True,
        )
    )
    return out


def _scene_settings() -> list[Setting]:
    """The scene categories: distractors, preconditions, ambiguity, geometry."""
    out: list[Setting] = []
    for kind, rule in DISTRACTOR_RULES.items():
        out.append(_setting("task_relevant_distractors", kind, distractor=kind, rule=rule))
    for cat, physical in (("task_precondition_variation", True), ("visual_state_ambiguity", False)):
        out.append(
            _setting(
                cat,
                "receptacle_openness",
                attribute="receptacle_openness",
                state="other",
                physical=physical,
                visual_only_geometry=not physical,
            )
        )
        out.append(
            _setting(
                cat,
                "object_pose",
                attribute="object_pose",
                state="inverted",
                physical=physical,
                visual_only_geometry=not physical,
            )
        )
    for deformation, (param, amounts) in GEOMETRY_SEVERITY.items():
        for severity, amount in enumerate(amounts, start=1):
            extra = {"twist_ellipticity": TWIST_ELLIPTICITY[severity - 1]} if deformation == "twist" else {}
            setting = _setting(
                "target_geometry_variation",
                f"{deformation}-s{severity}",
                deformation=deformation,
                severity=severity,
                **{param: amount},
                **extra,
            )
            out.append(dataclasses.replace(setting, version=GEOMETRY_VERSIONS[deformation]))
    return out


def _build_settings() -> tuple[Setting, ...]:
    """The 96 settings in taxonomy order (the order of the catalog's cases)."""
    return (*_masking_settings(), *_corruption_settings(), *_view_settings(), *_evidence_settings(), *_scene_settings())


SETTINGS: tuple[Setting, ...] = _build_settings()
