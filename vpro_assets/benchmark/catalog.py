"""The catalog: every case of the benchmark (task x setting) as a frozen JSON record.

`build_catalog()` is a pure function of LIBERO's task files and the taxonomy; `catalog.json` is
its canonical serialisation (sorted keys, fixed layout), so a rebuild is byte-identical and
`verify_catalog()` can name the first case and field that differ.
"""

from __future__ import annotations

import json
from collections import Counter
from collections.abc import Iterator
from importlib import metadata
from pathlib import Path
from typing import Any

from vpro_assets.benchmark import allocation
from vpro_assets.benchmark import lock as scene_lock_mod
from vpro_assets.benchmark import taxonomy as tx
from vpro_assets.benchmark.variants import BASE, Variant, variant_params
from vpro_assets.core.atomic import write_text_atomic
from vpro_assets.core.errors import CatalogError, UnknownIdError
from vpro_assets.core.hashing import canonical_json
from vpro_assets.core.seeding import SEED_SCHEME, TRIALS_PER_CASE, trial_seeds
from vpro_assets.libero import bridge as libero_bridge
from vpro_assets.libero.tasks import TaskRecord, load_tasks

SCHEMA_VERSION = 1
# Libraries whose versions decide what cases and artifacts contain.
RECORDED_LIBRARIES = (
    "hf-libero",
    "robosuite",
    "mujoco",
    "bddl",
    "numpy",
    "trimesh",
    "manifold3d",
    "coacd",
    "usd-core",
    "yourdfpy",
)
CASE_FIELDS = (
    "id",
    "suite",
    "task",
    "task_name",
    "dimension",
    "category",
    "setting",
    "level",
    "indicator",
    "params",
    "language",
    "trial_seeds",
    "init_states",
    "artifacts",
)


def case_id(task: TaskRecord, setting: tx.Setting, variant: Variant | None = None) -> str:
    """`libero_goal-03/target_object_masking/ratio50-before_grasp-v1`; a variant other than the
    base one adds its suffix: `libero_10-09/task_precondition_variation/receptacle_openness-v1-open25`."""
    suffix = variant.suffix if variant else ""
    return f"{task.key}/{setting.id.removeprefix('vpro/')}{suffix}"


def normal_id(task: TaskRecord) -> str:
    return f"{task.key}/normal"


def _libero_init_ref(task: TaskRecord) -> dict:
    return {"source": "libero", "file": task.init_relpath, "rows": list(range(TRIALS_PER_CASE))}


def _case(task: TaskRecord, setting: tx.Setting, variant: Variant, scene_lock: dict | None = None) -> dict:
    cat = tx.category(setting.category)
    cid = case_id(task, setting, variant)
    scene = cat.level == tx.SCENE
    # Scene cases: artifact hashes recorded by `vpro build` in the committed lock file.
    built = (scene_lock or {}).get(cid) if scene else None
    init_ref = {"source": "generated", "file": None, "rows": list(range(TRIALS_PER_CASE))}
    artifacts: dict = {}
    if built:
        init_ref["file"] = scene_lock_mod.init_file(cid, built)
        artifacts = scene_lock_mod.case_artifacts(cid, built)
    return {
        "id": cid,
        "suite": task.suite,
        "task": task.key,
        "task_name": task.name,
        "language": task.language,
        "instruction": task.instruction,
        "dimension": cat.dimension,
        "category": cat.id,
        "indicator": cat.indicator,
        "level": cat.level,
        "setting": setting.id,
        # The base variant's parameters are the setting's; another variant adds its own (and `variant`).
        "params": variant_params(setting, variant),
        "trial_seeds": trial_seeds(cid),
        # Scene cases get frozen initial states of their own from the generators.
        "init_states": init_ref if scene else _libero_init_ref(task),
        "artifacts": artifacts,
    }


def library_versions() -> dict[str, str]:
    versions = {}
    for name in RECORDED_LIBRARIES:
        try:
            versions[name] = metadata.version(name)
        except metadata.PackageNotFoundError:
            versions[name] = "not installed"
    return versions


def build_catalog(tasks: tuple[TaskRecord, ...] | None = None) -> dict[str, Any]:
    tasks = tasks or load_tasks()
    chosen = allocation.select(tasks, libero_bridge.SUITES)
    scene_lock = scene_lock_mod.load()
    cases = [_case(c.task, c.setting, c.variant, scene_lock) for s in tx.SETTINGS for c in chosen[s.id]]
    per_category = Counter(c["category"] for c in cases)
    header = {
        "benchmark": "LIBERO-VPro",
        "schema_version": SCHEMA_VERSION,
        "taxonomy_version": tx.TAXONOMY_VERSION,
        "library_versions": library_versions(),
        "seed_scheme": SEED_SCHEME,
        "selection_rule": " ".join((allocation.__doc__ or "").split()),
        "pinned_counts": {p.category: {"cases": p.cases, "source": p.source} for p in allocation.PINNED},
        "totals": {
            "cases": len(cases),
            "settings": len({c["setting"] for c in cases}),
            "categories": len(per_category),
            "dimensions": len({c["dimension"] for c in cases}),
            "tasks": len(tasks),
            "trials_per_case": TRIALS_PER_CASE,
            "episodes": len(cases) * TRIALS_PER_CASE,
        },
        "cases_per_category": dict(per_category),
        "variant_cases": sum(c["params"].get("variant", BASE) != BASE for c in cases),
    }
    normal = [
        {
            "id": normal_id(t),
            "suite": t.suite,
            "task": t.key,
            "task_name": t.name,
            "language": t.language,
            "instruction": t.instruction,
            "trial_seeds": trial_seeds(normal_id(t)),
            "init_states": _libero_init_ref(t),
        }
        for t in tasks
    ]
    return {
        "header": header,
        "dimensions": [vars(d) for d in tx.DIMENSIONS],
        "categories": [vars(c) for c in tx.CATEGORIES],
        "settings": [s.to_json() for s in tx.SETTINGS],
        "tasks": [t.to_json() for t in tasks],
        "normal": normal,
        "cases": cases,
    }


def dumps(catalog: dict) -> str:
    """Canonical text: sorted keys, one-space indent, trailing newline."""
    return canonical_json(catalog)


def write_catalog(catalog: dict, path: Path) -> None:
    write_text_atomic(path, dumps(catalog))


def load_catalog(path: Path) -> dict:
    """Read and structurally check a catalog; every problem is a CatalogError naming it."""
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise CatalogError(f"{path}: no such catalog; build one with `vpro catalog build`") from None
    except UnicodeDecodeError as exc:
        raise CatalogError(f"{path}: not UTF-8 text ({exc.reason} at byte {exc.start})") from None
    try:
        data = json.loads(text)
    except json.JSONDecodeError as exc:
        truncated = "" if text.rstrip().endswith("}") else " (the file looks truncated: it does not end with '}')"
        raise CatalogError(
            f"{path}: invalid JSON at line {exc.lineno}, column {exc.colno}: {exc.msg}{truncated}"
        ) from None
    if not isinstance(data, dict) or not isinstance(data.get("header"), dict):
        raise CatalogError(f"{path}: not a catalog (expected a JSON object with a 'header')")
    version = data["header"].get("schema_version")
    if version != SCHEMA_VERSION:
        raise CatalogError(f"{path}: schema_version {version!r}, this toolkit reads schema_version {SCHEMA_VERSION}")
    cases = data.get("cases")
    if not isinstance(cases, list):
        raise CatalogError(f"{path}: 'cases' must be a list")
    for i, case in enumerate(cases):
        missing = [f for f in CASE_FIELDS if not isinstance(case, dict) or f not in case]
        if missing:
            where = case.get("id", f"#{i}") if isinstance(case, dict) else f"#{i}"
            raise CatalogError(f"{path}: case {where} lacks field(s) {', '.join(missing)}")
    declared = data["header"].get("totals", {}).get("cases")
    if declared != len(cases):
        raise CatalogError(f"{path}: header.totals.cases is {declared!r} but the file holds {len(cases)} cases")
    ids = Counter(c["id"] for c in cases)
    dupes = [i for i, n in ids.items() if n > 1]
    if dupes:
        raise CatalogError(f"{path}: duplicate case id {dupes[0]}")
    return data


def _diff(a: Any, b: Any, where: str) -> Iterator[str]:
    if isinstance(a, dict) and isinstance(b, dict):
        for key in sorted(set(a) | set(b)):
            path = f"{where}.{key}" if where else key
            if key not in b:
                yield f"{path}: not in the rebuild"
            elif key not in a:
                yield f"{path}: missing (rebuild has {json.dumps(b[key])[:80]})"
            else:
                yield from _diff(a[key], b[key], path)
    elif isinstance(a, list) and isinstance(b, list) and len(a) == len(b):
        for i, (x, y) in enumerate(zip(a, b)):
            yield from _diff(x, y, f"{where}[{i}]")
    elif a != b or type(a) is not type(b):
        yield f"{where}: committed {json.dumps(a)[:80]}, rebuilt {json.dumps(b)[:80]}"


def differences(committed: dict, rebuilt: dict) -> list[str]:
    """Human-readable differences, cases keyed by id so a reordering or an edit names the case."""
    out = []
    for section in sorted(set(committed) | set(rebuilt)):
        a, b = committed.get(section), rebuilt.get(section)
        if section in ("cases", "normal") and isinstance(a, list) and isinstance(b, list):
            a_ids = {c.get("id"): c for c in a if isinstance(c, dict)}
            b_ids = {c["id"]: c for c in b}
            out += [f"{section}: case {i} is not in the rebuild" for i in a_ids if i not in b_ids]
            out += [f"{section}: case {i} is missing" for i in b_ids if i not in a_ids]
            for cid in b_ids:
                if cid in a_ids:
                    out += [f"case {cid}: field {d}" for d in _diff(a_ids[cid], b_ids[cid], "")]
            if not out and [c.get("id") for c in a] != [c["id"] for c in b]:
                out.append(f"{section}: cases are in a different order")
        else:
            out += list(_diff(a, b, section))
    return out


def verify_catalog(path: Path) -> tuple[dict, list[str]]:
    """Rebuild in memory and compare, first as data then byte for byte."""
    committed = load_catalog(path)
    rebuilt = build_catalog()
    diffs = differences(committed, rebuilt)
    if not diffs and Path(path).read_text(encoding="utf-8") != dumps(rebuilt):
        diffs = [
            f"{path}: same data but not in canonical form (sorted keys, indent 1); rewrite with `vpro catalog build`"
        ]
    return committed, diffs


def find_case(catalog: dict, cid: str) -> dict:
    for case in catalog["cases"] + catalog.get("normal", []):
        if case["id"] == cid:
            return case
    raise UnknownIdError("case", cid, [c["id"] for c in catalog["cases"] + catalog.get("normal", [])])
