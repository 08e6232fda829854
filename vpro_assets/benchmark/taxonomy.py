"""The benchmark's taxonomy as data: 4 dimensions, 12 categories, 96 settings.

Each setting is a frozen, JSON-serialisable record with a stable, versioned id
(`vpro/<category>/<name>-v<version>`). Values the paper leaves open (frequencies, delays, noise
level, severities) are chosen once, in `vpro_assets.benchmark.settings_table`, and documented in
docs/taxonomy.md. Changing what a setting does means bumping its version, which changes its id and
every case id built on it. The records and the fixed tables of dimensions and categories are in
`vpro_assets.benchmark.taxonomy_types`; this module gathers both for the rest of the toolkit (the
perturbations, the reports, the docs) and looks settings up.
"""

from __future__ import annotations

import functools

from vpro_assets.benchmark.settings_table import (
    CONTACT_DILATION_PX,
    CONTRADICTION_EDITS,
    CONTRADICTION_MIN_SHIFT,
    CONTRADICTION_OFFSET_M,
    CONTRADICTION_VERSIONS,
    CORRUPTION_BURST_STEPS,
    CORRUPTION_FREQUENCIES,
    DISTRACTOR_RULES,
    FREEZE_STEP,
    GEOMETRY_SEVERITY,
    GEOMETRY_VERSIONS,
    MASK_RATIOS,
    MASK_SCHEDULES,
    NOISE_STD,
    OCCLUDER_GRAY,
    REPLAY_START,
    REPLAY_WINDOW,
    SETTINGS,
    STALENESS_DELAYS,
    TWIST_ELLIPTICITY,
)
from vpro_assets.benchmark.taxonomy_types import (
    CATEGORIES,
    CONTROL_HZ,
    DIAGNOSTIC,
    DIMENSIONS,
    OBSERVATION,
    PHASES,
    ROBUSTNESS,
    SCENE,
    TAXONOMY_VERSION,
    VIEWS,
    Category,
    Dimension,
    JSONScalar,
    Setting,
    category,
    dimension,
    lookup,
)

__all__ = [
    "CATEGORIES",
    "CONTACT_DILATION_PX",
    "CONTRADICTION_EDITS",
    "CONTRADICTION_MIN_SHIFT",
    "CONTRADICTION_OFFSET_M",
    "CONTRADICTION_VERSIONS",
    "CONTROL_HZ",
    "CORRUPTION_BURST_STEPS",
    "CORRUPTION_FREQUENCIES",
    "DIAGNOSTIC",
    "DIMENSIONS",
    "DISTRACTOR_RULES",
    "FREEZE_STEP",
    "GEOMETRY_SEVERITY",
    "GEOMETRY_VERSIONS",
    "MASK_RATIOS",
    "MASK_SCHEDULES",
    "NOISE_STD",
    "OBSERVATION",
    "OCCLUDER_GRAY",
    "PHASES",
    "REPLAY_START",
    "REPLAY_WINDOW",
    "ROBUSTNESS",
    "SCENE",
    "SETTINGS",
    "STALENESS_DELAYS",
    "TAXONOMY_VERSION",
    "TWIST_ELLIPTICITY",
    "VIEWS",
    "Category",
    "Dimension",
    "JSONScalar",
    "Setting",
    "category",
    "dimension",
    "setting",
    "settings_of",
]


@functools.cache
def _settings_index() -> dict[str, Setting]:
    return {s.id: s for s in SETTINGS}


def setting(setting_id: str) -> Setting:
    return lookup("setting", _settings_index(), setting_id)


def settings_of(cat_id: str) -> tuple[Setting, ...]:
    category(cat_id)
    return tuple(s for s in SETTINGS if s.category == cat_id)
