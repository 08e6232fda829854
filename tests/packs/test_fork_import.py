"""A pack registered in a LIBERO environment that does not have the toolkit (a "fork"): LIBERO's
own benchmark API builds every pack scene, loads every initial state with torch.load, and steps.

The fork environment is made by scripts/make-fork-venv.sh (LIBERO, robosuite, mujoco, CPU torch;
about 2 minutes the first time, reused afterwards under out/fork-venv)."""

import json
import os
import subprocess
from pathlib import Path

import pytest
from fork_obs import check_obs_report, fork_config, run_drift_check, run_obs_check, write_obs_pack

from vpro_assets.benchmark import fingerprints as fp
from vpro_assets.benchmark.catalog import load_catalog
from vpro_assets.benchmark.selection import select_cases
from vpro_assets.core import paths
from vpro_assets.packs.writer import write_pack

pytestmark = pytest.mark.fork
FORK_VENV = paths.REPO_ROOT / "out" / "fork-venv"
CHECK = Path(__file__).with_name("fork_check.py")
# One case of every scene-variation category plus observation cases.
SCENE_CASES = [
    "libero_spatial-00/task_relevant_distractors/same_color-v1",
    "libero_goal-03/task_precondition_variation/receptacle_openness-v1",
    "libero_goal-03/visual_state_ambiguity/receptacle_openness-v1",
    "libero_spatial-00/target_geometry_variation/taper-s1-v1",
]
CASES = SCENE_CASES + [
    "libero_goal-03/camera_staleness/wrist-delay2-v1",
    "libero_10-09/view_unavailability/wrist-constant-v1",
]


@pytest.fixture(scope="module")
def fork_python(tmp_path_factory):
    subprocess.run(
        ["bash", str(paths.REPO_ROOT / "scripts" / "make-fork-venv.sh"), str(FORK_VENV)], check=True, timeout=1800
    )
    python = FORK_VENV / "bin" / "python"
    site = subprocess.run(
        [str(python), "-c", "import sysconfig; print(sysconfig.get_paths()['purelib'])"],
        capture_output=True,
        text=True,
        check=True,
    ).stdout.strip()
    config = tmp_path_factory.mktemp("fork-config")
    root = f"{site}/libero/libero"
    (config / "config.yaml").write_text(
        f"benchmark_root: {root}\nbddl_files: {root}/bddl_files\ninit_states: {root}/init_files\n"
        f"datasets: {config}/datasets\nassets: {root}/assets\n"
    )
    return python, config


def _run(fork_python, *args):
    python, config = fork_python
    env = {k: v for k, v in os.environ.items() if not k.startswith(("VPRO_", "PYTHONPATH"))}
    env.update(LIBERO_CONFIG_PATH=str(config), MUJOCO_GL=os.environ.get("MUJOCO_GL", "egl"))
    env["PYOPENGL_PLATFORM"] = env["MUJOCO_GL"]
    proc = subprocess.run(
        [str(python), str(CHECK), *map(str, args)], capture_output=True, text=True, timeout=1800, cwd="/", env=env
    )
    assert proc.returncode == 0, proc.stderr[-3000:]
    line = next(line for line in proc.stdout.splitlines() if line.startswith("REPORT "))
    return json.loads(line[len("REPORT ") :])


@pytest.fixture(scope="module")
def pack(tmp_path_factory):
    from vpro_assets.scene.build import build

    catalog = load_catalog(paths.catalog_path())
    mp = pytest.MonkeyPatch()
    mp.setenv("VPRO_OUT", str(tmp_path_factory.mktemp("vpro-out")))
    try:
        build(select_cases(catalog, SCENE_CASES), jobs=1, progress=False)
        out = tmp_path_factory.mktemp("packs") / "pack.tar.gz"
        yield write_pack(select_cases(catalog, CASES), out, catalog, paths.catalog_path())
    finally:
        mp.undo()


def test_fork_runs_every_pack_scene(fork_python, pack):
    report = _run(fork_python, pack)
    assert report["idempotent"]
    tasks = {t["task"]: t for rows in report["suites"].values() for t in rows}
    assert set(report["suites"]) == {
        "vpro_camera_staleness",
        "vpro_view_unavailability",
        "vpro_task_relevant_distractors",
        "vpro_task_precondition_variation",
        "vpro_visual_state_ambiguity",
        "vpro_target_geometry_variation",
    }
    assert set(tasks) == {f"{c.split('/')[0]}__{c.rsplit('/', 1)[1]}" for c in CASES}
    assert (
        tasks["libero_10-09__wrist-constant-v1"]["language"]
        == "put the yellow and white mug in the microwave and close it"
    )
    for name, row in tasks.items():
        scene = any(name == f"{c.split('/')[0]}__{c.rsplit('/', 1)[1]}" for c in SCENE_CASES)
        assert row["init_states"] == (10 if scene else 50), name  # scene cases carry their frozen states
        assert row["stepped"] == 10 and row["image"] == [64, 64, 3]


def test_clashing_names_are_refused_and_registries_unchanged(fork_python, pack, tmp_path):
    from vpro_assets.packs.archive import extract_archive

    root = extract_archive(pack, tmp_path)
    manifest = json.loads((root / "manifest.json").read_text())
    manifest["suites"]["libero_spatial"] = manifest["suites"].pop("vpro_camera_staleness")
    manifest["objects"] = [{"name": "akita_black_bowl", "xml": "taxonomy.json", "sha256": "0" * 64}]
    (root / "manifest.json").write_text(json.dumps(manifest))
    report = _run(fork_python, root, "--expect-clash")
    assert report["error"] and "nothing was changed" in report["error"]
    assert "'akita_black_bowl'" in report["error"] and "'libero_spatial'" in report["error"]
    assert report["unchanged"]


def test_fork_runs_every_observation_category_after_wrap(fork_python, tmp_path):
    """robosuite 1.4 fork, no toolkit: the pack's own `vpro_libero_fork.wrap` and `reset` run one
    case of every observation category in the fork's loop (fork_obs.check_obs_report says what each
    must show, the staleness case's delayed frame included); the fork's LIBERO config keeps its
    bytes and nothing is written in its home or working folder."""
    python, _ = fork_python
    pack = write_obs_pack(tmp_path / "obs-pack")
    report = run_obs_check(python, fork_config(python, tmp_path / "fork-config"), pack, tmp_path / "run")
    assert report["robosuite"].startswith("1.4")
    check_obs_report(report)


# Two starts: libero_goal-03 (a cabinet: its drawers are fingerprinted joints), shared by two cases,
# and libero_object-01 (on the floor). Both start alike under MuJoCo 3.2.3, 3.3.7 and 3.8.1
# (docs/simulator.md: only libero_10-00, -01, -07 and libero_spatial-05 differ beyond 0.56 cm).
DRIFT_CASES = [
    "libero_goal-03/camera_staleness/wrist-delay1-v1",
    "libero_goal-03/target_object_masking/ratio50-always-v1",
    "libero_object-01/camera_staleness/wrist-delay1-v1",
]
MEASURED_MUJOCO = ("3.2.3", "3.3.7", "3.8.1")


def test_fork_drift_check_reports_no_drift_and_names_a_moved_fingerprint(fork_python, tmp_path):
    """robosuite 1.4 fork, no toolkit: `python -m vpro_libero_fork verify PACK --simulate` re-settles
    the pack's cases in the fork's env against the fingerprints the pack carries: no drift; with a
    fingerprint whose object was moved 1 cm, exit status 1 naming that case and only it."""
    python, config = fork_python
    catalog = load_catalog(paths.catalog_path())
    pack = write_pack(select_cases(catalog, DRIFT_CASES), tmp_path / "pack", catalog, paths.catalog_path())
    prints = json.loads((pack / fp.FILE_NAME).read_text())
    fork_mujoco = subprocess.run(
        [str(python), "-c", "from importlib import metadata; print(metadata.version('mujoco'))"],
        capture_output=True,
        text=True,
        check=True,
    ).stdout.strip()
    # Another MuJoCo than the fingerprints' would be checked against the settle table, not assumed.
    assert {fork_mujoco, prints["simulator"]["mujoco"]} <= set(MEASURED_MUJOCO)

    status, rows, out = run_drift_check(python, config, pack, "--trials", "2")
    assert status == 0, out
    assert f"this environment: mujoco {fork_mujoco} / robosuite 1.4" in out
    assert set(rows) == set(DRIFT_CASES)
    for case, row in rows.items():
        assert row["status"] == "ok" and row["trials"] == 2, (case, row)
        if fork_mujoco == prints["simulator"]["mujoco"]:
            assert row["displacement_cm"] == 0.0 and row["tilt_deg"] == 0.0, (case, row)  # the same simulator

    moved = DRIFT_CASES[2]
    trial = prints["cases"][moved]["trials"]["0"]
    name = sorted(trial["objects"])[0]
    trial["objects"][name][0] += 0.01
    edited = tmp_path / "edited.json"
    edited.write_text(json.dumps(prints))
    status, rows, out = run_drift_check(python, config, pack, "--fingerprints", str(edited), "--trials", "1")
    assert status == 1, out
    assert f"drifted: {moved}" in out.splitlines()
    assert rows[moved]["status"] == "drifted" and 0.9 < rows[moved]["displacement_cm"] < 1.1, rows[moved]
    assert all(rows[c]["status"] == "ok" for c in DRIFT_CASES[:2]), rows
