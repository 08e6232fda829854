"""LIBERO-VPro inside vla-eval (the evaluation harness, `pip install libero-vpro[vla-eval]`).

- `benchmark.LiberoVProBenchmark`: catalog cases as vla-eval benchmark tasks (docs/vla-eval.md);
- `server.ScriptedModelServer`: a model server on vla-eval's own base class that replays a fixed
  action sequence (no-op by default), for smoke runs and tests without a model;
- `configs/`: the shipped run configs (`config_path("smoke")`).

Importing this package does not import vla-eval; its modules do, with an actionable message when
the extra is not installed.
"""

from __future__ import annotations

import importlib.util
from pathlib import Path

from vpro_assets.core.errors import UnknownIdError, VProError

CONFIG_DIR = Path(__file__).resolve().parent / "configs"


def require_vla_eval() -> None:
    if importlib.util.find_spec("vla_eval") is None:
        raise VProError("vla-eval is not installed; install the extra: pip install 'libero-vpro[vla-eval]'")


def config_names() -> list[str]:
    return sorted(p.stem for p in CONFIG_DIR.glob("*.yaml"))


def config_path(name: str) -> Path:
    """A shipped config by name (`smoke`, `all`, `normal`, or a category such as `camera_staleness`)."""
    path = CONFIG_DIR / f"{name}.yaml"
    if not path.is_file():
        raise UnknownIdError("vla-eval config", name, config_names())
    return path
