"""Registering MJCF object files with LIBERO: explicit names, clashes refused, idempotent."""

from __future__ import annotations

import pytest

from vpro_assets.objects.registry import ObjectRegistryError, content_sha256, register_mjcf_object, unregister_object

OBJECT_XML = """<mujoco model="{model}">
  <asset>
    <mesh name="{model}_mesh" file="meshes/cube.obj"/>
  </asset>
  <worldbody>
    <body>
      <body name="object">
        <geom type="mesh" mesh="{model}_mesh" group="1" contype="0" conaffinity="0" rgba="{rgba}" mass="0"/>
        <geom type="box" size="0.02 0.02 0.02" group="0" density="100"/>
      </body>
      <site name="bottom_site" pos="0 0 -0.02" size="0.005" rgba="0 0 0 0"/>
      <site name="top_site" pos="0 0 0.02" size="0.005" rgba="0 0 0 0"/>
      <site name="horizontal_radius_site" pos="0.02 0.02 0" size="0.005" rgba="0 0 0 0"/>
    </body>
  </worldbody>
</mujoco>
"""

CUBE_OBJ = """v -0.02 -0.02 -0.02
v 0.02 -0.02 -0.02
v 0.02 0.02 -0.02
v -0.02 0.02 -0.02
v -0.02 -0.02 0.02
v 0.02 -0.02 0.02
v 0.02 0.02 0.02
v -0.02 0.02 0.02
f 1 3 2
f 1 4 3
f 5 6 7
f 5 7 8
f 1 2 6
f 1 6 5
f 2 3 7
f 2 7 6
f 3 4 8
f 3 8 7
f 4 1 5
f 4 5 8
"""


def write_object(folder, model="test_cube", rgba="1 0 0 1"):
    (folder / "meshes").mkdir(parents=True, exist_ok=True)
    (folder / "meshes" / "cube.obj").write_text(CUBE_OBJ)
    path = folder / f"{model}.xml"
    path.write_text(OBJECT_XML.format(model=model, rgba=rgba))
    return path


@pytest.fixture
def objects_dict():
    from vpro_assets.libero.bridge import libero_envs

    return libero_envs().OBJECTS_DICT


def test_registers_under_its_own_name_and_builds_as_a_libero_object(tmp_path, objects_dict):
    xml = write_object(tmp_path)
    cls = register_mjcf_object("vpro_test_cube_a", xml, template="akita_black_bowl")
    try:
        assert objects_dict["vpro_test_cube_a"] is cls
        obj = objects_dict["vpro_test_cube_a"](name="vpro_test_cube_a_1")  # as LIBERO's problem classes call it
        assert obj.category_name == "vpro_test_cube_a"
        assert obj.name == "vpro_test_cube_a_1"
        # placement attributes copied from the template object
        bowl = objects_dict["akita_black_bowl"]()
        assert obj.rotation == bowl.rotation and obj.rotation_axis == bowl.rotation_axis
        assert obj.bottom_offset[-1] == pytest.approx(-0.02)
        assert obj.horizontal_radius == pytest.approx(0.02)
        fixture = objects_dict["vpro_test_cube_a"](name="fixed_1", joints=None)  # LIBERO's fixture call
        assert fixture.joint_specs == []
    finally:
        unregister_object("vpro_test_cube_a")
    assert "vpro_test_cube_a" not in objects_dict


def test_identical_registration_is_idempotent(tmp_path):
    xml = write_object(tmp_path)
    first = register_mjcf_object("vpro_test_cube_b", xml)
    try:
        assert register_mjcf_object("vpro_test_cube_b", xml) is first
    finally:
        unregister_object("vpro_test_cube_b")


def test_a_different_object_under_a_taken_name_is_refused(tmp_path, objects_dict):
    red = write_object(tmp_path / "red", rgba="1 0 0 1")
    blue = write_object(tmp_path / "blue", rgba="0 0 1 1")
    assert content_sha256(red) != content_sha256(blue)
    register_mjcf_object("vpro_test_cube_c", red)
    try:
        with pytest.raises(ObjectRegistryError, match="vpro_test_cube_c.*already registered"):
            register_mjcf_object("vpro_test_cube_c", blue)
        with pytest.raises(ObjectRegistryError, match="already registered"):
            register_mjcf_object("vpro_test_cube_c", red, rotation_axis="x")  # same file, other placement
    finally:
        unregister_object("vpro_test_cube_c")
    bowl_class = objects_dict["akita_black_bowl"]
    with pytest.raises(ObjectRegistryError, match="akita_black_bowl.*LIBERO's AkitaBlackBowl"):
        register_mjcf_object("akita_black_bowl", red)
    assert objects_dict["akita_black_bowl"] is bowl_class
    with pytest.raises(ObjectRegistryError, match="LIBERO's own objects"):
        unregister_object("akita_black_bowl")


def test_content_change_of_a_referenced_mesh_is_a_different_object(tmp_path):
    xml = write_object(tmp_path)
    before = content_sha256(xml)
    (tmp_path / "meshes" / "cube.obj").write_text(CUBE_OBJ.replace("0.02 0.02 0.02", "0.03 0.03 0.03"))
    assert content_sha256(xml) != before


@pytest.mark.parametrize(
    "name, problem, match",
    [
        ("Bad-Name", None, "not snake_case"),
        ("vpro_ok", "missing_file", "does not exist"),
        ("vpro_ok", "no_object_body", "LIBERO's object layout"),
        ("vpro_ok", "no_sites", "missing placement site"),
        ("vpro_ok", "missing_mesh", "references 'meshes/cube.obj'"),
    ],
)
def test_bad_input_is_refused_with_a_clear_error(tmp_path, objects_dict, name, problem, match):
    xml = write_object(tmp_path)
    if problem == "missing_file":
        xml = tmp_path / "nope.xml"
    elif problem == "no_object_body":
        xml.write_text(xml.read_text().replace('name="object"', 'name="thing"'))
    elif problem == "no_sites":
        xml.write_text(xml.read_text().replace('name="top_site"', 'name="other_site"'))
    elif problem == "missing_mesh":
        (tmp_path / "meshes" / "cube.obj").unlink()
    with pytest.raises(ObjectRegistryError, match=match):
        register_mjcf_object(name, xml)
    assert name not in objects_dict


def test_unknown_template_names_the_template(tmp_path):
    from vpro_assets.core.errors import UnknownIdError

    with pytest.raises(UnknownIdError, match="akita_blak_bowl.*akita_black_bowl"):
        register_mjcf_object("vpro_test_cube_d", write_object(tmp_path), template="akita_blak_bowl")


def test_the_identical_object_from_another_folder_is_accepted(tmp_path):
    import shutil

    first = write_object(tmp_path / "build1")
    second = write_object(tmp_path / "build2")
    cls = register_mjcf_object("vpro_test_cube_e", first)
    try:
        assert register_mjcf_object("vpro_test_cube_e", second) is cls  # same bytes elsewhere
        shutil.rmtree(tmp_path / "build1")
        moved = register_mjcf_object("vpro_test_cube_e", second)  # the first copy is gone
        assert moved.xml_path == str(second.resolve())
        moved(name="cube_1")  # and it loads
    finally:
        unregister_object("vpro_test_cube_e")
