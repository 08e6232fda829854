"""A pack registered in a LIBERO environment that does not have the toolkit (a "fork"): LIBERO's
own benchmark API builds every pack scene, loads every initial state with torch.load, and steps.

The fork environment is made by scripts/make-fork-venv.sh (LIBERO, robosuite, mujoco, CPU torch;
about 2 minutes the first time, reused afterwards under out/fork-venv)."""
import json
import os
import subprocess
from pathlib import Path

import pytest

from vpro_assets import paths
from vpro_assets.catalog import load_catalog
from vpro_assets.packs.writer import write_pack
from vpro_assets.selection import select_cases

pytestmark = pytest.mark.fork
FORK_VENV = paths.REPO_ROOT / "out" / "fork-venv"
CHECK = Path(__file__).with_name("fork_check.py")
CASES = ["libero_goal-03/camera_staleness/wrist-delay2-v1", "libero_10-09/view_unavailability/wrist-constant-v1"]


@pytest.fixture(scope="module")
def fork_python(tmp_path_factory):
    subprocess.run(["bash", str(paths.REPO_ROOT / "scripts" / "make-fork-venv.sh"), str(FORK_VENV)], check=True,
                   timeout=1800)
    python = FORK_VENV / "bin" / "python"
    site = subprocess.run([str(python), "-c", "import sysconfig; print(sysconfig.get_paths()['purelib'])"],
                          capture_output=True, text=True, check=True).stdout.strip()
    config = tmp_path_factory.mktemp("fork-config")
    root = f"{site}/libero/libero"
    (config / "config.yaml").write_text(
        f"benchmark_root: {root}\nbddl_files: {root}/bddl_files\ninit_states: {root}/init_files\n"
        f"datasets: {config}/datasets\nassets: {root}/assets\n")
    return python, config


def _run(fork_python, *args):
    python, config = fork_python
    env = {k: v for k, v in os.environ.items() if not k.startswith(("VPRO_", "PYTHONPATH"))}
    env.update(LIBERO_CONFIG_PATH=str(config), MUJOCO_GL=os.environ.get("MUJOCO_GL", "egl"))
    env["PYOPENGL_PLATFORM"] = env["MUJOCO_GL"]
    proc = subprocess.run([str(python), str(CHECK), *map(str, args)], capture_output=True, text=True,
                          timeout=1800, cwd="/", env=env)
    assert proc.returncode == 0, proc.stderr[-3000:]
    line = next(l for l in proc.stdout.splitlines() if l.startswith("REPORT "))
    return json.loads(line[len("REPORT "):])


@pytest.fixture(scope="module")
def pack(tmp_path_factory):
    catalog = load_catalog(paths.catalog_path())
    out = tmp_path_factory.mktemp("packs") / "pack.tar.gz"
    return write_pack(select_cases(catalog, CASES), out, catalog, paths.catalog_path())


def test_fork_runs_every_pack_scene(fork_python, pack):
    report = _run(fork_python, pack)
    assert report["idempotent"]
    tasks = {t["task"]: t for rows in report["suites"].values() for t in rows}
    assert set(report["suites"]) == {"vpro_camera_staleness", "vpro_view_unavailability"}
    assert set(tasks) == {"libero_goal-03__wrist-delay2-v1", "libero_10-09__wrist-constant-v1"}
    assert tasks["libero_10-09__wrist-constant-v1"]["language"] == "put the yellow and white mug in the microwave and close it"
    for row in tasks.values():
        assert row["init_states"] >= 10 and row["stepped"] == 10 and row["image"] == [64, 64, 3]


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
