"""Choose a headless OpenGL backend for MuJoCo before robosuite is imported.

robosuite reads `MUJOCO_GL` once, at import time, and defaults to EGL; a backend that cannot
create a context then fails much later, deep inside the first render. We probe each candidate in
a child process (a failed EGL/OSMesa initialisation can abort the interpreter) and keep the first
that renders.
"""

from __future__ import annotations

import logging
import os
import subprocess
import sys

from vpro_assets.core.errors import LiberoSetupError

log = logging.getLogger(__name__)

CANDIDATES = ("egl", "osmesa")
_PROBE = "import mujoco; c = mujoco.GLContext(16, 16); c.make_current(); c.free(); print('ok')"


def probe(backend: str, timeout: float = 60.0) -> str | None:
    """Return None if `backend` creates a context, else the reason it failed."""
    env = dict(os.environ, MUJOCO_GL=backend, PYOPENGL_PLATFORM=backend)
    try:
        proc = subprocess.run([sys.executable, "-c", _PROBE], env=env, capture_output=True, text=True, timeout=timeout)
    except subprocess.TimeoutExpired:
        return f"timed out after {timeout:.0f} s"
    if proc.returncode == 0 and proc.stdout.strip().endswith("ok"):
        return None
    lines = (proc.stderr or proc.stdout).strip().splitlines()
    return lines[-1] if lines else f"exit code {proc.returncode}"


def ensure_gl_backend() -> str:
    """Set `MUJOCO_GL` (and PyOpenGL's platform) to a working headless backend and return it.

    A backend the user already chose is kept as it is. Otherwise EGL is tried, then OSMesa.
    """
    chosen = os.environ.get("MUJOCO_GL", "").strip().lower()
    if chosen:
        os.environ.setdefault("PYOPENGL_PLATFORM", chosen if chosen in CANDIDATES else "")
        return chosen
    failures = []
    for backend in CANDIDATES:
        reason = probe(backend)
        if reason is None:
            os.environ["MUJOCO_GL"] = backend
            os.environ["PYOPENGL_PLATFORM"] = backend
            log.info("headless rendering through MUJOCO_GL=%s", backend)
            return backend
        failures.append(f"{backend}: {reason}")
    raise LiberoSetupError(
        "no headless OpenGL backend works (" + "; ".join(failures) + "). Install Mesa's EGL or "
        "OSMesa (`make setup` runs scripts/install-system-packages.sh), or set MUJOCO_GL yourself."
    )
