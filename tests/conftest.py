"""Shared fixtures. Tests never touch the user's home: LIBERO's config goes to a temp dir."""
from __future__ import annotations

import os
import tempfile

import pytest

# Before anything imports LIBERO: config in a per-run folder, quiet robosuite.
os.environ.setdefault("VPRO_LIBERO_CONFIG_DIR", tempfile.mkdtemp(prefix="vpro-libero-config-"))


@pytest.fixture(scope="session")
def tasks():
    from vpro_assets.tasks import load_tasks

    return load_tasks()


@pytest.fixture(scope="session")
def built_catalog():
    from vpro_assets.catalog import build_catalog

    return build_catalog()
