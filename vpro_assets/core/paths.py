"""Where the project's files live: the repository root, out/, the committed catalog."""
from __future__ import annotations

import os
from pathlib import Path

PACKAGE_DIR = Path(__file__).resolve().parent.parent  # vpro_assets/
REPO_ROOT = PACKAGE_DIR.parent


def out_dir() -> Path:
    """Generated artifacts; `VPRO_OUT` overrides the repository's out/."""
    return Path(os.environ.get("VPRO_OUT", REPO_ROOT / "out"))


def catalog_path() -> Path:
    """The committed catalog; `VPRO_CATALOG` overrides it."""
    return Path(os.environ.get("VPRO_CATALOG", REPO_ROOT / "catalog.json"))


def libero_config_dir() -> Path:
    """LIBERO's config folder used by the toolkit: never the user's ~/.libero unless asked."""
    return Path(os.environ.get("VPRO_LIBERO_CONFIG_DIR", REPO_ROOT / ".libero"))
