"""Observation cases in a fork venv, shared by the robosuite 1.4 (`-m fork`) and 1.5 (`-m fork15`)
tests: one case of every observation category (on libero_goal-03, the blackout on libero_goal-09),
packed, registered with the pack's own module in the fork venv and run through a fork-style loop
after `wrap` (tests/packs/fork_obs_check.py)."""

from __future__ import annotations

import json
import os
import subprocess
from pathlib import Path

import numpy as np

from vpro_assets.benchmark.catalog import load_catalog
from vpro_assets.benchmark.selection import select_cases
from vpro_assets.core import paths
from vpro_assets.packs.writer import write_pack

CHECK = Path(__file__).with_name("fork_obs_check.py")
DRIFT_CHECK = Path(__file__).with_name("fork_drift_check.py")
TASK = "libero_goal-03"
STEPS = 12
STALE_DELAY = 5  # wrist-delay1
PREDICTION_GROUND_TRUTH = 1
OBS_CASES = {
    "target_object_masking": f"{TASK}/target_object_masking/ratio50-always-v1",
    "target_receptacle_masking": f"{TASK}/target_receptacle_masking/ratio50-always-v1",
    "interaction_cue_masking": f"{TASK}/interaction_cue_masking/gripper-v1",
    # The allocation gives libero_goal-03 no approach-phase blackout; libero_goal-09 has one.
    "temporary_observation_corruption": "libero_goal-09/temporary_observation_corruption/blackout-phase_approach-v1",
    "view_unavailability": f"{TASK}/view_unavailability/wrist-single_view-v1",
    "camera_staleness": f"{TASK}/camera_staleness/wrist-delay1-v1",
    "cross_view_contradiction": f"{TASK}/cross_view_contradiction/existence-third_person-v1",
    "prediction_reality_divergence": f"{TASK}/prediction_reality_divergence/recursive_self_prediction-v1",
}


def write_obs_pack(out: Path) -> Path:
    catalog = load_catalog(paths.catalog_path())
    return write_pack(select_cases(catalog, list(OBS_CASES.values())), out, catalog, paths.catalog_path())


def fork_config(python: Path, folder: Path) -> Path:
    """A LIBERO config of the fork's own (its checkout's folders), as a fork user has it."""
    site = subprocess.run(
        [str(python), "-c", "import sysconfig; print(sysconfig.get_paths()['purelib'])"],
        capture_output=True,
        text=True,
        check=True,
    ).stdout.strip()
    root = f"{site}/libero/libero"
    folder.mkdir(parents=True, exist_ok=True)
    (folder / "config.yaml").write_text(
        f"benchmark_root: {root}\nbddl_files: {root}/bddl_files\ninit_states: {root}/init_files\n"
        f"datasets: {folder}/datasets\nassets: {root}/assets\n"
    )
    return folder


def run_obs_check(python: Path, config: Path, pack: Path, work: Path) -> dict:
    """Run the check in the fork venv with its own home and working folder; return its report with
    `config_bytes_unchanged` (the fork's config.yaml, byte for byte)."""
    home, cwd = work / "home", work / "cwd"
    home.mkdir(parents=True)
    cwd.mkdir()
    config_bytes = (config / "config.yaml").read_bytes()
    env = {k: v for k, v in os.environ.items() if not k.startswith(("VPRO_", "PYTHONPATH"))}
    env.update(HOME=str(home), LIBERO_CONFIG_PATH=str(config), MUJOCO_GL=os.environ.get("MUJOCO_GL", "egl"))
    env["PYOPENGL_PLATFORM"] = env["MUJOCO_GL"]
    proc = subprocess.run(
        [str(python), str(CHECK), str(pack), str(STEPS)], capture_output=True, text=True, timeout=3600, cwd=cwd, env=env
    )
    assert proc.returncode == 0, proc.stderr[-3000:]
    line = next(line for line in proc.stdout.splitlines() if line.startswith("REPORT "))
    report = json.loads(line[len("REPORT ") :])
    (work / "report.json").write_text(json.dumps(report, indent=1))  # for a failing check's details
    report["config_bytes_unchanged"] = (config / "config.yaml").read_bytes() == config_bytes
    return report


def run_drift_check(python: Path, config: Path, pack: Path, *options: str) -> tuple[int, dict[str, dict], str]:
    """The pack's own drift check in the fork venv (`python -m vpro_libero_fork verify PACK
    --simulate`, after the fork's set-up line): its exit status, its table (case -> row), its output."""
    env = {k: v for k, v in os.environ.items() if not k.startswith(("VPRO_", "PYTHONPATH"))}
    env.update(LIBERO_CONFIG_PATH=str(config), MUJOCO_GL=os.environ.get("MUJOCO_GL", "egl"))
    env["PYOPENGL_PLATFORM"] = env["MUJOCO_GL"]
    proc = subprocess.run(
        [str(python), str(DRIFT_CHECK), str(pack), *options], capture_output=True, text=True, timeout=3600, env=env
    )
    assert proc.returncode in (0, 1), proc.stderr[-3000:]
    header = None
    rows = {}
    for line in proc.stdout.splitlines():
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        if cells[0] == "case":
            header = cells
        elif header and len(cells) == len(header) and not cells[0].startswith("---"):
            row = dict(zip(header, cells))
            rows[row["case"]] = {
                "trials": int(row["trials"]),
                "displacement_cm": float(row["displacement (cm)"]),
                "tilt_deg": float(row["tilt change (deg)"]),
                "status": row["status"],
            }
    return proc.returncode, rows, proc.stdout


def check_obs_report(report: dict) -> None:
    """What every category must show in the fork's loop (raw = what LIBERO returned)."""
    assert report["config_unchanged"] and report["config_bytes_unchanged"]
    assert report["written"] == [], report["written"][:20]  # in the home, working or config folder
    cases = report["cases"]
    assert {c: v["id"] for c, v in cases.items()} == OBS_CASES
    for category, case in cases.items():
        assert len(case["rows"]) == STEPS + 1, category
        assert case["raw_moves"], f"{category}: the arm did not move; the checks would prove nothing"
    agent, wrist = "agentview", "robot0_eye_in_hand"

    def frames(category, cam):
        return [row[cam] for row in cases[category]["rows"]]

    # Masking: a grey occluder over the target / receptacle / gripper from the first observation.
    for category in ("target_object_masking", "target_receptacle_masking", "interaction_cue_masking"):
        seen = frames(category, agent) + frames(category, wrist)
        assert sum(not f["equals_raw"] for f in seen) >= STEPS, category
    # Corruption during the approach phase (the first steps): black frames in both views.
    for cam in (agent, wrist):
        first = frames("temporary_observation_corruption", cam)[0]
        assert first["uniform"] and first["value00"] == 0 and not first["equals_raw"]
    # Single-view unavailability: the wrist key is absent, the third-person view untouched.
    assert all(f == "absent" for f in frames("view_unavailability", wrist))
    assert all(f["equals_raw"] for f in frames("view_unavailability", agent))
    # Staleness: the wrist view shows LIBERO's frame of STALE_DELAY steps before; the other is current.
    stale = frames("camera_staleness", wrist)
    for t, f in enumerate(stale):
        assert max(t - STALE_DELAY, 0) in f["raw_steps"], (t, f)
    assert any(not f["equals_raw"] for f in stale[STALE_DELAY:]), "the delayed frame never differed"
    assert all(f["equals_raw"] for f in frames("camera_staleness", agent))
    # Contradiction: the target is hidden in the third-person view only (a per-camera scene edit).
    assert cases["cross_view_contradiction"]["scene_edits"] == {agent: True, wrist: False}
    # Prediction feedback: after the ground-truth steps each view is the frame fed at the step before.
    fed = cases["prediction_reality_divergence"]["fed"]
    for cam in (agent, wrist):
        seen = frames("prediction_reality_divergence", cam)
        for t in range(PREDICTION_GROUND_TRUTH, STEPS + 1):
            assert seen[t]["uniform"] and seen[t]["value00"] == fed[t - 1][cam], (cam, t)
    assert np.all([cases[c]["rows"][0][agent] != "absent" for c in cases])
