"""`vpro build`: scene cases to files in out/, content-addressed, parallel, atomic, resumable.

Layout (relative to out/):
    scene/<task>/<category>/<setting>/            one directory per case (its id is the path)
        <task_name>.bddl                           the variant, LIBERO's BDDL dialect
        <task_name>.pruned_init                    10 frozen initial states, LIBERO's format
        init_states.npz                            the same states as numpy
        meta.json                                  input hash, the rule's choices, file hashes
    objects/<name>/                                generated MJCF objects shared by cases
    scene/artifact_hashes.json is not written here: hashes go to the committed lock file
    (vpro_assets/scene/lock.py).

A case is rebuilt only when its input hash changes (generator name and version, the case record,
the base task's BDDL and initial states, the pool table, the toolkit's build version, library
versions). Each case is written to a temporary directory and renamed into place, so an
interrupted build leaves whole cases or none; a rerun resumes with the cases still missing.
"""

from __future__ import annotations

import json
import logging
import os
import shutil
import time
from concurrent.futures import ProcessPoolExecutor, as_completed
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from tqdm import tqdm

from vpro_assets.core import mjcache, mjlog, numerics, paths
from vpro_assets.core.atomic import publish_dir
from vpro_assets.core.errors import VProError
from vpro_assets.core.hashing import canonical_json, sha256_bytes
from vpro_assets.core.memory import peak_rss_mb
from vpro_assets.objects.registry import register_mjcf_object
from vpro_assets.scene import bddl_doc, case_key, plugins, sim, state_files
from vpro_assets.scene.base_scene import BaseScene, base_scene
from vpro_assets.scene.context import GenContext
from vpro_assets.scene.init_gen import trial_state
from vpro_assets.scene.stages import StageClock
from vpro_assets.scene.variant import GeneratedObject, SceneVariant

log = logging.getLogger(__name__)


@dataclass
class CaseResult:
    case_id: str
    status: str  # "built", "unchanged", "failed"
    seconds: float = 0.0
    stages: dict = field(default_factory=dict)
    error: str = ""
    files: dict = field(default_factory=dict)  # relative path -> sha256
    physics: dict = field(default_factory=dict)  # stage -> seconds of MuJoCo in it (inside physics.metered())
    peak_rss_mb: float = 0.0  # the worker's largest resident memory when the case ended
    peak_child_rss_mb: float = 0.0  # and that of its largest child (a generated object's), if any


def ensure_objects(generated: list[GeneratedObject], case_id: str, clock: StageClock | None = None) -> dict[str, Path]:
    """Write (once, atomically) and register the generated objects a case needs; the seconds a
    shared producer reports per stage (mesh work) are added to `clock` as `object_<stage>`, and the
    peak memory of the child process it generated in, if any."""
    out = {}
    for obj in generated:
        final = paths.objects_root() / obj.name
        xml = final / f"{obj.name}.xml"
        if obj.shared:  # the producer caches, lays out and publishes its files itself
            written = obj.write(paths.objects_root())
            if not isinstance(written, Path):
                xml = written.xml_path
                if clock is not None:
                    for stage, seconds in written.timings.items():
                        clock.wall[f"object_{stage}"] = clock.wall.get(f"object_{stage}", 0.0) + seconds
                    clock.peak_child_rss_mb = max(clock.peak_child_rss_mb, written.peak_rss_mb)
            else:
                xml = written
        elif not xml.is_file():
            tmp = paths.objects_root() / f".tmp-{obj.name}-{os.getpid()}"
            shutil.rmtree(tmp, ignore_errors=True)
            written = obj.write(tmp)
            if not isinstance(written, Path) or written.name != xml.name:
                raise VProError(f"case {case_id}: generated object {obj.name} wrote {written}, expected {xml.name}")
            publish_dir(tmp, final)
        register_mjcf_object(obj.name, xml, template=obj.template)
        out[obj.name] = xml
    return out


def _bddl_name(task) -> str:
    return f"{task.name}.bddl"


def variant_bddl(case: dict, generator: str, base: BaseScene, variant: SceneVariant) -> str:
    """The BDDL text of a case's scene variant, checked against its base task's BDDL."""
    text = bddl_doc.render_variant(
        base.bddl,
        case_id=case["id"],
        generator=generator,
        base_task=case["task"],
        summary=variant.summary,
        objects=variant.objects,
        fixtures=variant.fixtures,
        regions=variant.regions,
        init=variant.init,
    )
    bddl_doc.check_variant(text, base.bddl, case["id"])
    return text


def build_case(case: dict, force: bool = False) -> CaseResult:
    """Build one scene case (or confirm it is current)."""
    started = time.perf_counter()
    cid = case["id"]
    generator = plugins.generator_for(case)
    clock = StageClock()
    key = case_key.input_hash(case, generator)  # cheap: no simulation, so a warm rebuild is quick
    if not force:
        meta = case_key.current_meta(cid, key)
        if meta is not None:
            return CaseResult(cid, "unchanged", time.perf_counter() - started, files=meta["files"])
    numerics.check(f"building {cid}")
    with clock.stage("base_scene"):
        base = base_scene(case["task"])
    # "generate" includes the object_* stages (mesh work of generated objects).
    with clock.stage("generate"):
        variant = generator.fn(GenContext(case=case, base=base))
        ensure_objects(variant.generated_objects, cid, clock)
    with clock.stage("bddl"):
        text = variant_bddl(case, f"{generator.name}-v{generator.version}", base, variant)
    hashes = _write_case(case, key, generator, base, variant, text, clock)
    return CaseResult(
        cid,
        "built",
        time.perf_counter() - started,
        clock.wall,
        files=hashes,
        physics=clock.physics,
        peak_rss_mb=peak_rss_mb(),
        peak_child_rss_mb=clock.peak_child_rss_mb,
    )


def _write_case(
    case: dict,
    key: str,
    generator: plugins.Generator,
    base: BaseScene,
    variant: SceneVariant,
    text: str,
    clock: StageClock,
) -> dict[str, str]:
    """Settle the trials' initial states in LIBERO's env of the variant and publish the case's
    files (BDDL, initial states, meta.json) at once; return {file name: sha256}."""
    cid = case["id"]
    tmp = paths.scene_root() / f".tmp-{cid.replace('/', '__')}-{os.getpid()}"
    shutil.rmtree(tmp, ignore_errors=True)
    tmp.mkdir(parents=True)
    try:
        bddl_path = tmp / _bddl_name(base.task)
        bddl_path.write_text(text)
        states = _trial_states(bddl_path, case, base, variant, clock)
        files = {
            _bddl_name(base.task): text.encode(),
            f"{base.task.name}.pruned_init": state_files.libero_init_bytes(states),
            "init_states.npz": state_files.npz_bytes(states),
        }
        for name, data in files.items():
            (tmp / name).write_bytes(data)
        hashes = {name: sha256_bytes(data) for name, data in files.items()}
        meta = {**_meta(cid, key, generator, base, variant, states, generator.revision_of(case)), "files": hashes}
        (tmp / paths.SCENE_META).write_text(canonical_json(meta))
        publish_dir(tmp, paths.scene_case_dir(cid))
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise
    return hashes


def _trial_states(bddl_path: Path, case: dict, base: BaseScene, variant: SceneVariant, clock: StageClock) -> np.ndarray:
    """One accepted initial state per trial seed, in LIBERO's env of the variant's BDDL."""
    with clock.stage("variant_env"):
        env = sim.physics_env(str(bddl_path))
    try:
        with clock.stage("settle"):
            rows = [
                trial_state(
                    env, variant, base.rows[base.trial_rows[k]], base.slots, k, base.layouts[k], fixture_seed=seed
                )
                for k, seed in enumerate(case["trial_seeds"])
            ]
    finally:
        sim.close(env)
    return np.stack(rows)


def _meta(
    cid: str,
    key: str,
    generator: plugins.Generator,
    base: BaseScene,
    variant: SceneVariant,
    states: np.ndarray,
    revision: str = "",
) -> dict:
    """meta.json of a case (without its file hashes): inputs, the rule's choices, the states' shape."""
    rows = len(states)
    return {
        "case": cid,
        "input_hash": key,
        "generator": generator.name,
        "generator_version": generator.version,
        **({"generator_revision": revision} if revision else {}),
        "build_version": case_key.BUILD_VERSION,
        "summary": variant.summary,
        "details": dict(variant.details),
        "added": list(variant.added),
        "generated_objects": {o.name: {"template": o.template} for o in variant.generated_objects},
        "init_states": {
            "rows": rows,
            "width": int(states.shape[1]),
            # trial k starts from LIBERO's row k; listed only where one was replaced
            **({"libero_rows": base.trial_rows} if base.trial_rows != list(range(rows)) else {}),
        },
    }


# MuJoCo's asset cache in a build (or validation) process: the meshes of one scene (124-199 MB
# decoded, libero_goal-03 to libero_10-09), which its variant envs compile again; 500 MB by default.
ASSET_CACHE_BYTES = 256 << 20


def worker_init() -> None:
    """What a build, validate or settle worker sets once at its start."""
    mjlog.route_warnings()
    mjcache.set_capacity(ASSET_CACHE_BYTES)
    os.environ.setdefault("LP_NUM_THREADS", "1")
    logging.getLogger("robosuite").setLevel(logging.ERROR)


def _build_group(cases: list[dict], force: bool) -> list[CaseResult]:
    """Build the cases of one task in one process (the base scene is measured once)."""
    out = []
    for case in cases:
        try:
            out.append(build_case(case, force))
        except VProError as exc:
            out.append(CaseResult(case["id"], "failed", error=str(exc)))
        except Exception as exc:  # a crash inside LIBERO/MuJoCo: report it against the case
            out.append(CaseResult(case["id"], "failed", error=f"case {case['id']}: {type(exc).__name__}: {exc}"))
    return out


def clean_partial() -> None:
    """Remove temporary directories an interrupted build left behind: those whose writer (the pid
    that ends their name) is gone, so a second build running into the same out/ is left alone."""
    for root in (paths.scene_root(), paths.objects_root()):
        if root.is_dir():
            # .staging-*: the geometry pipeline's folder for a deformed object in progress
            for tmp in [p for pattern in (".tmp-*", ".old-*", ".staging-*") for p in root.rglob(pattern)]:
                if not _writer_alive(tmp.name):
                    shutil.rmtree(tmp, ignore_errors=True)


def _writer_alive(name: str) -> bool:
    pid = name.rsplit("-", 1)[-1]
    if not pid.isdigit() or int(pid) == os.getpid():
        return False
    try:
        os.kill(int(pid), 0)
    except ProcessLookupError:
        return False
    except PermissionError:  # alive, another user's
        pass
    return True


def _collect(done: list[CaseResult], results: list[CaseResult], bar) -> None:
    """Add finished cases to the results; a failure is shown as it happens, above the bar."""
    results += done
    for r in done:
        if r.status == "failed":
            bar.write(f"FAILED {r.error}")
    bar.update(len(done))


def build(cases: list[dict], jobs: int = 1, force: bool = False, progress: bool = True) -> list[CaseResult]:
    """Build scene cases; other cases in the selection are ignored (they have no scene artifacts)."""
    cases = [c for c in cases if c.get("level") == "scene"]
    clean_partial()
    groups: dict[str, list[dict]] = {}
    for c in cases:
        groups.setdefault(c["task"], []).append(c)
    results: list[CaseResult] = []
    bar = tqdm(total=len(cases), unit="case", desc="vpro build", disable=not progress)
    try:
        if jobs <= 1 or len(groups) <= 1:
            mjcache.set_capacity(ASSET_CACHE_BYTES)  # this process builds, as a worker would
            for group in groups.values():
                for case in group:
                    _collect(_build_group([case], force), results, bar)
        else:
            # One task per submission, so each worker measures a base scene once per task it gets.
            with ProcessPoolExecutor(max_workers=jobs, initializer=worker_init) as pool:
                futures = [pool.submit(_build_group, g, force) for g in groups.values()]
                for fut in as_completed(futures):
                    _collect(fut.result(), results, bar)
    finally:
        bar.close()
    order = {c["id"]: i for i, c in enumerate(cases)}
    return sorted(results, key=lambda r: order[r.case_id])


def built_case(case_id: str) -> dict:
    """Paths of a built case; registers its generated objects with LIBERO."""
    d = paths.scene_case_dir(case_id)
    meta_path = d / paths.SCENE_META
    if not meta_path.is_file():
        raise VProError(f"case {case_id}: not built (no {meta_path}); run `vpro build --select {case_id}`")
    meta = json.loads(meta_path.read_text())
    for name, info in meta.get("generated_objects", {}).items():
        register_mjcf_object(name, paths.objects_root() / name / f"{name}.xml", template=info.get("template"))
    bddl = next(p for p in meta["files"] if p.endswith(".bddl"))
    init = next(p for p in meta["files"] if p.endswith(".pruned_init"))
    return {"dir": d, "bddl": d / bddl, "init_states": d / init, "init_states_npz": d / "init_states.npz", "meta": meta}
