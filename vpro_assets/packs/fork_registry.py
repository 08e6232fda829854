"""Registration of a pack's objects and suites with LIBERO's own registries, all or nothing (part of
the pack runtime, `vpro_libero_fork`; see `vpro_assets.packs.fork_runtime`).

Each generated object becomes a `MujocoXMLObject` subclass in LIBERO's `OBJECTS_DICT` under its
own name, placed like the LIBERO object it varies; each suite a `Benchmark` subclass in
`BENCHMARK_MAPPING`. Every clash is found before anything is registered. LIBERO, robosuite and
torch are the fork's own, imported inside the functions that need them.
"""

from __future__ import annotations

import copy
import json
import os
import tarfile
from pathlib import Path

from vpro_assets.core.hashing import sha256_file

SUPPORTED_SCHEMA = 1
MANIFEST = "manifest.json"


class PackRegistrationError(Exception):
    """The pack cannot be registered: unreadable, newer schema, damaged, or a name clash."""


def open_pack(pack: str | os.PathLike) -> Path:
    pack = Path(pack)
    if pack.is_file() and pack.name.endswith(".tar.gz"):
        # Extracted once, beside the archive: <name>/<the archive's single top folder>/.
        dest = pack.with_name(pack.name[: -len(".tar.gz")])
        if not any(dest.glob(f"*/{MANIFEST}")):
            try:
                with tarfile.open(pack, "r:gz") as tar:
                    tar.extractall(dest, filter="data")
            except (tarfile.TarError, EOFError, OSError) as exc:
                raise PackRegistrationError(f"{pack}: damaged or truncated archive ({exc})") from None
        tops = sorted(dest.glob(f"*/{MANIFEST}"))
        if len(tops) != 1:
            raise PackRegistrationError(f"{pack}: expected one pack folder inside, found {len(tops)}")
        pack = tops[0].parent
    if not (pack / MANIFEST).is_file():
        raise PackRegistrationError(f"{pack}: no {MANIFEST}; not a LIBERO-VPro pack")
    return pack.resolve()


def read_manifest(pack: Path) -> dict:
    try:
        manifest = json.loads((pack / MANIFEST).read_text(encoding="utf-8"))
    except (OSError, ValueError) as exc:
        raise PackRegistrationError(f"{pack / MANIFEST}: unreadable ({exc})") from None
    version = manifest.get("schema_version") if isinstance(manifest, dict) else None
    if not isinstance(version, int) or version > SUPPORTED_SCHEMA:
        raise PackRegistrationError(
            f"{pack}: pack schema_version {version!r}; this module reads up to "
            f"{SUPPORTED_SCHEMA}, use the vpro_libero_fork.py shipped in the pack"
        )
    return manifest


def check_files(pack: Path, manifest: dict) -> None:
    """Every file the manifest lists exists with its size and sha256."""
    bad = []
    for rel, entry in sorted(manifest.get("files", {}).items()):
        path = pack / rel
        if not path.is_file():
            bad.append(f"missing {rel}")
        elif path.stat().st_size != entry["size"] or sha256_file(path) != entry["sha256"]:
            bad.append(f"changed {rel}")
    if bad:
        raise PackRegistrationError(f"{pack}: does not match its manifest: " + "; ".join(bad[:10]))


def _placement(spec: dict, objects: dict) -> dict:
    """Placement attributes of a generated object: those of the LIBERO object it varies (its
    `template`), so it is placed and oriented like the original."""
    placement = {"rotation": (0.0, 0.0), "rotation_axis": "z", "object_properties": {"vis_site_names": {}}}
    template = spec.get("template")
    if template:
        probe = objects[template]()
        for key in placement:
            if hasattr(probe, key):
                placement[key] = getattr(probe, key)
    return placement


def _object_class(name: str, xml: Path, spec: dict, pack_id: str, placement: dict):
    from robosuite.models.objects import MujocoXMLObject

    def __init__(self, name=name, joints="default", **_ignored):
        # LIBERO builds fixtures with joints=None (no joint) and objects with the default free joint.
        if isinstance(joints, str) and joints == "default":
            joints = [{"type": "free", "damping": "0.0005"}]
        MujocoXMLObject.__init__(
            self, str(xml), name=name, joints=joints, obj_type="all", duplicate_collision_geoms=False
        )
        self.category_name = type(self).registered_name
        for key, value in placement.items():
            setattr(self, key, copy.deepcopy(value))

    class_name = "VproPack" + "".join(p.capitalize() for p in name.split("_"))
    return type(
        class_name,
        (MujocoXMLObject,),
        {
            "__init__": __init__,
            "registered_name": name,
            "xml_path": str(xml),
            "_vpro_pack_object": (pack_id, spec["sha256"]),
        },
    )


def _suite_class(suite: str, tasks: list[dict], pack: Path, pack_id: str):
    from libero.libero.benchmark import Benchmark, Task

    bddl_dir, init_dir = pack / "bddl_files" / suite, pack / "init_files" / suite
    entries = [
        Task(
            name=t["name"],
            language=t["language"],
            problem="Libero",
            problem_folder=str(bddl_dir),
            bddl_file=f"{t['name']}.bddl",
            init_states_file=f"{t['name']}.pruned_init",
        )
        for t in tasks
    ]

    def __init__(self, task_order_index=0):
        Benchmark.__init__(self, task_order_index=task_order_index)
        self.name = suite
        self._make_benchmark()

    def _make_benchmark(self):
        self.tasks = list(entries)  # pack order; LIBERO's task_orders assume 10 tasks
        self.n_tasks = len(self.tasks)

    def get_task_init_states(self, i):
        import torch

        return torch.load(os.path.join(init_dir, self.tasks[i].init_states_file), weights_only=False)

    return type(
        suite.upper(),
        (Benchmark,),
        {
            "__init__": __init__,
            "_make_benchmark": _make_benchmark,
            "get_task_init_states": get_task_init_states,
            "_vpro_pack_id": pack_id,
            "__doc__": f"LIBERO-VPro pack suite {suite}",
        },
    )


def register(pack: str | os.PathLike, verify: bool = True) -> dict[str, type]:
    """Register the pack's objects and suites with LIBERO; return {suite name: Benchmark class}."""
    pack = open_pack(pack)
    manifest = read_manifest(pack)
    if verify:
        check_files(pack, manifest)
    pack_id = manifest["pack_id"]
    from libero.libero import benchmark
    from libero.libero.envs import OBJECTS_DICT

    objects = {o["name"]: o for o in manifest.get("objects", [])}
    suites = manifest.get("suites", {})
    clashes = []
    for name, spec in objects.items():
        if spec.get("template") and spec["template"] not in OBJECTS_DICT:
            clashes.append(f"object {name!r} varies {spec['template']!r}, which this LIBERO does not have")
        existing = OBJECTS_DICT.get(name)
        if existing is not None and getattr(existing, "_vpro_pack_object", (None, None))[1] != spec["sha256"]:
            clashes.append(
                f"object {name!r} is already registered ({getattr(existing, 'xml_path', existing.__name__)})"
            )
    for suite in suites:
        existing = benchmark.BENCHMARK_MAPPING.get(suite.lower())
        if existing is not None and getattr(existing, "_vpro_pack_id", None) != pack_id:
            clashes.append(f"suite {suite!r} is already registered ({existing.__name__})")
    if clashes:
        raise PackRegistrationError(f"{pack}: cannot register, nothing was changed: " + "; ".join(clashes))

    added_objects, added_suites = [], []
    try:
        for name, spec in objects.items():
            if name not in OBJECTS_DICT:
                OBJECTS_DICT[name] = _object_class(
                    name, pack / spec["xml"], spec, pack_id, _placement(spec, OBJECTS_DICT)
                )
                added_objects.append(name)
        classes = {}
        for suite, tasks in suites.items():
            key = suite.lower()
            if key not in benchmark.BENCHMARK_MAPPING:
                benchmark.BENCHMARK_MAPPING[key] = _suite_class(suite, tasks, pack, pack_id)
                added_suites.append(key)
            classes[suite] = benchmark.BENCHMARK_MAPPING[key]
    except Exception:
        for name in added_objects:
            OBJECTS_DICT.pop(name, None)
        for key in added_suites:
            benchmark.BENCHMARK_MAPPING.pop(key, None)
        raise
    return classes


def unregister(pack: str | os.PathLike) -> None:
    """Remove what `register` added for this pack (LIBERO's own entries are never touched)."""
    pack = open_pack(pack)
    pack_id = read_manifest(pack)["pack_id"]
    from libero.libero import benchmark
    from libero.libero.envs import OBJECTS_DICT

    for name, cls in list(OBJECTS_DICT.items()):
        if getattr(cls, "_vpro_pack_object", (None,))[0] == pack_id:
            del OBJECTS_DICT[name]
    for key, cls in list(benchmark.BENCHMARK_MAPPING.items()):
        if getattr(cls, "_vpro_pack_id", None) == pack_id:
            del benchmark.BENCHMARK_MAPPING[key]
