"""Packs: deterministic bytes, verification that names each file, clear errors on damage."""

import json
import shutil
import subprocess
import sys
import tarfile

import pytest

from vpro_assets.benchmark import fingerprints as fp
from vpro_assets.benchmark.catalog import load_catalog
from vpro_assets.benchmark.selection import select_cases
from vpro_assets.core import paths
from vpro_assets.packs import manifest as mf
from vpro_assets.packs.archive import extract_archive
from vpro_assets.packs.fork_drift import load_fingerprints, settle_cases
from vpro_assets.packs.fork_registry import PackRegistrationError
from vpro_assets.packs.manifest import PackError
from vpro_assets.packs.writer import pack_fingerprints, pack_names, verify_pack, write_pack

OBSERVATION_CASES = [
    "libero_goal-03/camera_staleness/wrist-delay2-v1",
    "libero_object-01/target_object_masking/ratio50-after_grasp-v1",
]


@pytest.fixture(scope="module")
def catalog():
    return load_catalog(paths.catalog_path())


def _pack(catalog, out, ids=OBSERVATION_CASES):
    return write_pack(select_cases(catalog, ids), out, catalog, paths.catalog_path())


def test_archive_bytes_are_identical_across_runs_and_names(catalog, tmp_path):
    a = _pack(catalog, tmp_path / "a.tar.gz")
    b = _pack(catalog, tmp_path / "other-name.tar.gz")
    assert mf.sha256_file(a) == mf.sha256_file(b)
    folder_a, folder_b = _pack(catalog, tmp_path / "fa"), _pack(catalog, tmp_path / "fb")
    assert mf.file_entries(folder_a) == mf.file_entries(folder_b)
    assert (folder_a / "manifest.json").read_bytes() == (folder_b / "manifest.json").read_bytes()
    with tarfile.open(a) as tar:
        assert all(m.mtime == 0 and m.uid == 0 and m.uname == "" for m in tar.getmembers())


def test_pack_layout_and_manifest(catalog, tmp_path):
    root = _pack(catalog, tmp_path / "p")
    manifest = mf.read_manifest(root)
    assert sorted(manifest["cases"]) == sorted(OBSERVATION_CASES)
    assert set(manifest["suites"]) == {"vpro_camera_staleness", "vpro_target_object_masking"}
    task = manifest["suites"]["vpro_camera_staleness"][0]
    assert task == {
        "name": "libero_goal-03__wrist-delay2-v1",
        "case": OBSERVATION_CASES[0],
        "language": "open the top drawer and put the bowl inside",
    }
    for rel in (
        "bddl_files/vpro_camera_staleness/libero_goal-03__wrist-delay2-v1.bddl",
        "init_files/vpro_camera_staleness/libero_goal-03__wrist-delay2-v1.pruned_init",
        "cases/vpro_camera_staleness/libero_goal-03__wrist-delay2-v1.json",
        "taxonomy.json",
        "vpro_libero_fork.py",
        "README.md",
    ):
        assert rel in manifest["files"], rel
    assert manifest["files"] == mf.file_entries(root)
    assert manifest["catalog_sha256"] == mf.sha256_file(paths.catalog_path())
    for path in root.rglob("*"):
        if path.is_file():
            text = path.read_bytes().decode("utf-8", errors="replace")
            assert str(paths.REPO_ROOT) not in text and "site-packages" not in text, path


def test_pack_carries_the_fingerprints_of_its_cases(catalog, tmp_path):
    """Observation cases carry their task's Normal fingerprint, hashed in the manifest; a scene case
    with a fingerprint of its own gets it under its id, one without none."""
    root = _pack(catalog, tmp_path / "p")
    manifest = mf.read_manifest(root)
    toolkit = fp.load()
    entry = manifest["settle_fingerprints"]
    assert entry["file"] == fp.FILE_NAME and entry["sha256"] == mf.sha256_file(root / fp.FILE_NAME)
    assert entry["simulator"] == toolkit["simulator"] and entry["cases"] == len(OBSERVATION_CASES)
    shipped = load_fingerprints(root, manifest)
    assert (shipped["simulator"], shipped["wait_steps"]) == (toolkit["simulator"], toolkit["wait_steps"])
    for cid in OBSERVATION_CASES:
        normal = cid.split("/")[0] + "/normal"
        assert shipped["cases"][cid] == dict(toolkit["cases"][normal], inherits=normal)
    (root / fp.FILE_NAME).write_text(fp.dumps(shipped))  # canonical text: written as the toolkit's file
    assert not verify_pack(root)[1]

    scene = [c for c in catalog["cases"] if c["level"] == "scene"][:2]
    own = {"inputs": {"bddl": "b", "init_states": "i"}, "trials": {}}
    others = {cid: entry for cid, entry in toolkit["cases"].items() if cid not in {c["id"] for c in scene}}
    prints = pack_fingerprints(scene, dict(toolkit, cases={**others, scene[0]["id"]: own}))
    assert prints["cases"] == {scene[0]["id"]: own}


def test_pack_drift_check_refuses_bad_input_in_one_line(catalog, tmp_path):
    root = _pack(catalog, tmp_path / "p")
    manifest = mf.read_manifest(root)
    (tmp_path / "bad.json").write_text('{"schema_version": 99, "cases": {}}')
    for path, message in (
        (tmp_path / "bad.json", "not a fingerprint file of schema 1"),
        (tmp_path / "no", "unreadable"),
    ):
        with pytest.raises(PackRegistrationError, match=message) as err:
            load_fingerprints(root, manifest, path)
        assert "\n" not in str(err.value)
    with pytest.raises(PackRegistrationError, match="no case 'nope' in this pack"):
        settle_cases(root, load_fingerprints(root, manifest), cases=["nope"])
    with pytest.raises(PackRegistrationError, match="trials must be at least 1, got 0"):
        settle_cases(root, load_fingerprints(root, manifest), trials=0)


def test_verify_names_changed_missing_and_extra_files(catalog, tmp_path):
    root = _pack(catalog, tmp_path / "p")
    assert not verify_pack(root)[1]
    bddl = next((root / "bddl_files").rglob("*.bddl"))
    data = bytearray(bddl.read_bytes())
    data[10] ^= 1  # one byte
    bddl.write_bytes(bytes(data))
    spec = next((root / "cases").rglob("*.json"))
    spec.unlink()
    (root / "assets").mkdir()
    (root / "assets" / "stray.xml").write_text("<mujoco/>")
    _, mismatch = verify_pack(root)
    rel = lambda p: p.relative_to(root).as_posix()  # noqa: E731
    assert (
        mismatch.changed == [rel(bddl)] and mismatch.missing == [rel(spec)] and mismatch.extra == ["assets/stray.xml"]
    )
    proc = subprocess.run(
        [sys.executable, "-m", "vpro_assets.cli", "pack", "verify", str(root)],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert proc.returncode == 1
    for line in (f"changed: {rel(bddl)}", f"missing: {rel(spec)}", "extra: assets/stray.xml"):
        assert line in proc.stderr


def test_truncated_archive_and_newer_schema_are_clear_errors(catalog, tmp_path):
    archive = _pack(catalog, tmp_path / "a.tar.gz")
    truncated = tmp_path / "t.tar.gz"
    truncated.write_bytes(archive.read_bytes()[: archive.stat().st_size // 2])
    with pytest.raises(PackError, match="damaged or truncated"):
        verify_pack(truncated)
    root = extract_archive(archive, tmp_path / "x")
    manifest = json.loads((root / "manifest.json").read_text())
    manifest["schema_version"] = mf.PACK_SCHEMA_VERSION + 1
    (root / "manifest.json").write_text(json.dumps(manifest))
    with pytest.raises(PackError, match="newer than this toolkit reads"):
        verify_pack(root)
    proc = subprocess.run(
        [sys.executable, "-m", "vpro_assets.cli", "pack", "verify", str(truncated)],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert proc.returncode == 2 and "Traceback" not in proc.stderr and "truncated" in proc.stderr


def test_unbuilt_scene_case_is_refused_and_nothing_is_written(catalog, tmp_path, monkeypatch):
    monkeypatch.setenv("VPRO_OUT", str(tmp_path / "empty-out"))
    scene = next(c for c in catalog["cases"] if c["level"] == "scene")
    out = tmp_path / "never"
    with pytest.raises(PackError, match=scene["id"]):
        write_pack([scene], out, catalog, paths.catalog_path())
    assert not out.exists() and [p.name for p in tmp_path.iterdir()] == []


def test_import_copies_into_a_fork_checkout(catalog, tmp_path):
    root = _pack(catalog, tmp_path / "p")
    fork = tmp_path / "fork"
    (fork / "libero" / "libero" / "bddl_files").mkdir(parents=True)
    (fork / "libero" / "libero" / "init_files").mkdir()
    proc = subprocess.run(
        [sys.executable, "-m", "vpro_assets.cli", "import", str(root), "--into", str(fork)],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert proc.returncode == 0, proc.stderr
    copied = fork / "vpro_packs" / "p"
    assert not verify_pack(copied)[1]
    assert (fork / "libero/libero/bddl_files/vpro_camera_staleness/libero_goal-03__wrist-delay2-v1.bddl").is_file()
    assert (
        fork / "libero/libero/init_files/vpro_camera_staleness/libero_goal-03__wrist-delay2-v1.pruned_init"
    ).is_file()
    shutil.rmtree(fork / "libero")
    proc = subprocess.run(
        [sys.executable, "-m", "vpro_assets.cli", "import", str(root), "--into", str(fork)],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert proc.returncode == 2 and "not a LIBERO checkout" in proc.stderr


def test_every_case_of_the_catalog_has_its_own_pack_task_name():
    """Variants of a setting (receptacle_openness-v1-open25, -open50 ...) share the task and the
    setting, so the pack task name carries the case id's variant suffix."""
    cases = load_catalog(paths.catalog_path())["cases"]
    names = [pack_names(c) for c in cases]
    assert len(set(names)) == len(names) == 3296
    variant = next(c for c in cases if c["id"].endswith("-open25"))
    assert pack_names(variant)[1].endswith("receptacle_openness-v1-open25")
