"""Fast checks of the scene machinery: BDDL templates, generator registry, pool, state files."""

from __future__ import annotations

import zipfile

import numpy as np
import pytest

from vpro_assets.core.errors import VProError
from vpro_assets.libero import bridge as libero_bridge
from vpro_assets.libero.init_states import read_init_states
from vpro_assets.libero.tasks import get_task
from vpro_assets.scene import bddl_doc, state_files

CASE = "libero_spatial-00/task_relevant_distractors/same_category-v1"


def _base():
    t = get_task("libero_spatial-00")
    return bddl_doc.read_base(libero_bridge.bddl_path(t.suite, t.name))


def _render(base, **kw):
    args = {
        "case_id": CASE,
        "generator": "test",
        "base_task": "libero_spatial-00",
        "summary": "unchanged",
        "objects": base.objects,
        "fixtures": base.fixtures,
        "regions": [],
        "init": base.init,
    }
    args.update(kw)
    return bddl_doc.render_variant(base, **args)


def test_unchanged_variant_parses_and_keeps_language_and_goal():
    base = _base()
    parsed = bddl_doc.check_variant(_render(base), base, CASE)
    assert parsed["objects"] == base.parsed["objects"]
    assert parsed["initial_state"] == base.parsed["initial_state"]


def test_added_object_and_region_parse():
    base = _base()
    region = bddl_doc.Region("vpro_distractor_region", "main_table", (0.1, 0.1, 0.12, 0.12))
    text = _render(
        base,
        objects=base.objects + [("white_bowl_1", "white_bowl")],
        regions=[region],
        init=base.init + ["(On white_bowl_1 main_table_vpro_distractor_region)"],
    )
    parsed = bddl_doc.check_variant(text, base, CASE)
    assert parsed["objects"]["white_bowl"] == ["white_bowl_1"]
    assert parsed["regions"]["main_table_vpro_distractor_region"]["ranges"] == [[0.1, 0.1, 0.12, 0.12]]


def test_changed_goal_is_refused_naming_the_case():
    base = _base()
    text = _render(base).replace("(On akita_black_bowl_1 plate_1)", "(On akita_black_bowl_2 plate_1)")
    with pytest.raises(bddl_doc.BDDLError, match=CASE):
        bddl_doc.check_variant(text, base, CASE)


def test_template_with_missing_field_names_case_and_field(tmp_path):
    (tmp_path / bddl_doc.SCENE_TEMPLATE).write_text(
        "(define (problem ${problem}) ${language} ${regions} ${fixtures} "
        "${objects} ${obj_of_interest} ${init} ${goal} ${colour})"
    )
    with pytest.raises(bddl_doc.BDDLError, match=rf"{CASE}.*field 'colour'"):
        _render(_base(), template_dir=tmp_path)


def test_template_lacking_a_section_is_refused(tmp_path):
    (tmp_path / bddl_doc.SCENE_TEMPLATE).write_text("(define (problem ${problem}) ${language} ${objects})")
    with pytest.raises(bddl_doc.BDDLError, match=rf"{CASE}.*lacks field\(s\) regions, fixtures"):
        _render(_base(), template_dir=tmp_path)


def test_unknown_object_names_case():
    from vpro_assets.scene import pool

    with pytest.raises(VProError, match=rf"{CASE}: unknown object 'golden_teapot'"):
        pool.get("golden_teapot", CASE)


def test_generator_registry_refuses_duplicates():
    from vpro_assets.scene import plugins

    reg = plugins.registry()
    assert len(reg) == 22  # 6 distractors + 2 preconditions + 2 ambiguity + 12 geometry
    name = "task_relevant_distractors/same_color"
    with pytest.raises(plugins.GeneratorError, match="already registered"):
        plugins.register(name)(lambda ctx: None)


def test_libero_init_format_matches_libero_and_roundtrips(tmp_path):
    t = get_task("libero_spatial-00")
    src = libero_bridge.init_state_path(t.suite, t.name)
    states = read_init_states(src)
    data = state_files.libero_init_bytes(states)
    out = tmp_path / "x.pruned_init"
    out.write_bytes(data)
    assert np.array_equal(read_init_states(out), states)
    with zipfile.ZipFile(src) as a, zipfile.ZipFile(out) as b:  # the pickle is byte-identical to LIBERO's own
        assert a.read("archive/data.pkl") == b.read("archive/data.pkl")
        assert b.read("archive/version") == b"3\n"
    assert state_files.libero_init_bytes(states) == data
    (tmp_path / "x.npz").write_bytes(state_files.npz_bytes(states))
    assert np.array_equal(state_files.read_npz(tmp_path / "x.npz"), states)


def test_catalog_artifact_check_reports_changed_and_unbuilt_files(tmp_path, monkeypatch):
    import hashlib

    from vpro_assets.benchmark import lock

    monkeypatch.setenv("VPRO_OUT", str(tmp_path))
    good, bad = tmp_path / "scene/a/x.bddl", tmp_path / "scene/a/y.npz"
    good.parent.mkdir(parents=True)
    good.write_bytes(b"good")
    bad.write_bytes(b"tampered")
    catalog = {
        "cases": [
            {
                "id": "a",
                "artifacts": {
                    "scene/a/x.bddl": hashlib.sha256(b"good").hexdigest(),
                    "scene/a/y.npz": hashlib.sha256(b"original").hexdigest(),
                    "scene/a/z.pruned_init": "0" * 64,
                },
            }
        ]
    }
    diffs, checked, missing = lock.check_built(catalog)
    assert (checked, missing) == (2, 1)
    assert len(diffs) == 1 and "case a: scene/a/y.npz" in diffs[0]


def test_generated_object_tree_hash_covers_folder_and_shared_textures(tmp_path, monkeypatch):
    """A generated object is recorded as one hash over its folder and the shared textures its MJCF
    references: changing a hull, adding a file or changing a texture outside the folder changes it,
    and `check_built` names the object folder."""
    from vpro_assets.benchmark import lock
    from vpro_assets.core.hashing import mjcf_tree_files as object_files
    from vpro_assets.core.hashing import mjcf_tree_sha256 as tree_sha256

    monkeypatch.setenv("VPRO_OUT", str(tmp_path))
    folder = tmp_path / "objects" / "vpro_thing"
    (folder / "meshes").mkdir(parents=True)
    (tmp_path / "objects" / "textures").mkdir()
    (folder / "meshes" / "hull_a.obj").write_text("v 0 0 0\n")
    (tmp_path / "objects" / "textures" / "wood.png").write_bytes(b"png1")
    (tmp_path / "objects" / "textures" / "unused.png").write_bytes(b"other object's")
    xml = folder / "vpro_thing.xml"
    xml.write_text(
        '<mujoco><asset><texture file="../textures/wood.png"/><mesh file="meshes/hull_a.obj"/></asset></mujoco>'
    )
    assert [p.relative_to(tmp_path / "objects").as_posix() for p in object_files(xml)] == [
        "textures/wood.png",
        "vpro_thing/meshes/hull_a.obj",
        "vpro_thing/vpro_thing.xml",
    ]
    first = tree_sha256(xml)
    catalog = {"cases": [{"id": "a", "artifacts": {"objects/vpro_thing/": first}}]}
    assert lock.check_built(catalog) == ([], 1, 0)
    (tmp_path / "objects" / "textures" / "wood.png").write_bytes(b"png2")
    second = tree_sha256(xml)
    (folder / "vpro_thing.usda").write_text("#usda 1.0\n")
    third = tree_sha256(xml)
    (folder / "meshes" / "hull_a.obj").write_text("v 0 0 1\n")
    assert len({first, second, third, tree_sha256(xml)}) == 4
    diffs, checked, missing = lock.check_built(catalog)
    assert (checked, missing) == (1, 0) and len(diffs) == 1 and "case a: objects/vpro_thing/" in diffs[0]


def test_clean_partial_removes_only_folders_of_dead_writers(tmp_path, monkeypatch):
    """A build starts by removing what an interrupted build left; a second build running into the
    same out/ must not delete the folder the first one is writing (its pid is alive)."""
    import os
    import subprocess
    import sys

    from vpro_assets.scene import build

    monkeypatch.setenv("VPRO_OUT", str(tmp_path))
    dead = subprocess.run(
        [sys.executable, "-c", "import os; print(os.getpid())"], capture_output=True, text=True
    ).stdout.strip()
    alive = str(os.getppid())
    for name in (
        f"scene/.tmp-a__b__c-{dead}",
        f"scene/x/.old-c-{dead}",
        f"objects/.staging-vpro_x-{dead}",
        f"scene/.tmp-a__b__d-{alive}",
        f"objects/.tmp-vpro_thing-{alive}",
    ):
        (tmp_path / name).mkdir(parents=True)
    build.clean_partial()
    left = sorted(p.relative_to(tmp_path).as_posix() for p in tmp_path.rglob(".*-*"))
    assert left == [f"objects/.tmp-vpro_thing-{alive}", f"scene/.tmp-a__b__d-{alive}"]


def test_validation_reports_a_written_back_mjcf_that_does_not_compile_or_warns(tmp_path, monkeypatch):
    """`vpro validate` compiles the scene's written-back MJCF once its env is closed, from the text:
    a text that does not compile is a problem, so is one whose first forward pass warns (20 spheres
    piled into each other with room for too few contacts), and a sound one is none. (Called without
    `core.mjlog`'s routing, MuJoCo's own handler writes MUJOCO_LOG.TXT: into a temporary directory.)"""
    from vpro_assets.scene.validate import _xml_problems

    monkeypatch.chdir(tmp_path)

    pile = "".join(f'<body pos="0 0 {0.01 * i}"><freejoint/><geom size="0.1"/></body>' for i in range(20))
    sound = f"<mujoco><worldbody>{pile}</worldbody></mujoco>"
    assert _xml_problems(sound) == []
    assert _xml_problems("<mujoco><worldbody>")[0].startswith("the scene MJCF does not compile again")
    crowded = sound.replace("<mujoco>", '<mujoco><size memory="16K"/>')
    assert _xml_problems(crowded) == ["the scene MJCF compiles with MuJoCo warning(s) mjWARN_CONTACTFULL"]
