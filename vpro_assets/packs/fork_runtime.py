"""Register a LIBERO-VPro pack inside any LIBERO installation: one call, then the fork's own code
runs the pack's scenes unchanged.

    import vpro_libero_fork                      # shipped at the root of every pack
    vpro_libero_fork.register("/path/to/pack")   # or vpro_assets.packs.fork_runtime.register(...)

    from libero.libero import benchmark
    suite = benchmark.get_benchmark_dict()["vpro_task_relevant_distractors"]()
    bddl = suite.get_task_bddl_file_path(0)       # or get_libero_path("bddl_files")/task.problem_folder/task.bddl_file
    init_states = suite.get_task_init_states(0)   # LIBERO's torch.load of the pack's .pruned_init

What `register` does, all or nothing (every clash is found before anything is registered):
- each generated object of the pack (deformed targets, recoloured distractors, visual-only
  copies) becomes a `MujocoXMLObject` subclass in LIBERO's `OBJECTS_DICT` under its own name;
- each suite of the pack (one per category) becomes a `Benchmark` subclass in LIBERO's
  `BENCHMARK_MAPPING`, its tasks in pack order, each task's language the base task's instruction.
A name already registered for something else (one of LIBERO's objects or suites, or another
pack's) is refused with `PackRegistrationError` and the registries are left as they were;
registering the same pack again is a no-op.

Observation-level cases (masking, corruption, view loss, staleness, contradiction, prediction
feedback) are applied around the fork's own env:

    env = vpro_libero_fork.wrap(env, case)        # case dict, the pack's case JSON path, or a case id
    for trial in range(10):
        obs = vpro_libero_fork.reset(env, case, trial, init_states)   # seed, reset, initial state
        ...                                                           # the fork's loop, unchanged

`reset` seeds LIBERO's global numpy stream with the trial's seed (`env.seed`, as the toolkit's
rollouts do) before the reset, so fixtures land where the frozen scenes were settled.

In a pack this file is `vpro_libero_fork.py`, next to the private package of the toolkit's own
perturbation code, copied by `vpro_assets.packs.vendor` with its imports renamed (this file's
included), so a fork needs neither the toolkit nor its pins: numpy, mujoco, cv2 and scipy (robosuite's
dependencies), LIBERO and robosuite. Nothing here writes a file, reads the toolkit's config or
LIBERO's, except that `register` extracts an archive beside it. The task's problem_folder is the
absolute path of the pack's suite folder, which `os.path.join` and `pathlib` both let replace the
fork's `bddl_files` root.
"""

from __future__ import annotations

import hashlib
import json
import os
import tarfile
from collections.abc import Mapping
from pathlib import Path

from vpro_assets.core.errors import InvalidParameterError
from vpro_assets.libero.task_record import TaskRecord
from vpro_assets.perturb.observer import CaseObserver

SUPPORTED_SCHEMA = 1
MANIFEST = "manifest.json"


class PackRegistrationError(Exception):
    """The pack cannot be registered: unreadable, newer schema, damaged, or a name clash."""


def _sha256(path: Path) -> str:
    digest = hashlib.sha256()
    with open(path, "rb") as handle:
        for block in iter(lambda: handle.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()


def _open_pack(pack: str | os.PathLike) -> Path:
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
        elif path.stat().st_size != entry["size"] or _sha256(path) != entry["sha256"]:
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
    import copy

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
    pack = _open_pack(pack)
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
    pack = _open_pack(pack)
    pack_id = read_manifest(pack)["pack_id"]
    from libero.libero import benchmark
    from libero.libero.envs import OBJECTS_DICT

    for name, cls in list(OBJECTS_DICT.items()):
        if getattr(cls, "_vpro_pack_object", (None,))[0] == pack_id:
            del OBJECTS_DICT[name]
    for key, cls in list(benchmark.BENCHMARK_MAPPING.items()):
        if getattr(cls, "_vpro_pack_id", None) == pack_id:
            del benchmark.BENCHMARK_MAPPING[key]


def pack_root() -> Path:
    """The pack this module was loaded from (in the toolkit: its own folder, which holds no cases)."""
    return Path(__file__).resolve().parent


def load_case(case: Mapping | str | os.PathLike, root: Path | None = None) -> dict:
    """A case: a dict as is, a case JSON file, or a case id looked up in the pack's cases/."""
    if isinstance(case, Mapping):
        return dict(case)
    path = Path(case)
    if path.suffix == ".json" and path.is_file():
        return json.loads(path.read_text(encoding="utf-8"))
    root = root or pack_root()
    for candidate in sorted((root / "cases").glob("*/*.json")):
        data = json.loads(candidate.read_text(encoding="utf-8"))
        if data.get("id") == str(case):
            return data
    raise InvalidParameterError(f"case {str(case)!r}: not a case JSON file nor a case of the pack at {root}")


class ForkEnv:
    """A fork's LIBERO env whose observations follow an observation-level case.

    Keeps LIBERO's `reset()`, `set_init_state(state)` and `step(action)` and returns raw
    (bottom-up) frames, so the fork's own flips and resizes still apply. The trial (which seeds the
    case's random streams) is the number of earlier `reset()` calls unless `env.trial` is set or
    `reset(env, case, trial)` is used. Under single-view View Unavailability the removed camera's
    key is absent from the observation (`available_cameras` lists what the policy receives).
    """

    def __init__(self, env, case: Mapping | str | os.PathLike):
        if not all(hasattr(env, m) for m in ("reset", "step", "set_init_state", "sim")):
            raise InvalidParameterError(f"wrap() needs a LIBERO env (OffScreenRenderEnv), got {type(env).__name__}")
        self.env = env
        self.case = load_case(case)
        case_id = self.case.get("id", "<case>")
        if self.case.get("level") != "observation":
            raise InvalidParameterError(
                f"case {case_id}: level {self.case.get('level')!r}, it changes the scene: build "
                "its env from the pack's BDDL instead of wrapping the base task's env"
            )
        if "task_record" not in self.case:
            raise InvalidParameterError(f"case {case_id}: no task_record; pass the pack's case JSON or its id")
        self.task = TaskRecord.from_json(self.case["task_record"])
        self.trial = 0
        self._observer: CaseObserver | None = None

    def __getattr__(self, name):
        if name in ("env", "case", "_observer"):
            raise AttributeError(name)
        return getattr(self.env, name)

    @property
    def available_cameras(self) -> tuple[str, ...]:
        return self._require().available_cameras

    def _require(self) -> CaseObserver:
        if self._observer is None:
            raise InvalidParameterError(f"case {self.case['id']}: call reset() before using the env")
        return self._observer

    def reset(self):
        raw = self.env.reset()
        self._observer = CaseObserver(self.env, self.case, self.trial, self.task)
        self.trial += 1
        return self._observer.on_reset(raw)

    def set_init_state(self, state):
        # LIBERO's loops set the initial state right after reset: the episode (step 0) starts here.
        return self._require().on_reset(self.env.set_init_state(state))

    def step(self, action, predicted_frames: Mapping | None = None):
        observer = self._require()
        observer.feed_predicted(predicted_frames)
        raw, reward, done, info = self.env.step(action)
        return observer.on_step(raw), reward, done, info

    def phase_timeline(self) -> dict:
        return self._require().phase_timeline()


def wrap(env, case: Mapping | str | os.PathLike) -> ForkEnv:
    """Wrap a fork's LIBERO env so its observations follow `case` (an observation-level case)."""
    return ForkEnv(env, case)


def reset(env, case: Mapping | str | os.PathLike, trial: int, init_states=None):
    """Start trial `trial` of `case` as the frozen scenes expect: `env.seed(case's trial seed)`,
    `env.reset()`, then (with `init_states`, the suite's `get_task_init_states(i)`) row `trial`.
    `env` is the fork's env or `wrap`'s; return the first observation (perturbed when wrapped)."""
    case = load_case(case)
    seeds = case.get("trial_seeds") or []
    if not isinstance(trial, int) or not 0 <= trial < len(seeds):
        raise InvalidParameterError(f"case {case.get('id')}: trial {trial!r} out of range (0..{len(seeds) - 1})")
    if isinstance(env, ForkEnv):
        env.trial = trial
    env.seed(int(seeds[trial]))
    obs = env.reset()
    if init_states is not None:
        if not 0 <= trial < len(init_states):
            raise InvalidParameterError(f"case {case.get('id')}: trial {trial} but {len(init_states)} initial states")
        obs = env.set_init_state(init_states[trial])
    return obs
