"""`vpro certify` and the solvability certificate: a stratified sample certified by default (one
Normal task per suite and one scene case of each scene setting but the geometry ones, 2 trials,
render-free; the geometry settings' cases behind the `certify` marker, as they need coacd), the
certificate tied to its catalog, bad input, and the full certificate behind the `certify` marker."""

from __future__ import annotations

import json
import shutil

import pytest

from vpro_assets.benchmark import certificate as cert
from vpro_assets.benchmark.catalog import find_case, load_catalog
from vpro_assets.cli import main
from vpro_assets.commands.catalog_cmd import certificate_problems
from vpro_assets.core import paths
from vpro_assets.core.errors import VProError
from vpro_assets.libero.bridge import simulator_versions
from vpro_assets.report import solvability
from vpro_assets.report.certify import (
    RUN_ID,
    Outputs,
    carry_certificate,
    check_built,
    run_certify,
    stratified_sample,
    write_outputs,
)
from vpro_assets.rollout.episode import EpisodeSettings
from vpro_assets.rollout.policies.oracle.policy import OraclePolicy
from vpro_assets.rollout.store import ResultsStore

CATALOG = load_catalog(paths.catalog_path())
NORMAL = "libero_spatial-01/normal"


def _outputs(tmp_path) -> Outputs:
    return Outputs(
        tmp_path / "solvability.json", tmp_path / "docs" / "solvability.md", tmp_path / "docs" / "solvability"
    )


def _certificate(tmp_path, cases: dict) -> dict:
    return {
        "schema_version": cert.SCHEMA_VERSION,
        "catalog_sha256": cert.file_sha256(paths.catalog_path()),
        "lock_sha256": cert.file_sha256(paths.REPO_ROOT / "scene_artifacts.lock.json"),
        "cases": cases,
    }


def _entry(case_id: str) -> dict:
    return {"case_sha256": cert.case_sha256(find_case(CATALOG, case_id)), "trials": 2, "solved": 2}


def test_certificate_of_this_catalog_is_accepted_and_counts_coverage(tmp_path):
    certificate = _certificate(tmp_path, {NORMAL: _entry(NORMAL)})
    assert cert.check(certificate, CATALOG, paths.catalog_path()) == []
    certified, total = cert.coverage(certificate, CATALOG)
    assert certified == 1 and total == len(CATALOG["normal"]) + sum(c["level"] == "scene" for c in CATALOG["cases"])


def test_certificate_of_another_catalog_is_refused_naming_the_mismatch_and_stale_cases(tmp_path):
    stale = _entry(NORMAL) | {"case_sha256": "0" * 64}
    certificate = _certificate(tmp_path, {NORMAL: stale, "libero_spatial-99/normal": _entry(NORMAL)})
    certificate["catalog_sha256"] = "f" * 64
    problems = cert.check(certificate, CATALOG, paths.catalog_path())
    assert any("computed on catalog sha256 ffffffffffff" in p for p in problems)
    assert f"case {NORMAL}: stale (its catalog record changed since it was certified)" in problems
    assert "case libero_spatial-99/normal: certified but not in the catalog" in problems
    path = tmp_path / "solvability.json"
    cert.write(certificate, path)
    lines = certificate_problems(CATALOG, paths.catalog_path(), path)
    assert lines[-1].endswith("refused; certify again with `vpro certify --resume`")
    assert main(["catalog", "verify", "--certificate", str(path)]) == 1


def test_observation_cases_inherit_their_task_baseline():
    obs = next(c for c in CATALOG["cases"] if c["level"] != "scene")
    scene = next(c for c in CATALOG["cases"] if c["level"] == "scene")
    assert cert.base_of(obs) == f"{obs['task']}/normal" and not cert.certifiable(obs)
    assert cert.base_of(scene) == scene["id"]


def test_unbuilt_scene_case_is_named_with_the_build_command(tmp_path, monkeypatch):
    monkeypatch.setenv("VPRO_OUT", str(tmp_path / "empty-out"))
    case = next(c for c in CATALOG["cases"] if c["level"] == "scene")
    with pytest.raises(VProError, match=rf"not built: {case['id']}; build them first: vpro build -j 2 --select"):
        check_built([case])


def test_resume_asks_only_the_cases_left_to_run_to_be_built(tmp_path, monkeypatch):
    """A resumed run over a task whose scene case the certificate holds runs on a machine where that
    case is not built; asked to run it again (`redo`), it names the case and keeps its trials."""
    monkeypatch.setenv("VPRO_OUT", str(tmp_path / "empty-out"))
    case = next(c for c in CATALOG["cases"] if c["level"] == "scene")
    committed = _committed(case["id"], [0, 1], [0, 1])
    summary = run_certify(
        [case], tmp_path / "c.sqlite", 2, True, "inline", 1, None, [case["id"]], carry_from=(CATALOG, committed)
    )
    assert summary.recorded == 0
    with pytest.raises(VProError, match=rf"not built: {case['id']};"):
        run_certify([case], tmp_path / "c.sqlite", 2, True, "inline", 1, None, [case["id"]], redo=[case["id"]])
    with ResultsStore(tmp_path / "c.sqlite") as store:
        assert len(store.episodes(RUN_ID)) == 2


def test_replaying_failures_of_an_unbuilt_scene_stops_once_naming_the_build(tmp_path, monkeypatch):
    """Writing the certificate where the scenes are not built (another VPRO_OUT than the run's) stops
    before any replay, naming the case and the build, rather than record "not built" as the reason
    of every failed trial; nothing is written."""
    monkeypatch.setenv("VPRO_OUT", str(tmp_path / "empty-out"))
    case = next(c for c in CATALOG["cases"] if c["level"] == "scene")
    run_certify(
        [case], tmp_path / "c.sqlite", 2, True, "inline", 1, None, [case["id"]],
        carry_from=(CATALOG, _committed(case["id"], [0, 1], [0])),
    )  # fmt: skip
    outputs = _outputs(tmp_path)
    with pytest.raises(VProError, match=rf"not built: {case['id']}; build them first"):
        write_outputs(paths.catalog_path(), tmp_path / "c.sqlite", outputs)
    assert not outputs.certificate.exists() and not (outputs.pictures / "replays.json").exists()


def test_stratified_sample_has_one_task_per_suite_and_one_case_per_scene_setting():
    sample = stratified_sample(CATALOG)
    normal = [c for c in sample if not c.get("setting")]
    scene = [c for c in sample if c.get("setting")]
    assert sorted(c["suite"] for c in normal) == sorted({c["suite"] for c in CATALOG["normal"]})
    assert sorted(c["setting"] for c in scene) == sorted(
        {c["setting"] for c in CATALOG["cases"] if c["level"] == "scene"}
    )


def test_a_trial_that_raises_is_an_error_never_unsolved(tmp_path, monkeypatch):
    def broken(self):
        raise RuntimeError("oracle exploded")

    monkeypatch.setattr(OraclePolicy, "next_action", broken)
    results = tmp_path / "c.sqlite"
    case = find_case(CATALOG, NORMAL)
    run_certify([case], results, 1, False, "inline", 1, None, [NORMAL])
    with ResultsStore(results) as store:
        (row,) = store.episodes(RUN_ID)
    assert row["status"] == "error" and row["success"] is None and "oracle exploded" in row["error"]
    collected = solvability.collect([case], [row])
    assert collected[NORMAL].trials == 0 and list(collected[NORMAL].errors) == [0]


GEOMETRY = "target_geometry_variation"


def _certify_sample(tmp_path, monkeypatch, sample: list[dict], workers: int) -> None:
    """Build the sample's scene cases into an empty out/, certify the sample (2 trials, render-free)
    and check the solved trials: every Normal task 2 of 2, every scene case at least 1 of 2 (issue
    13's 7 of 10), and the certificate and document written and accepted by `vpro catalog verify`'s
    check, with a picture of every case not fully solved."""
    monkeypatch.setenv("VPRO_OUT", str(tmp_path / "out"))
    scene = [c["id"] for c in sample if c.get("setting")]
    assert main(["build", "--no-record", "-j", str(workers), *[a for s in scene for a in ("--select", s)]]) == 0
    results = tmp_path / "certify.sqlite"
    run_certify(sample, results, 2, False, "local", workers, None, [c["id"] for c in sample])
    outputs = _outputs(tmp_path)
    certificate = write_outputs(paths.catalog_path(), results, outputs)
    entries = certificate["cases"]
    assert set(entries) == {c["id"] for c in sample}
    for cid, e in entries.items():
        assert e["errors"] == 0, cid
        assert e["solved"] >= (2 if cid.endswith("/normal") else 1), (cid, e)
        assert len(e["final_state"]) == e["trials"] == 2
    assert cert.check(cert.load(outputs.certificate), CATALOG, paths.catalog_path()) == []
    text = outputs.document.read_text()
    assert "Observation cases inherit their base task's certificate" in text
    for cid, e in entries.items():
        if e["solved"] < e["trials"]:
            assert f"![{cid}](solvability/" in text, f"no picture of {cid}"


def test_certify_stratified_sample(tmp_path, monkeypatch):
    """The default check: one Normal task per suite and one scene case of each scene setting but
    the geometry ones (10 cases, built first), 2 trials, in one worker (the test run already keeps
    both cores busy). The 12 geometry settings' cases each generate a deformed mesh with coacd
    (about a minute apiece on this machine), so they are `test_certify_stratified_geometry`."""
    sample = [c for c in stratified_sample(CATALOG) if c.get("category") != GEOMETRY]
    assert len(sample) == 4 + 10
    _certify_sample(tmp_path, monkeypatch, sample, workers=1)


@pytest.mark.slow
@pytest.mark.certify
def test_certify_stratified_geometry(tmp_path, monkeypatch):
    """The rest of the stratified sample: one case of each of the 12 geometry settings, built (coacd)
    and certified with 2 trials on 2 workers; `pytest -m certify -k stratified tests/report/test_certify.py`."""
    sample = [c for c in stratified_sample(CATALOG) if c.get("category") == GEOMETRY]
    assert len(sample) == 12
    _certify_sample(tmp_path, monkeypatch, sample, workers=2)


@pytest.mark.slow
@pytest.mark.certify
def test_full_certificate(tmp_path):
    """Every Normal baseline and built scene case, 10 trials (hours on 2 cores; build the scene
    cases first with `vpro build -j 2`). Issue 13's goals: Normal at least 95% with every task at
    least 8 of 10; every scene setting at least 90% with every case at least 7 of 10."""
    results = tmp_path / "certify.sqlite"
    assert main(["certify", "-j", "2", "--results", str(results), "--certificate", str(tmp_path / "s.json"),
                 "--doc", str(tmp_path / "docs" / "solvability.md"), "--no-progress"]) == 0  # fmt: skip
    entries = json.loads((tmp_path / "s.json").read_text())["cases"]
    normal = {k: e for k, e in entries.items() if k.endswith("/normal")}
    assert sum(e["solved"] for e in normal.values()) >= 0.95 * sum(e["trials"] for e in normal.values())
    assert all(e["solved"] >= 8 for e in normal.values()), {k: e["solved"] for k, e in normal.items()}
    by_setting: dict[str, list[dict]] = {}
    for k, e in entries.items():
        if not k.endswith("/normal"):
            by_setting.setdefault(find_case(CATALOG, k)["setting"], []).append(e)
    for setting, es in by_setting.items():
        assert sum(e["solved"] for e in es) >= 0.9 * sum(e["trials"] for e in es), setting
        assert all(e["solved"] >= 7 for e in es), setting
    shutil.rmtree(tmp_path / "docs", ignore_errors=True)


def _committed(case_id: str, trials: list[int], solved: list[int]) -> dict:
    """A certificate as `vpro certify` commits it, holding one case's trials."""
    return _certificate(None, {}) | {
        "settings": EpisodeSettings(render=False).to_json(),
        "versions": simulator_versions() | {"numpy": "any"},
        "cases": {
            case_id: _entry(case_id)
            | {"trials": len(trials), "solved": len(solved), "errors": 0, "solved_trials": solved,
               "trial_ids": trials, "steps": [100 + t for t in trials], "final_state": [f"fp{t}" for t in trials],
               "code_versions": {"c0ffee": trials[:1], "unrecorded": trials[1:]}}
        },
    }  # fmt: skip


def test_resume_on_a_fresh_machine_continues_from_the_committed_certificate(tmp_path):
    """A database without a certification run, resumed, starts from the certificate: its trials are
    not run again and are written back unchanged; a certificate of another simulator carries nothing."""
    case = find_case(CATALOG, NORMAL)
    planned: list[tuple[int, int]] = []
    committed = _committed(NORMAL, [0, 1], [1])
    summary = run_certify(
        [case], tmp_path / "c.sqlite", 2, True, "inline", 1, None, [NORMAL],
        on_plan=lambda todo, skipped: planned.append((todo, skipped)), carry_from=(CATALOG, committed),
    )  # fmt: skip
    assert planned == [(0, 2)] and summary.recorded == 0
    entry = write_outputs(paths.catalog_path(), tmp_path / "c.sqlite", _outputs(tmp_path), replays=False)["cases"][
        NORMAL
    ]
    assert {k: entry[k] for k in ("trials", "solved_trials", "steps", "final_state", "code_versions")} == {
        "trials": 2, "solved_trials": [1], "steps": [100, 101], "final_state": ["fp0", "fp1"],
        "code_versions": {"c0ffee": [0], "unrecorded": [1]},
    }  # fmt: skip
    other = committed | {"versions": {"mujoco": "2.3.7", "robosuite": "1.4.1"}}
    with ResultsStore(tmp_path / "d.sqlite") as store:
        store.create_run(RUN_ID, "oracle", "oracle", {}, [], 2, {}, None)
        assert carry_certificate(store, CATALOG, other, EpisodeSettings(render=False)) == []


def test_catalog_changed_during_a_run_leaves_the_changed_case_out_of_a_certificate_of_the_new_catalog(tmp_path):
    """Trials recorded on one catalog, the catalog then rebuilt with that case's record changed (as a
    merge during a long run does): the certificate written is bound to the catalog file as it is
    when written, without the stale case, and `vpro catalog verify`'s check accepts it."""
    run_certify(
        [find_case(CATALOG, NORMAL)], tmp_path / "c.sqlite", 2, True, "inline", 1, None, [NORMAL],
        carry_from=(CATALOG, _committed(NORMAL, [0, 1], [0, 1])),
    )  # fmt: skip
    changed = json.loads(paths.catalog_path().read_text(encoding="utf-8"))
    case = next(c for c in changed["normal"] if c["id"] == NORMAL)
    case["instruction"] += " (reworded)"
    catalog_file = tmp_path / "catalog.json"
    catalog_file.write_text(json.dumps(changed), encoding="utf-8")
    certificate = write_outputs(catalog_file, tmp_path / "c.sqlite", _outputs(tmp_path), replays=False)
    assert NORMAL not in certificate["cases"] and certificate["catalog_sha256"] == cert.file_sha256(catalog_file)
    assert cert.check(cert.load(_outputs(tmp_path).certificate), changed, catalog_file) == []


def test_redo_runs_a_carried_case_again(tmp_path):
    case = find_case(CATALOG, NORMAL)
    run_certify(
        [case], tmp_path / "c.sqlite", 1, True, "inline", 1, None, [NORMAL],
        carry_from=(CATALOG, _committed(NORMAL, [0], [])), redo=[NORMAL],
    )  # fmt: skip
    with ResultsStore(tmp_path / "c.sqlite") as store:
        (row,) = store.episodes(RUN_ID)
    assert row["worker"] != "carried from the certificate" and row["final_state"] != "fp0"
    assert row["status"] == "ok" and row["success"]  # the oracle solves this task (10 of 10 in the certificate)
