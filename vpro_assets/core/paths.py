"""Where the project's files live: the repository root, out/ and what is built there, the committed catalog."""

from __future__ import annotations

import os
from pathlib import Path

PACKAGE_DIR = Path(__file__).resolve().parent.parent  # vpro_assets/
REPO_ROOT = PACKAGE_DIR.parent


def out_dir() -> Path:
    """Generated artifacts; `VPRO_OUT` overrides the repository's out/."""
    return Path(os.environ.get("VPRO_OUT", REPO_ROOT / "out"))


def scene_root() -> Path:
    """Built scene cases: one folder per case id under out/scene/."""
    return out_dir() / "scene"


def scene_case_dir(case_id: str) -> Path:
    return scene_root() / case_id


SCENE_META = "meta.json"  # in each built case's folder: input hash, the rule's choices, file hashes


def objects_root() -> Path:
    """Generated objects (deformed targets, recoloured distractors) shared by scene cases."""
    return out_dir() / "objects"


def catalog_path() -> Path:
    """The committed catalog; `VPRO_CATALOG` overrides it."""
    return Path(os.environ.get("VPRO_CATALOG", REPO_ROOT / "catalog.json"))


def libero_config_dir() -> Path:
    """LIBERO's config folder used by the toolkit: never the user's ~/.libero unless asked."""
    return Path(os.environ.get("VPRO_LIBERO_CONFIG_DIR", REPO_ROOT / ".libero"))
