import pytest

from vpro_assets.benchmark.catalog import load_catalog
from vpro_assets.benchmark.selection import select_cases
from vpro_assets.core import paths
from vpro_assets.core.errors import UnknownIdError


@pytest.fixture(scope="module")
def catalog():
    return load_catalog(paths.catalog_path())


def ids(cases):
    return [c["id"] for c in cases]


def test_filters_by_every_kind_of_id(catalog):
    assert len(select_cases(catalog, [])) == 3296
    assert len(select_cases(catalog, ["camera_staleness"])) == 400
    assert len(select_cases(catalog, ["vpro/camera_staleness/wrist-freeze-v1"])) == 40
    assert len(select_cases(catalog, ["camera_staleness/wrist-freeze-v1"])) == 40
    assert ids(select_cases(catalog, ["libero_goal-03/camera_staleness/wrist-freeze-v1"])) == [
        "libero_goal-03/camera_staleness/wrist-freeze-v1"
    ]
    assert {c["suite"] for c in select_cases(catalog, ["libero_goal"])} == {"libero_goal"}
    assert {c["task"] for c in select_cases(catalog, ["libero_goal-03"])} == {"libero_goal-03"}
    assert {c["dimension"] for c in select_cases(catalog, ["camera_staleness", "visual_source_consistency"])} == {
        "camera_staleness",
        "visual_source_consistency",
    }


def test_normal_baselines(catalog):
    assert len(select_cases(catalog, ["normal"])) == 40
    assert ids(select_cases(catalog, ["normal", "libero_goal-03"])) == ["libero_goal-03/normal"]
    assert len(select_cases(catalog, ["normal", "libero_goal"])) == 10
    assert ids(select_cases(catalog, ["libero_spatial-00/normal"])) == ["libero_spatial-00/normal"]
    both = select_cases(catalog, ["normal", "camera_staleness"])
    assert len(both) == 40 + 400 and sum(c["id"].endswith("/normal") for c in both) == 40


def test_unknown_filter_suggests(catalog):
    with pytest.raises(UnknownIdError, match="camera_staleness"):
        select_cases(catalog, ["camera_stalenes"])
