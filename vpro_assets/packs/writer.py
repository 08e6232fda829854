"""Write a pack: the fork-facing LIBERO layout for a selection of cases.

```
<pack>/
  manifest.json                     every other file's sha256 and size; suites, objects, provenance
  README.md                         how to register the pack in a LIBERO fork
  vpro_libero_fork.py               registration, observation wrapper, drift check (packs/fork_runtime.py, imports renamed)
  _vpro_runtime/                    the toolkit's code it imports (packs/vendor.py)
  settle_fingerprints.json          the settled starts of its cases under the reference simulator (fork_drift.py)
  taxonomy.json                     dimensions, categories, settings
  cases/<suite>/<name>.json         each case's spec (catalog record + where its files are)
  bddl_files/<suite>/<name>.bddl    LIBERO BDDL, one per case
  init_files/<suite>/<name>.pruned_init   LIBERO's initial-state format (torch.load-able)
  assets/<object>/...               generated objects (MJCF + meshes), referenced relatively
```
One suite per category, named `vpro_<category>`; a case's task name is `<task>__<setting name>`.
Observation-level cases carry the base task's BDDL and LIBERO's initial states unchanged, and their
task record; the perturbation is applied at run time by `vpro_libero_fork.wrap(env, case)`.
"""

from __future__ import annotations

import hashlib
import json
import shutil
import tempfile
from pathlib import Path

from vpro_assets import __version__
from vpro_assets.benchmark import fingerprints as fp
from vpro_assets.benchmark.catalog import library_versions
from vpro_assets.benchmark.taxonomy import SCENE
from vpro_assets.core import paths
from vpro_assets.core.hashing import canonical_json, mjcf_tree_files
from vpro_assets.libero import bridge as libero_bridge
from vpro_assets.libero.tasks import libero_instruction
from vpro_assets.objects.registry import content_sha256
from vpro_assets.packs import archive, vendor
from vpro_assets.packs import manifest as mf
from vpro_assets.packs.manifest import PackError
from vpro_assets.packs.wrap import with_task_record

FORK_MODULE = vendor.FORK_MODULE
README = """# LIBERO-VPro pack

Register this pack inside any LIBERO installation (one call), then run its suites with the fork's
own code:

```python
import sys; sys.path.insert(0, "<this folder>")
import vpro_libero_fork
vpro_libero_fork.register("<this folder>")
from libero.libero import benchmark
suite = benchmark.get_benchmark_dict()["<suite>"]()
```

Suites: {suites}. Observation-level cases: `env = vpro_libero_fork.wrap(env, case)` around the
fork's env, and `vpro_libero_fork.reset(env, case, trial, init_states)` to seed and reset as the
frozen scenes expect (see docs/packs.md of libero-vpro). `manifest.json` lists every file with its sha256;
`vpro pack verify <this folder>` checks them. Whether this simulator starts the cases as the
reference simulator did (`settle_fingerprints.json`): `python -m vpro_libero_fork verify . --simulate`
in this folder (exit status 1 names the cases that drifted).
"""


def pack_names(case: dict) -> tuple[str, str]:
    """(suite, task name) of a case inside a pack: the task and the case id's last part, which is the
    setting's for a base case and adds the variant's suffix for a variant (so variants never collide)."""
    return f"vpro_{case['category']}", f"{case['task']}__{case['id'].split('/', 2)[2]}"


def _case_sources(case: dict) -> dict:
    """Source files of a case: its BDDL, its initial states and any generated objects."""
    if case["level"] == SCENE:
        return _scene_sources(case)
    return {
        "bddl": libero_bridge.bddl_path(case["suite"], case["task_name"]),
        "init_states": libero_bridge.init_state_path(case["suite"], case["task_name"]),
        "objects": [],
    }


def _scene_sources(case: dict) -> dict:
    """Files of a built scene case, read from its build record (nothing is registered or built)."""
    meta_path = paths.scene_case_dir(case["id"]) / paths.SCENE_META
    if not meta_path.is_file():
        raise PackError(
            f"case {case['id']} changes the scene and its artifacts are not built; "
            f"run `vpro build --select {case['id']}` first"
        )
    meta = json.loads(meta_path.read_text())
    files = meta["files"]
    objects = []
    for name, info in sorted(meta.get("generated_objects", {}).items()):
        xml = paths.objects_root() / name / f"{name}.xml"
        objects.append(
            {
                "name": name,
                "dir": paths.objects_root() / name,
                "xml": f"{name}.xml",
                "template": info.get("template"),
                "sha256": content_sha256(xml),
            }
        )
    return {
        "bddl": paths.scene_case_dir(case["id"]) / next(f for f in files if f.endswith(".bddl")),
        "init_states": paths.scene_case_dir(case["id"]) / next(f for f in files if f.endswith(".pruned_init")),
        "objects": objects,
    }


def _copy_object(obj: dict, assets: Path) -> None:
    """The object's files (`core.hashing.mjcf_tree_files`: its folder plus shared textures it
    references) at the same relative places under assets/ as under out/objects/."""
    src_root = Path(obj["dir"]).resolve().parent
    for path in mjcf_tree_files(Path(obj["dir"]) / obj["xml"]):
        _copy(path, assets / path.relative_to(src_root))


def _copy(src: Path, dest: Path) -> None:
    dest.parent.mkdir(parents=True, exist_ok=True)
    shutil.copyfile(src, dest)


def _check_no_absolute_paths(root: Path) -> None:
    forbidden = {
        str(paths.REPO_ROOT),
        str(libero_bridge.libero_root()),
        str(libero_bridge.assets_root()),
        str(Path.home()),
    }
    for path in root.rglob("*"):
        if path.suffix in (".xml", ".bddl", ".json", ".urdf", ".usda", ".md", ".mtl", ".obj"):
            text = path.read_text(encoding="utf-8", errors="replace")
            hit = next((f for f in forbidden if f and f in text), None)
            if hit:
                raise PackError(f"{path.relative_to(root)} contains the absolute path {hit}; packs must be relocatable")


def pack_fingerprints(cases: list[dict], toolkit: dict) -> dict:
    """The fingerprints a pack carries: each case's own entry of the toolkit's fingerprint file, or
    for an observation case (which starts as its task's Normal baseline) the Normal one, marked
    `inherits`. A case without either (a scene case not fingerprinted yet) is left out."""
    cases_out = {}
    for case in cases:
        entry = toolkit["cases"].get(case["id"])
        normal = f"{case['task']}/normal"
        if entry is None and case["level"] != SCENE and normal in toolkit["cases"]:
            entry = dict(toolkit["cases"][normal], inherits=normal)
        if entry is not None:
            cases_out[case["id"]] = entry
    return {k: v for k, v in toolkit.items() if k != "cases"} | {"cases": cases_out}


def _fill(root: Path, cases: list[dict], catalog: dict, catalog_sha: str) -> None:
    suites: dict[str, list[dict]] = {}
    objects: dict[str, dict] = {}
    for case in cases:
        suite, name = pack_names(case)
        sources = _case_sources(case)
        _copy(Path(sources["bddl"]), root / "bddl_files" / suite / f"{name}.bddl")
        _copy(Path(sources["init_states"]), root / "init_files" / suite / f"{name}.pruned_init")
        for obj in sources["objects"]:
            if obj["name"] not in objects:
                _copy_object(obj, root / "assets")
                objects[obj["name"]] = {k: v for k, v in obj.items() if k != "dir"} | {
                    "xml": f"assets/{obj['name']}/{obj['xml']}"
                }
        language = libero_instruction(case["task_name"])
        spec = dict(
            with_task_record(case, catalog),
            pack={
                "suite": suite,
                "name": name,
                "instruction": language,
                "bddl": f"bddl_files/{suite}/{name}.bddl",
                "init_states": f"init_files/{suite}/{name}.pruned_init",
            },
        )
        (root / "cases" / suite).mkdir(parents=True, exist_ok=True)
        (root / "cases" / suite / f"{name}.json").write_text(canonical_json(spec))
        suites.setdefault(suite, []).append({"name": name, "language": language, "case": case["id"]})
    (root / "taxonomy.json").write_text(
        canonical_json({k: catalog[k] for k in ("dimensions", "categories", "settings")})
    )
    vendor.write_runtime(root)
    prints = pack_fingerprints(cases, fp.load())
    (root / fp.FILE_NAME).write_text(fp.dumps(prints))
    (root / "README.md").write_text(README.format(suites=", ".join(f"`{s}`" for s in sorted(suites))))
    _check_no_absolute_paths(root)
    files = mf.file_entries(root)
    manifest = {
        "pack_format": mf.PACK_FORMAT,
        "schema_version": mf.PACK_SCHEMA_VERSION,
        "pack_version": __version__,
        "pack_id": hashlib.sha256(json.dumps(files, sort_keys=True).encode()).hexdigest(),
        "catalog_sha256": catalog_sha,
        "taxonomy_version": catalog["header"]["taxonomy_version"],
        "library_versions": library_versions(),
        "cases": [c["id"] for c in cases],
        "suites": suites,
        "objects": [objects[k] for k in sorted(objects)],
        "settle_fingerprints": {
            "file": fp.FILE_NAME,
            "sha256": files[fp.FILE_NAME]["sha256"],
            "simulator": prints["simulator"],
            "cases": len(prints["cases"]),
        },
        "files": files,
    }
    (root / mf.MANIFEST).write_text(mf.dumps(manifest))


def write_pack(cases: list[dict], out: Path, catalog: dict, catalog_file: Path) -> Path:
    """Write the pack as a folder, or as a deterministic archive when `out` ends in .tar.gz.
    Nothing is left half-written: the pack is assembled in a temporary folder and moved in."""
    if not cases:
        raise PackError("the selection is empty; nothing to pack")
    out = Path(out)
    catalog_sha = mf.sha256_file(catalog_file)
    out.parent.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory(prefix=".vpro-pack-", dir=out.parent) as tmp:
        stage = Path(tmp) / "pack"
        stage.mkdir()
        _fill(stage, cases, catalog, catalog_sha)
        if out.name.endswith(archive.ARCHIVE_SUFFIX):
            pack_id = json.loads((stage / mf.MANIFEST).read_text())["pack_id"]
            archive.write_archive(stage, out, top=f"vpro_pack-{pack_id[:12]}")
        else:
            if out.exists():
                shutil.rmtree(out) if out.is_dir() else out.unlink()
            stage.rename(out)
    return out


def open_pack(pack: Path, workdir: Path) -> Path:
    """A pack folder from a folder or an archive (extracted into `workdir`)."""
    pack = Path(pack)
    if pack.is_file():
        return archive.extract_archive(pack, workdir)
    if not pack.is_dir():
        raise PackError(f"{pack}: no such pack folder or archive")
    return pack


def verify_pack(pack: Path) -> tuple[dict, mf.Mismatch]:
    with tempfile.TemporaryDirectory(prefix="vpro-pack-verify-") as tmp:
        root = open_pack(pack, Path(tmp))
        manifest = mf.read_manifest(root)
        return manifest, mf.compare(manifest, root)
