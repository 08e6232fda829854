"""The drift check a LIBERO fork runs with a pack alone (part of the pack runtime, `vpro_libero_fork`;
see `vpro_assets.packs.fork_runtime`): does this fork's simulator start the pack's cases as the
toolkit's reference simulator does?

A pack carries `settle_fingerprints.json` (hashed in its manifest like every file): per case id,
for each trial, the seed and initial-state row the start was settled from and the poses of the
movable objects and articulated joints after the wait steps, taken with the simulator named in
its header. Observation cases carry their task's Normal fingerprint (`inherits` names it); a
scene case carries its own once taken, under its own id.

`settle_cases` settles each fingerprinted trial in the fork's own env, as `vpro settle` does: LIBERO's
`ControlEnv` of the case's BDDL without a renderer or camera observations, `env.seed(seed)`,
`reset()` (`seeded_reset`: the fixtures as a new env's), `set_init_state(row)`, the wait steps of
no-op actions. It compares the starts with `vpro_assets.libero.settled.compare`, the tolerances of
`vpro drift` (one definition, shipped in the pack). Cases of the same scene share one env, and cases
of the same start (the observation cases of one task) are settled once.
"""

from __future__ import annotations

import json
import os
from collections.abc import Callable, Iterable, Mapping
from pathlib import Path

from vpro_assets.core.hashing import sha256_file
from vpro_assets.libero.names import CAMERAS
from vpro_assets.libero.settled import (
    NOOP_ACTION,
    SCHEMA_VERSION,
    compare,
    empty_row,
    read_start,
    seeded_reset,
    simulator_versions,
)
from vpro_assets.packs.fork_registry import (
    PackRegistrationError,
    check_files,
    open_pack,
    read_manifest,
    register,
)

NOT_FINGERPRINTED = "no fingerprint"


def load_fingerprints(pack: Path, manifest: Mapping, path: str | os.PathLike | None = None) -> dict:
    """The pack's fingerprints (or those of `path`, for example an edited copy)."""
    if path is None:
        entry = manifest.get("settle_fingerprints")
        if not entry:
            raise PackRegistrationError(
                f"{pack}: this pack carries no settled-scene fingerprints (packed by an older toolkit: pack it again)"
            )
        path = pack / entry["file"]
    try:
        data = json.loads(Path(path).read_text(encoding="utf-8"))
    except (OSError, ValueError) as exc:
        raise PackRegistrationError(f"{path}: unreadable fingerprints ({exc})") from None
    if (
        not isinstance(data, dict)
        or data.get("schema_version") != SCHEMA_VERSION
        or not isinstance(data.get("cases"), dict)
    ):
        raise PackRegistrationError(f"{path}: not a fingerprint file of schema {SCHEMA_VERSION}")
    return data


def case_specs(pack: Path) -> dict[str, dict]:
    """Case id -> the pack's case JSON."""
    specs = {}
    for path in sorted((pack / "cases").glob("*/*.json")):
        spec = json.loads(path.read_text(encoding="utf-8"))
        specs[spec["id"]] = spec
    return specs


def settle_start(env, state, seed: int, wait_steps: int) -> dict:
    """Settle one start in a LIBERO env (an episode's first policy frame) and read it."""
    seeded_reset(env, seed)
    env.set_init_state(state)
    for _ in range(wait_steps):
        env.step(NOOP_ACTION)
    return read_start(env.env)


def _control_env(bddl: Path):
    from libero.libero.envs.env_wrapper import ControlEnv

    return ControlEnv(
        bddl_file_name=str(bddl),
        has_renderer=False,
        has_offscreen_renderer=False,
        use_camera_obs=False,
        camera_names=list(CAMERAS),
    )


def _init_states(path: Path):
    import torch

    return torch.load(str(path), weights_only=False)


def settle_cases(
    pack: Path,
    fingerprints: Mapping,
    cases: Iterable[str] | None = None,
    trials: int | None = None,
    progress: Callable[[str], None] | None = None,
) -> list[dict]:
    """Settle the fingerprinted trials of the pack's cases (`cases`: ids, default all; `trials`: the
    first N of each) in this environment; one `compare` row per case, and a `no fingerprint` row
    for each case of the pack without one (not checked). The pack must be registered (its objects)."""
    specs = case_specs(pack)
    wanted = list(specs) if cases is None else list(cases)
    unknown = [c for c in wanted if c not in specs]
    if unknown:
        raise PackRegistrationError(f"{pack}: no case {unknown[0]!r} in this pack")
    if trials is not None and trials < 1:
        raise PackRegistrationError(f"trials must be at least 1, got {trials}")
    records, rows = [], []
    by_bddl: dict[str, list[tuple[str, dict[str, str], dict[str, Path]]]] = {}  # one env per scene
    for cid in wanted:
        if cid not in fingerprints["cases"]:
            rows.append(empty_row(cid) | {"status": NOT_FINGERPRINTED, "note": "not checked"})
            continue
        files = {"bddl": pack / specs[cid]["pack"]["bddl"], "init_states": pack / specs[cid]["pack"]["init_states"]}
        inputs = {key: sha256_file(path) for key, path in files.items()}
        by_bddl.setdefault(inputs["bddl"], []).append((cid, inputs, files))
    starts: dict[tuple, dict] = {}  # (init_states sha256, row, seed) -> settled start: shared by cases
    for group in by_bddl.values():
        env = _control_env(group[0][2]["bddl"])
        try:
            for cid, inputs, files in group:
                if progress:
                    progress(cid)
                states = _init_states(files["init_states"])
                recorded = fingerprints["cases"][cid]["trials"]
                for trial in sorted(recorded, key=int)[:trials]:
                    seed, row = recorded[trial]["seed"], recorded[trial]["init_row"]
                    key = (inputs["init_states"], row, seed)
                    if key not in starts:
                        starts[key] = settle_start(env, states[row], seed, fingerprints["wait_steps"])
                    records.append(
                        {
                            "case": cid,
                            "trial": int(trial),
                            "seed": seed,
                            "inputs": {**inputs, "init_row": row},
                        }
                        | starts[key]
                    )
        finally:
            env.close()
    return compare(fingerprints, records) + rows


def verify(
    pack: str | os.PathLike,
    simulate: bool = False,
    *,
    fingerprints: str | os.PathLike | None = None,
    cases: Iterable[str] | None = None,
    trials: int | None = None,
    progress: Callable[[str], None] | None = None,
) -> dict:
    """Check the pack's files against its manifest (PackRegistrationError naming what differs); with
    `simulate`, also re-settle its fingerprinted cases in this environment (`settle_cases`; the
    pack is registered first, so its scene cases' objects exist). Returns the report: `rows` (one
    per case), the `drifted` and `unchecked` (stale or missing) case ids, `ok`, both simulators."""
    root = open_pack(pack)
    manifest = read_manifest(root)
    check_files(root, manifest)
    report: dict = {"pack": str(root), "files": len(manifest.get("files", {})), "rows": []}
    if simulate:
        prints = load_fingerprints(root, manifest, fingerprints)
        register(root, verify=False)  # a no-op when already registered
        report["rows"] = settle_cases(root, prints, cases, trials, progress)
        report["fingerprint_simulator"] = prints["simulator"]
        report["simulator"] = simulator_versions()
    report["drifted"] = [r["case"] for r in report["rows"] if r["status"] == "drifted"]
    report["unchecked"] = [r["case"] for r in report["rows"] if r["status"] in ("stale", "missing")]
    report["ok"] = not report["drifted"] and not report["unchecked"]
    return report
