"""A robosuite 1.5 LIBERO fork (rpent-libero 0.2.0, robosuite 1.5.2, mujoco 3.9), made once by
scripts/make-fork15-venv.sh under out/fork15-venv (a few minutes the first time):

- without the toolkit, the pack's own `vpro_libero_fork` runs one case of every observation
  category through the fork's loop, as in the robosuite 1.4 fork test;
- the pack's drift check (`python -m vpro_libero_fork verify PACK --simulate`) runs there and
  reports every case of the pack (docs/packs.md has its figures for one case of each of the 40 tasks);
- the toolkit's wheel (`make wheel`) installs into it without changing any installed version: the
  base requirements are already satisfied there, so `pip freeze` after equals `pip freeze` before
  plus the toolkit itself. The venv is restored afterwards (the toolkit uninstalled).

Run with `pytest -m fork15 tests/packs/test_fork15.py`.
"""

import glob
import subprocess

import pytest
from fork_obs import OBS_CASES, check_obs_report, fork_config, run_drift_check, run_obs_check, write_obs_pack

from vpro_assets.core import paths

pytestmark = [pytest.mark.slow, pytest.mark.fork15]  # minutes the first time: not in the default run
VENV = paths.REPO_ROOT / "out" / "fork15-venv"


@pytest.fixture(scope="module")
def python():
    subprocess.run(
        ["bash", str(paths.REPO_ROOT / "scripts" / "make-fork15-venv.sh"), str(VENV)], check=True, timeout=3600
    )
    return VENV / "bin" / "python"


def _freeze(python) -> list[str]:
    out = subprocess.run([str(python), "-m", "pip", "freeze", "--all"], capture_output=True, text=True, check=True)
    return sorted(out.stdout.splitlines())


def test_fork15_runs_every_observation_category_after_wrap(python, tmp_path):
    assert subprocess.run([str(python), "-c", "import vpro_assets"], capture_output=True, cwd=tmp_path).returncode != 0
    pack = write_obs_pack(tmp_path / "obs-pack")
    report = run_obs_check(python, fork_config(python, tmp_path / "fork-config"), pack, tmp_path / "run")
    assert report["robosuite"] == "1.5.2"
    check_obs_report(report)


def test_fork15_drift_check_runs_and_reports(python, tmp_path):
    pack = write_obs_pack(tmp_path / "obs-pack")
    status, rows, out = run_drift_check(python, fork_config(python, tmp_path / "fork-config"), pack, "--trials", "2")
    assert "this environment: mujoco 3.9" in out and "robosuite 1.5.2" in out
    assert set(rows) == set(OBS_CASES.values())
    assert all(row["trials"] == 2 and row["status"].split(":")[0] in ("ok", "drifted") for row in rows.values()), rows
    assert status == (1 if any(row["status"].startswith("drifted") for row in rows.values()) else 0)


def test_wheel_installs_without_changing_any_version(python, tmp_path):
    dist = tmp_path / "dist"
    subprocess.run(
        ["make", "-C", str(paths.REPO_ROOT), "wheel", f"WHEEL_DIR={dist}"], check=True, timeout=900, capture_output=True
    )
    (wheel,) = glob.glob(str(dist / "libero_vpro-*.whl"))
    before = _freeze(python)
    try:
        proc = subprocess.run([str(python), "-m", "pip", "install", wheel], capture_output=True, text=True)
        assert proc.returncode == 0, proc.stderr[-2000:]
        after = _freeze(python)
        assert [line for line in after if not line.startswith("libero-vpro")] == before
        (added,) = [line for line in after if line.startswith("libero-vpro")]
        assert added.startswith("libero-vpro @ file://" + wheel)
        # The installed toolkit works there: `vpro pack verify` and the same wrapper the pack ships.
        pack = write_obs_pack(tmp_path / "pack")
        verify = subprocess.run(
            [str(VENV / "bin" / "vpro"), "pack", "verify", str(pack)], capture_output=True, text=True, cwd=tmp_path
        )
        assert verify.returncode == 0, verify.stderr[-2000:]
        same = "import vpro_assets.packs.fork_runtime as f, vpro_assets.packs.wrap as w; assert w.ForkEnv is f.ForkEnv"
        out = subprocess.run([str(python), "-c", same], capture_output=True, text=True, cwd=tmp_path)
        assert out.returncode == 0, out.stderr[-2000:]
    finally:
        subprocess.run([str(python), "-m", "pip", "uninstall", "-y", "libero-vpro"], check=True, capture_output=True)
    assert _freeze(python) == before
