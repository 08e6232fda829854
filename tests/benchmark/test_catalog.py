import json
from collections import Counter

import pytest

from vpro_assets.benchmark import catalog as cat
from vpro_assets.core import paths
from vpro_assets.core.errors import CatalogError


def test_totals(built_catalog):
    cases = built_catalog["cases"]
    assert len(cases) == 3296
    assert len({c["setting"] for c in cases}) == 96
    assert len({c["category"] for c in cases}) == 12
    assert len({c["dimension"] for c in cases}) == 4
    assert len({c["task"] for c in cases}) == 40
    assert built_catalog["header"]["totals"]["cases"] == 3296
    assert not any(c["id"].endswith("/normal") for c in cases)
    assert len(built_catalog["normal"]) == 40 and len({n["task"] for n in built_catalog["normal"]}) == 40
    for c in cases + built_catalog["normal"]:
        assert len(c["trial_seeds"]) == 10 and len(set(c["trial_seeds"])) == 10
        assert c["init_states"]["rows"] == list(range(10))
    assert len({c["id"] for c in cases}) == 3296


def test_rebuild_is_byte_identical_and_matches_the_committed_catalog(built_catalog):
    again = cat.build_catalog()
    assert cat.dumps(again) == cat.dumps(built_catalog)
    committed = paths.catalog_path().read_text()
    assert committed == cat.dumps(built_catalog), "catalog.json is stale: run `vpro catalog build`"


def test_observation_cases_reference_libero_initial_states(built_catalog, tasks):
    by_key = {t.key: t for t in tasks}
    for c in built_catalog["cases"]:
        if c["level"] == "observation":
            assert c["init_states"] == {
                "source": "libero",
                "file": by_key[c["task"]].init_relpath,
                "rows": list(range(10)),
            }


@pytest.fixture()
def catalog_copy(tmp_path, built_catalog):
    path = tmp_path / "catalog.json"
    cat.write_catalog(built_catalog, path)
    return path


def test_verify_names_the_edited_case_and_field(catalog_copy):
    data = json.loads(catalog_copy.read_text())
    victim = data["cases"][1234]
    victim["params"]["ratio"] = 0.33 if "ratio" in victim["params"] else 0.33
    victim["trial_seeds"][3] += 1
    catalog_copy.write_text(cat.dumps(data))
    _, diffs = cat.verify_catalog(catalog_copy)
    assert any(victim["id"] in d and "params.ratio" in d for d in diffs), diffs
    assert any(victim["id"] in d and "trial_seeds[3]" in d for d in diffs), diffs


def test_verify_names_removed_and_foreign_cases(catalog_copy):
    data = json.loads(catalog_copy.read_text())
    removed = data["cases"].pop(7)
    data["cases"].append(dict(removed, id="libero_goal-03/made_up/case-v1"))
    catalog_copy.write_text(cat.dumps(data))
    _, diffs = cat.verify_catalog(catalog_copy)
    assert any(removed["id"] in d and "missing" in d for d in diffs)
    assert any("made_up" in d for d in diffs)


def test_non_canonical_formatting_is_reported(catalog_copy):
    catalog_copy.write_text(json.dumps(json.loads(catalog_copy.read_text())))
    _, diffs = cat.verify_catalog(catalog_copy)
    assert diffs and "canonical" in diffs[0]


@pytest.mark.parametrize(
    "damage, message",
    [
        (lambda text: text[: len(text) // 2], "truncated"),
        (lambda text: text.replace('"schema_version": 1', '"schema_version": 99'), "schema_version 99"),
        (lambda text: "[]", "not a catalog"),
        (lambda text: text.replace('"totals": {\n   "cases": 3296', '"totals": {\n   "cases": 3297'), "3297"),
    ],
)
def test_damaged_catalogs_give_clear_errors(catalog_copy, damage, message):
    catalog_copy.write_text(damage(catalog_copy.read_text()))
    with pytest.raises(CatalogError) as err:
        cat.load_catalog(catalog_copy)
    assert message in str(err.value) and str(catalog_copy) in str(err.value)


def test_missing_case_field_is_named(catalog_copy):
    data = json.loads(catalog_copy.read_text())
    del data["cases"][5]["trial_seeds"]
    catalog_copy.write_text(cat.dumps(data))
    with pytest.raises(CatalogError, match=r"case .* lacks field\(s\) trial_seeds"):
        cat.load_catalog(catalog_copy)


def test_every_setting_and_suite_has_cases(built_catalog):
    per_setting = Counter(c["setting"] for c in built_catalog["cases"])
    assert min(per_setting.values()) >= 1
    assert set(Counter(c["suite"] for c in built_catalog["cases"])) == {
        "libero_spatial",
        "libero_object",
        "libero_goal",
        "libero_10",
    }


def test_taxonomy_doc_is_current():
    from vpro_assets.benchmark.taxonomy_doc import render_taxonomy_doc

    doc = (paths.REPO_ROOT / "docs" / "taxonomy.md").read_text()
    assert doc == render_taxonomy_doc(), "docs/taxonomy.md is stale: run `vpro taxonomy --doc docs/taxonomy.md`"
