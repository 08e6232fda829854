"""LIBERO-VPro: closed-loop visual robustness benchmark on LIBERO.

Importing the package is cheap: LIBERO, robosuite and renderers load only when used.
`vpro_assets.wrap(env, case)` puts a case's observation perturbations around a fork's env.

In the toolkit's own environment, importing the package also points LIBERO at the config that
`make setup` wrote (`.libero/config.yaml` in the repository) when neither `LIBERO_CONFIG_PATH` nor
the user's own `~/.libero/config.yaml` exists, so a user's own script that imports LIBERO afterwards is not stopped by LIBERO's stdin prompt.
Importing it first also pins numpy's floating-point kernels (`vpro_assets.core.numerics`), so built
scenes are the same bytes on every x86-64 CPU with AVX2. Nothing is written at import.
"""

from vpro_assets.core import numerics as _numerics

_numerics.pin()  # before anything here imports numpy

import os as _os  # noqa: E402
from pathlib import Path as _Path  # noqa: E402

from vpro_assets.core import paths as _paths  # noqa: E402

__version__ = "0.1.0"

# Only where LIBERO would otherwise prompt: a user's own ~/.libero/config.yaml (a fork with the
# toolkit installed) keeps being the one LIBERO reads.
if (
    "LIBERO_CONFIG_PATH" not in _os.environ
    and not (_Path.home() / ".libero" / "config.yaml").is_file()
    and (_paths.libero_config_dir() / "config.yaml").is_file()
):
    _os.environ["LIBERO_CONFIG_PATH"] = str(_paths.libero_config_dir())


def wrap(env, case):
    """See `vpro_assets.packs.wrap`."""
    from vpro_assets.packs.wrap import wrap as _wrap

    return _wrap(env, case)
