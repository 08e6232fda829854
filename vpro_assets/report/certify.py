"""A certification run: the oracle, render-free, on Normal baselines and scene cases through `vpro
eval`'s runner (run id `certify` of a results database, so `--resume` and the backends are the
runner's), then every failed trial replayed to read why, and the certificate and its document
written from all the rows of that run.

The committed certificate is what outlives a machine: `--resume` into a database that holds no
certification run starts it from the certificate's entries whose case record is unchanged and that
ran under this simulator and these settings (`carry_certificate`), so a fresh clone continues where
the last one committed. `--redo` runs chosen cases afresh (an improved oracle) and keeps the rest.

The catalog record each case ran on is kept beside the database (`<results>.cases.json`, sha256 of
the record): a case whose record changed is refused on `--resume` and left out of the certificate
(the catalog may change under a long run; the cases that did not change keep their trials).
Replays are kept beside the document's pictures (`docs/solvability/replays.json`, keyed by case,
trial and final-state fingerprint) and committed with them, so writing again, on this machine or a
fresh clone resuming from the committed certificate, replays only new failures. The first failed trial of
a case is replayed rendered for its picture (a contact sheet in `docs/solvability/`); the next
MAX_REPLAYS - 1 render-free (the others are listed as not replayed).
"""

from __future__ import annotations

import json
import logging
import statistics
import time
from collections import Counter
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path

from vpro_assets.benchmark import certificate as cert
from vpro_assets.benchmark.catalog import load_catalog
from vpro_assets.benchmark.lock import lock_path
from vpro_assets.core.atomic import write_text_atomic
from vpro_assets.core.errors import VProError
from vpro_assets.core.hashing import canonical_json, sha256_file
from vpro_assets.core.images import write_png
from vpro_assets.libero.bridge import simulator_versions
from vpro_assets.report import solvability
from vpro_assets.rollout.case_env import CaseUnavailableError, check_available
from vpro_assets.rollout.episode import EpisodeSettings
from vpro_assets.rollout.failure_replay import replay
from vpro_assets.rollout.jobs import base_row, make_job
from vpro_assets.rollout.runner import RunSummary, create_run, run_eval
from vpro_assets.rollout.spec import policy_label
from vpro_assets.rollout.store import ResultsStore

log = logging.getLogger(__name__)

RUN_ID = "certify"
POLICY = "oracle"
PICTURE_RESOLUTION = 160
SHOWN_UNBUILT = 3
SIM_KEYS = ("mujoco", "robosuite")
MAX_REPLAYS = 3  # failed trials replayed per case (the first one rendered, for its picture)


@dataclass(frozen=True)
class Outputs:
    certificate: Path
    document: Path
    pictures: Path  # folder of contact sheets, referenced from the document's folder


def certifiable_cases(catalog: dict, selected: Sequence[dict]) -> list[dict]:
    """The cases to certify for a selection: Normal baselines and scene cases as they are; an
    observation case stands for its base task's Normal baseline (it inherits that certificate)."""
    normal = {c["id"]: c for c in catalog.get("normal", [])}
    out: dict[str, dict] = {}
    for case in selected:
        cid = cert.base_of(case)
        out.setdefault(cid, case if cid == case["id"] else normal[cid])
    return list(out.values())


def stratified_sample(catalog: dict) -> list[dict]:
    """One Normal baseline per suite (its first task) and one scene case per scene setting, the
    settings (in sorted order) taking their case from the suites in turn (the first case of that
    suite in catalog order, else the setting's first): the sample `make test` certifies."""
    normal: dict[str, dict] = {}
    for case in catalog["normal"]:
        normal.setdefault(case["suite"], case)
    suites = list(normal)
    by_setting: dict[str, list[dict]] = {}
    for case in catalog["cases"]:
        if case.get("level") == "scene":
            by_setting.setdefault(case["setting"], []).append(case)
    scene = []
    for k, (_, cases) in enumerate(sorted(by_setting.items())):
        suite = suites[k % len(suites)]
        scene.append(next((c for c in cases if c["suite"] == suite), cases[0]))
    return list(normal.values()) + scene


def check_built(cases: Sequence[dict]) -> None:
    """VProError naming the scene cases that are not built and the command that builds them."""
    unbuilt = []
    for case in cases:
        try:
            check_available(case)
        except CaseUnavailableError:
            unbuilt.append(case["id"])
    if unbuilt:
        shown = ", ".join(unbuilt[:SHOWN_UNBUILT])
        more = f" and {len(unbuilt) - SHOWN_UNBUILT} more" if len(unbuilt) > SHOWN_UNBUILT else ""
        select = " ".join(f"--select {c}" for c in unbuilt[:SHOWN_UNBUILT])
        raise VProError(
            f"scene case(s) not built: {shown}{more}; build them first: vpro build -j 2 {select}"
            + (" ... (or the whole selection)" if more else "")
        )


def carry_certificate(
    store: ResultsStore, catalog: dict, certificate: dict, settings: EpisodeSettings, skip: Sequence[str] = ()
) -> list[dict]:
    """Record the trials of the certificate's current entries (case record unchanged, same episode
    settings and simulator; not in `skip`) as rows of the certification run; the cases carried."""
    current = simulator_versions()
    sim = {k: v for k, v in certificate.get("versions", {}).items() if k in current}
    if certificate.get("settings") != settings.to_json() or sim != current:
        log.warning("the certificate ran under other settings or another simulator (%s): nothing carried", sim)
        return []
    records = {c["id"]: c for c in catalog.get("normal", []) + catalog["cases"] if cert.certifiable(c)}
    carried = []
    for cid, entry in certificate["cases"].items():
        case = records.get(cid)
        if case is None or cid in skip or entry.get("case_sha256") != cert.case_sha256(case):
            continue
        solved = set(entry["solved_trials"])
        commit = {t: v for v, trials in entry.get("code_versions", {}).items() for t in trials}
        for trial, steps, final in zip(entry["trial_ids"], entry["steps"], entry["final_state"], strict=True):
            row = base_row(make_job(RUN_ID, case, trial, POLICY, {}, settings, 0, 0.0))
            code = commit.get(trial)
            store.record(
                row
                | {"status": "ok", "success": trial in solved, "steps": steps, "final_state": final}
                | {"worker": "carried from the certificate", "simulator": sim}
                | {"code_version": None if code in (None, solvability.UNRECORDED) else code}
            )
        carried.append(case)
    return carried


def run_certify(
    cases: Sequence[dict],
    results: Path,
    trials: int,
    resume: bool,
    backend: str,
    workers: int,
    address: str | None,
    selection: Sequence[str],
    on_row: Callable[[dict], None] | None = None,
    on_plan: Callable[[int, int], None] | None = None,
    carry_from: tuple[dict, dict] | None = None,
    redo: Sequence[str] = (),
) -> RunSummary:
    """Certify `cases` into the run of `results`. `carry_from` (catalog, certificate): on `resume`
    into a database without a run, start it from the certificate; `redo`: case ids whose trials in
    the database (or the certificate) are dropped and run again."""
    settings = EpisodeSettings(render=False)
    carried: list[dict] = []
    with ResultsStore(results) as store:
        exists = store.run(RUN_ID) is not None
        if exists and not resume:
            raise VProError(
                f"{results}: a certification run exists; continue it with --resume (or certify into a new file)"
            )
        if resume and not exists and carry_from is not None:
            create_run(store, RUN_ID, POLICY, policy_label(POLICY), settings, selection, trials)
            catalog, certificate = carry_from
            carried = carry_certificate(store, catalog, certificate, settings, skip=redo)
            exists = True
            log.info("carried %d case(s) from the certificate", len(carried))
        # Only the cases with trials left to run need their scene built: a resumed run over a whole
        # task does not ask a fresh machine to build the cases it has certified already.
        done = {key for key in store.done_keys(RUN_ID) if key[0] not in redo} if exists else set()
        check_built([c for c in cases if any((c["id"], t) not in done for t in range(trials))])
        if exists and redo:
            store.forget(RUN_ID, redo)
    record_case_hashes(results, cases, carried)
    return run_eval(
        cases,
        results=results,
        policy_spec=POLICY,
        settings=settings,
        trials=trials,
        run_id=RUN_ID,
        resume=exists,
        backend=backend,
        workers=workers,
        address=address,
        selection=selection,
        on_row=on_row,
        on_plan=on_plan,
    )


def _hashes_path(results: Path) -> Path:
    return results.with_name(results.name + ".cases.json")


def _case_hashes(results: Path) -> dict[str, str]:
    """case id -> sha256 of the catalog record its trials in `results` ran on."""
    path = _hashes_path(results)
    return json.loads(path.read_text(encoding="utf-8")) if path.is_file() else {}


def record_case_hashes(results: Path, cases: Sequence[dict], carried: Sequence[dict] = ()) -> None:
    """Note the catalog record each case runs on (`carried`: the records the certificate's trials ran
    on); VProError when a case with trials in the database has changed since (its rows would mix two
    versions of the case)."""
    hashes = _case_hashes(results) | {c["id"]: cert.case_sha256(c) for c in carried}
    with ResultsStore(results) as store:
        done = {cid for cid, _ in store.done_keys(RUN_ID)} if store.run(RUN_ID) else set()
    for case in cases:
        now = cert.case_sha256(case)
        if case["id"] in done and hashes.get(case["id"]) != now:
            raise VProError(
                f"case {case['id']}: its catalog record changed since its trials in {results} ran; "
                "certify it into a new results database"
            )
        hashes[case["id"]] = now
    write_text_atomic(_hashes_path(results), canonical_json(hashes))


def _replays_path(pictures: Path) -> Path:
    return pictures / "replays.json"


def _picture_name(case_id: str) -> str:
    return case_id.replace("/", "__") + ".png"


def explain_failures(
    results_map: dict[str, solvability.CaseResult],
    pictures: Path,
    settings: EpisodeSettings,
    replays: bool = True,
) -> dict[tuple[str, int], dict]:
    """(case, trial) -> {reason, reproduced, picture} for every failed trial, replayed where not
    cached (`replays=False`: the cached ones only)."""
    path = _replays_path(pictures)
    cache: dict[str, dict] = json.loads(path.read_text(encoding="utf-8")) if path.is_file() else {}
    out: dict[tuple[str, int], dict] = {}
    todo: list[tuple[str, int, bool]] = []  # (case, trial, with picture) to replay
    for cid, r in results_map.items():
        for i, t in enumerate(sorted(r.failed)[:MAX_REPLAYS]):
            cached = cache.get(f"{cid}#{t}")
            if cached is not None and cached["final_state"] != r.final_state[t]:
                cached = None  # a replay of another trial's end
            want_picture = i == 0
            pic = (cached or {}).get("picture")
            if cached is not None and (not want_picture or (pic and (pictures / pic).is_file()) or not replays):
                out[(cid, t)] = cached
            elif replays:
                todo.append((cid, t, want_picture))
    # Every replay needs its scene: stop once, naming the build, rather than record "not built" as
    # the reason of each failed trial (a VPRO_OUT other than the one the run used).
    check_built([results_map[cid].case for cid in dict.fromkeys(cid for cid, _, _ in todo)])
    for cid, t, want_picture in todo:
        r = results_map[cid]
        log.info("replaying %s trial %d%s", cid, t, " (rendered)" if want_picture else "")
        try:
            rep = replay(r.case, t, settings, render=want_picture, resolution=PICTURE_RESOLUTION)
            entry: dict = {
                "final_state": r.final_state[t],
                "reason": rep.reason,
                "reproduced": rep.final_state == r.final_state[t],
            }
            if not entry["reproduced"]:
                entry["reason"] += " (the replay ended in another state than the recorded trial)"
            if want_picture and rep.frames:
                write_png(pictures / _picture_name(cid), rep.sheet(), [f"t{t} step {s}" for s in rep.frame_steps])
                entry["picture"] = _picture_name(cid)
        except Exception as exc:  # a replay that raises is reported, not fatal to the document
            entry = {"final_state": r.final_state[t], "reason": f"replay raised {type(exc).__name__}: {exc}"}
        cache[f"{cid}#{t}"] = entry
        out[(cid, t)] = entry
        write_text_atomic(path, canonical_json(cache))
    return out


def write_outputs(catalog_file: Path, results: Path, outputs: Outputs, replays: bool = True) -> dict:
    """Write the certificate and the document from every row of the certification run; the certificate.

    The catalog is read here, not where the run started: its records and its sha256 must come from
    the same file, or a catalog rebuilt during a long run would bind the certificate to the new file
    while its entries hold the old records (stale entries in a certificate that claims to belong)."""
    with ResultsStore(results) as store:
        run = store.run(RUN_ID)
        if run is None:
            raise VProError(f"{results}: no certification run; run vpro certify first")
        rows = store.episodes(RUN_ID)
    catalog_sha = sha256_file(catalog_file)
    catalog = load_catalog(catalog_file)
    if sha256_file(catalog_file) != catalog_sha:
        raise VProError(f"{catalog_file} changed while being read; write the certificate again (--write-only)")
    lock_sha = cert.file_sha256(lock_path())
    all_cases = catalog.get("normal", []) + catalog["cases"]
    ran_on = _case_hashes(results)
    current = [c for c in all_cases if ran_on.get(c["id"]) == cert.case_sha256(c)]
    stale = sorted({r["case_id"] for r in rows} - {c["id"] for c in current})
    if stale:
        log.warning(
            "%d case(s) left out: their catalog records changed since their trials ran (or are gone), e.g. %s; "
            "certify them into a new results database",
            len(stale),
            ", ".join(stale[:3]),
        )
    results_map = solvability.collect(current, rows)
    settings = EpisodeSettings(**{**run["settings"], "render": False})
    outputs.pictures.mkdir(parents=True, exist_ok=True)
    explained = explain_failures(results_map, outputs.pictures, settings, replays)
    certificate = solvability.certificate(results_map, catalog_sha, lock_sha, run["settings"], run["versions"])
    cert.write(certificate, outputs.certificate)
    rel = (
        outputs.pictures.relative_to(outputs.document.parent)
        if outputs.pictures.is_relative_to(outputs.document.parent)
        else outputs.pictures
    )
    pictures = {cid: f"{rel}/{e['picture']}" for (cid, _), e in explained.items() if e.get("picture")}
    used = {Path(p).name for p in pictures.values()}
    for png in outputs.pictures.glob("*.png"):
        if png.name not in used:
            png.unlink()  # a case solved since its picture was taken
    certified, certifiable = cert.coverage(certificate, catalog)
    scene_total = sum(1 for c in catalog["cases"] if c.get("level") == "scene")
    scene_done = sum(1 for r in results_map.values() if r.case.get("setting"))
    ok_rows = [r for r in rows if r["status"] == "ok" and r["case_id"] in results_map]
    wall = [float(r["wall_time"]) for r in ok_rows if r.get("wall_time")]
    header = {
        "catalog": f"`catalog.json` sha256 {catalog_sha[:12]}, `scene_artifacts.lock.json` sha256 "
        f"{(lock_sha or 'none')[:12]}",
        "simulator": "; ".join(
            sorted(
                {
                    ", ".join(
                        f"{k} {v}" for k, v in sorted((r.get("simulator") or run["versions"]).items()) if k in SIM_KEYS
                    )
                    for r in ok_rows
                }
            )
        )
        + " (per trial in the results database's `simulator` column)",
        "toolkit": "; ".join(
            f"{'commit ' + code if code != solvability.UNRECORDED else code} {n} trials"
            for code, n in Counter(r.get("code_version") or solvability.UNRECORDED for r in ok_rows).most_common()
        )
        + " (per case in the certificate's `code_versions`: the commit whose oracle ran each trial)",
        "certified": f"{certified} of {certifiable} certifiable cases (40 Normal baselines + {scene_total} scene cases); "
        f"{len(ok_rows)} trials",
        "episode time": (
            f"median {statistics.median(wall):.1f} s per render-free episode on one worker "
            f"({3600 / statistics.mean(wall):.0f} episodes per hour per worker)"
            if wall
            else "- (no episode ran in this database: its trials were carried from the committed certificate)"
        ),
        "written": time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime()) + " by `vpro certify`",
    }
    previous = outputs.document.read_text(encoding="utf-8") if outputs.document.is_file() else None
    text = solvability.document(
        results_map,
        {k: e["reason"] for k, e in explained.items()},
        pictures,
        header,
        solvability.kept_findings(previous),
        scene_total - scene_done,
    )
    write_text_atomic(outputs.document, text)
    return certificate
