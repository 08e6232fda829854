"""The drift check between two simulators (docs/simulator.md): the committed fingerprints (taken
under the toolkit's pin, the reference simulator, MuJoCo 3.3.7) against a venv with MuJoCo 3.8.1, the
previous pin, which changes four Normal starts. Builds that venv once
(scripts/make-sim-venv.sh, a few minutes; kept in out/sim-venvs/). Run with
`.venv/bin/python -m pytest -m simulators tests/rollout/test_simulator_drift.py` (about 15 minutes)."""

from __future__ import annotations

import os
import subprocess
from pathlib import Path

import cv2
import pytest

from vpro_assets.benchmark import fingerprints as fp
from vpro_assets.libero.bridge import simulator_versions

pytestmark = [pytest.mark.slow, pytest.mark.simulators]

REPO = Path(__file__).resolve().parents[2]
OTHER_MUJOCO = "3.8.1"  # the previous pin (docs/simulator.md)
# The Normal baselines whose first frame differs between MuJoCo 3.8.1 and 3.3.7 (as 3.2.3).
DIFFERING = {"libero_10-00/normal", "libero_10-01/normal", "libero_10-07/normal", "libero_spatial-05/normal"}


@pytest.fixture(scope="module")
def other_venv() -> Path:
    venv = REPO / "out" / "sim-venvs" / f"mujoco-{OTHER_MUJOCO}"
    subprocess.run(["bash", str(REPO / "scripts" / "make-sim-venv.sh"), OTHER_MUJOCO, str(venv)], check=True)
    return venv


def _drift(venv: Path, tmp_path: Path, *args: str) -> subprocess.CompletedProcess:
    env = dict(os.environ, VPRO_LIBERO_CONFIG_DIR=str(tmp_path / "libero-config"))
    return subprocess.run(
        [str(venv / "bin" / "vpro"), "drift", *args], capture_output=True, text=True, env=env, cwd=REPO, timeout=3600
    )


def test_drift_from_the_fingerprints_to_mujoco_3_8_1_lists_the_four_tasks(other_venv, tmp_path):
    prints = fp.load()
    assert prints["simulator"]["mujoco"] == simulator_versions()["mujoco"] != OTHER_MUJOCO
    proc = _drift(other_venv, tmp_path, "--select", "normal", "--trials", "3", "--no-pictures")
    assert proc.returncode == 1, proc.stdout + proc.stderr
    assert f"this environment: mujoco {OTHER_MUJOCO}" in proc.stdout
    listed = next(line for line in proc.stdout.splitlines() if line.startswith("drifted: ")).split()[1:]
    assert set(listed) == DIFFERING, proc.stdout


def test_a_drifted_case_gets_its_first_frames_side_by_side(other_venv, tmp_path):
    proc = _drift(
        other_venv,
        tmp_path,
        "--select",
        "libero_10-00/normal",
        "--trials",
        "1",
        "--pictures",
        str(tmp_path / "pictures"),
    )
    assert proc.returncode == 1, proc.stdout + proc.stderr
    pictures = sorted((tmp_path / "pictures").glob("*.png"))
    assert [p.name for p in pictures] == ["libero_10-00__normal-trial0.png"]
    image = cv2.imread(str(pictures[0]))
    assert image.shape == (256, 512, 3)
    left, right = image[:, :256].astype(int), image[:, 256:].astype(int)
    assert abs(left - right).mean() > 1.0  # the recorded and the current first frame differ
