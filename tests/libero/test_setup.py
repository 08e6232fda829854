"""LIBERO is configured without prompting and without the user's home; GL backend selection."""

import os
import subprocess
import sys
from pathlib import Path

import pytest

from vpro_assets.core.errors import LiberoSetupError, VProError
from vpro_assets.libero import gl as gl_backend
from vpro_assets.libero.init_states import read_init_states


def test_libero_imports_without_prompt_or_home(tmp_path):
    home = tmp_path / "home"
    home.mkdir()
    env = {k: v for k, v in os.environ.items() if k not in ("LIBERO_CONFIG_PATH", "VPRO_LIBERO_CONFIG_DIR")}
    env.update(HOME=str(home), VPRO_LIBERO_CONFIG_DIR=str(tmp_path / "cfg"))
    code = (
        "from vpro_assets.libero import bridge as b; m = b.libero(); "
        "print(m.get_libero_path('bddl_files')); print(m.get_assets_path())"
    )
    proc = subprocess.run(
        [sys.executable, "-c", code], env=env, stdin=subprocess.DEVNULL, capture_output=True, text=True, timeout=120
    )
    assert proc.returncode == 0, proc.stderr
    bddl, assets = proc.stdout.split()[-2:]
    assert Path(bddl, "libero_goal").is_dir() and Path(assets, "stable_scanned_objects").is_dir()
    assert (tmp_path / "cfg" / "config.yaml").is_file()
    assert not (home / ".libero").exists()


def test_probe_reports_a_broken_backend():
    assert gl_backend.probe("egl") is None or gl_backend.probe("osmesa") is None
    assert gl_backend.probe("no-such-backend")


def test_no_working_backend_is_a_clear_error(monkeypatch):
    monkeypatch.delenv("MUJOCO_GL", raising=False)
    monkeypatch.setattr(gl_backend, "CANDIDATES", ("no-such-backend",))
    with pytest.raises(LiberoSetupError, match="no headless OpenGL backend works"):
        gl_backend.ensure_gl_backend()


def test_user_choice_of_backend_is_kept(monkeypatch):
    monkeypatch.setenv("MUJOCO_GL", "osmesa")
    assert gl_backend.ensure_gl_backend() == "osmesa"


def test_initial_states_read_without_torch(tasks):
    from vpro_assets.libero import bridge as libero_bridge

    states = read_init_states(libero_bridge.init_state_path(tasks[0].suite, tasks[0].name))
    assert states.shape == (50, 92) and states.dtype.name == "float64"
    assert "torch" not in sys.modules


def test_broken_initial_state_file_is_named(tmp_path):
    bad = tmp_path / "x.pruned_init"
    bad.write_bytes(b"not a zip")
    with pytest.raises(VProError, match="x.pruned_init"):
        read_init_states(bad)


def test_a_users_script_imports_libero_after_the_toolkit_without_prompt(tmp_path):
    """`import vpro_assets`, then LIBERO's envs directly: configured by the config `make setup` wrote,
    nothing written by the import."""
    from vpro_assets.core import paths

    env = {k: v for k, v in os.environ.items() if k != "LIBERO_CONFIG_PATH"} | {"HOME": str(tmp_path)}
    setup = "from vpro_assets.libero.bridge import write_libero_config; write_libero_config()"  # as `make setup`
    subprocess.run([sys.executable, "-c", setup], env=env, check=True, timeout=120, stdin=subprocess.DEVNULL)
    config = paths.libero_config_dir() / "config.yaml"
    before = config.stat().st_mtime_ns, config.read_bytes()
    code = "import vpro_assets\nfrom libero.libero.envs import OffScreenRenderEnv\nprint('ok')"
    proc = subprocess.run(
        [sys.executable, "-c", code],
        env=env,
        stdin=subprocess.DEVNULL,
        capture_output=True,
        text=True,
        timeout=300,
        cwd=paths.REPO_ROOT.parent,
    )
    assert proc.returncode == 0 and proc.stdout.strip().endswith("ok"), proc.stderr[-2000:]
    assert (config.stat().st_mtime_ns, config.read_bytes()) == before


def test_the_config_does_not_depend_on_the_output_folder(tmp_path):
    """Processes with other outputs (`VPRO_OUT`: the tests' scratch builds, a user's second output)
    leave LIBERO's config as it is: they once rewrote it in turn, under a script reading it."""
    from vpro_assets.core import paths

    config = paths.libero_config_dir() / "config.yaml"
    setup = "from vpro_assets.libero.bridge import write_libero_config; write_libero_config()"
    env = {k: v for k, v in os.environ.items() if k != "LIBERO_CONFIG_PATH"}
    subprocess.run([sys.executable, "-c", setup], env=env, check=True, timeout=120, stdin=subprocess.DEVNULL)
    before = config.stat().st_mtime_ns, config.read_bytes()
    for out in ("a", "b"):
        subprocess.run([sys.executable, "-c", setup], env=env | {"VPRO_OUT": str(tmp_path / out)}, check=True,
                       timeout=120, stdin=subprocess.DEVNULL)  # fmt: skip
        assert (config.stat().st_mtime_ns, config.read_bytes()) == before
