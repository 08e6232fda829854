"""Unit and property tests of the deformation maps, mesh refinement and manifold repair (no coacd)."""

from __future__ import annotations

import numpy as np
import pytest

from vpro_assets.core.errors import InvalidParameterError
from vpro_assets.geometry.deform import DEFORMATIONS, check_amount, deformation_map, upright_frame
from vpro_assets.geometry.meshes import MeshError, obj_bytes, read_msh, soup_to_indexed
from vpro_assets.geometry.refine import refine_soup
from vpro_assets.geometry.solid import manifold_arrays, repair_part


def box_soup(extents=(0.08, 0.04, 0.02)):
    import trimesh

    box = trimesh.creation.box(extents)
    box.apply_translation([0.0, 0.0, extents[2] / 2])
    return np.array(box.triangles)


@pytest.fixture(scope="module")
def refined_box():
    corners, _, _ = refine_soup(box_soup(), None, 0.004)
    manifold, report = repair_part("box", corners)
    assert report.method == "merge"
    return manifold


@pytest.mark.parametrize(
    "deformation, amount", [("taper", 0.55), ("multipeak", 0.18), ("twist", 60.0), ("asymmetric", 0.3)]
)
def test_maps_move_points_only_horizontally_and_keep_the_solid_closed(refined_box, deformation, amount):
    import trimesh

    vertices, faces = manifold_arrays(refined_box)
    frame = upright_frame("+z", vertices, vertices.mean(axis=0))
    extra = {"twist_ellipticity": 0.18} if deformation == "twist" else {}
    warp = deformation_map(deformation, amount, frame, **extra)
    moved = warp(vertices)
    np.testing.assert_allclose(moved[:, 2], vertices[:, 2], atol=1e-12)  # heights untouched
    assert np.abs(moved - vertices).max() > 1e-3  # and it does move
    deformed = refined_box.warp_batch(lambda p: warp(np.asarray(p)))
    v, f = manifold_arrays(deformed)
    mesh = trimesh.Trimesh(v, f, process=False)
    assert mesh.is_watertight and mesh.is_winding_consistent and mesh.volume > 0
    if deformation == "twist":  # turning keeps each slice's area, the ellipse scales it by (1 +- e)^2 at most
        assert (1 - 0.18) ** 2 < mesh.volume / refined_box.volume() < (1 + 0.18) ** 2


def test_twist_makes_a_round_slice_elliptical_then_turns_it():
    angles = np.radians(np.arange(0, 360, 15))
    ring = np.stack([0.03 * np.cos(angles), 0.03 * np.sin(angles)], axis=1)
    bottom, top = np.c_[ring, np.zeros(len(ring))], np.c_[ring, np.full(len(ring), 0.1)]
    vertices = np.concatenate([bottom, top])
    frame = upright_frame("+z", vertices, np.zeros(3))
    moved = deformation_map("twist", 60.0, frame, twist_ellipticity=0.18)(vertices)
    radii = np.linalg.norm(moved[:, :2], axis=1)
    assert radii.max() == pytest.approx(0.03 * 1.18) and radii.min() == pytest.approx(0.03 * 0.82)
    # the long axis of the bottom ellipse at -30 degrees, of the top one at +30 degrees
    for points, degrees in ((moved[: len(ring)], -30.0), (moved[len(ring) :], 30.0)):
        far = points[np.argmax(np.linalg.norm(points[:, :2], axis=1))]
        assert np.degrees(np.arctan2(far[1], far[0])) % 180 == pytest.approx(degrees % 180)
    unchanged = deformation_map("twist", 60.0, frame)(vertices)  # no ellipse: a ring stays a ring
    np.testing.assert_allclose(np.linalg.norm(unchanged[:, :2], axis=1), 0.03)


@pytest.mark.parametrize(
    "deformation, extra, message",
    [
        ("twist", {"twist_ellipticity": 0.7}, "twist_ellipticity=0.7 is outside"),
        ("taper", {"twist_ellipticity": 0.1}, "taper has no parameter 'twist_ellipticity'"),
        ("twist", {"twist_ellipticity": True}, "twist_ellipticity=True"),
    ],
)
def test_bad_extra_parameters_are_refused(deformation, extra, message):
    with pytest.raises(InvalidParameterError, match=message):
        check_amount(deformation, 40.0 if deformation == "twist" else 0.7, **extra)


def test_taper_keeps_mid_height_and_scales_top_against_bottom():
    vertices = np.array([[0.01, 0.0, 0.0], [0.01, 0.0, 0.05], [0.01, 0.0, 0.1]])
    frame = upright_frame("+z", vertices, np.zeros(3))
    moved = deformation_map("taper", 0.7, frame)(vertices)
    assert moved[1, 0] == pytest.approx(0.01)
    assert moved[2, 0] / moved[0, 0] == pytest.approx(0.7)


def test_up_axis_y_deforms_about_y():
    vertices = np.array([[0.01, 0.0, 0.0], [0.01, 0.1, 0.0]])
    frame = upright_frame("+y", vertices, np.zeros(3))
    moved = deformation_map("taper", 0.5, frame)(vertices)
    np.testing.assert_allclose(moved[:, 1], vertices[:, 1])
    assert moved[1, 0] / moved[0, 0] == pytest.approx(0.5)


@pytest.mark.parametrize(
    "deformation, amount", [("taper", 0.0), ("twist", float("nan")), ("bend", 1.0), ("multipeak", 0.9)]
)
def test_bad_amounts_and_names_are_refused(deformation, amount):
    with pytest.raises(InvalidParameterError, match=deformation):
        check_amount(deformation, amount)


def test_every_taxonomy_geometry_setting_has_a_valid_amount():
    from vpro_assets.benchmark.taxonomy import settings_of
    from vpro_assets.geometry.deform import amount_of, extra_params_of

    settings = settings_of("target_geometry_variation")
    assert len(settings) == 12
    for setting in settings:
        params = setting.param_dict
        check_amount(
            params["deformation"],
            amount_of(params["deformation"], params),
            **extra_params_of(params["deformation"], params),
        )
    assert set(DEFORMATIONS) == {s.param_dict["deformation"] for s in settings}


def test_refinement_is_conforming_and_interpolates_texture_coordinates():
    import trimesh

    corners = box_soup((0.1, 0.1, 0.15))
    uv = corners[:, :, :2] * 5.0  # any linear function of position
    fine, fine_uv, _ = refine_soup(corners, uv, 0.01)
    assert np.linalg.norm(fine - np.roll(fine, -1, axis=1), axis=2).max() <= 0.01
    np.testing.assert_allclose(fine_uv, fine[:, :, :2] * 5.0, atol=1e-12)
    v, f, _, _ = soup_to_indexed(fine, None)
    mesh = trimesh.Trimesh(v, f, process=False)
    assert mesh.is_watertight and mesh.volume == pytest.approx(0.1 * 0.1 * 0.15)


def test_open_surface_is_closed_by_level_set_and_says_so():
    corners = box_soup()
    open_box = corners[2:]  # two triangles removed: a square hole
    manifold, report = repair_part("open_box", open_box)
    assert report.method in ("fill_holes", "level_set")
    assert manifold.volume() == pytest.approx(0.08 * 0.04 * 0.02, rel=0.25)
    sheet = corners[:2]  # an open square sheet with no thickness at all
    sheet = np.concatenate([sheet, sheet + [0, 0, 1e-9], sheet[:, ::-1]])
    manifold, report = repair_part("sheet", sheet)
    assert report.method == "level_set" and "level-set remesh" in report.detail and manifold.volume() > 0


def test_unusable_meshes_raise_mesh_error_naming_the_part():
    with pytest.raises(MeshError, match="'two_triangles'"):
        repair_part("two_triangles", box_soup()[:2])
    bad = box_soup()
    bad[0, 0, 0] = np.nan
    with pytest.raises(MeshError, match="'nan_box'.*non-finite"):
        repair_part("nan_box", bad)


def test_truncated_msh_is_a_mesh_error_naming_the_file(tmp_path):
    path = tmp_path / "broken.msh"
    path.write_bytes(np.array([10, 0, 0, 5], "<i4").tobytes() + b"\0" * 20)
    with pytest.raises(MeshError, match="broken.msh"):
        read_msh(path)


def test_obj_bytes_are_canonical():
    v = np.array([[0.1, 0.2, 0.3], [1e-9, -0.0, 2.0], [0.0, 1.0, 0.0]])
    a = obj_bytes(v, np.array([[0, 1, 2]]))
    b = obj_bytes(v + 1e-10, np.array([[0, 1, 2]]))  # noise below the written precision
    assert a == b and b"-0.000000" not in a


def test_written_visual_mesh_has_the_original_texture_coordinates_in_mujoco(tmp_path):
    """.msh stores texture coordinates as MuJoCo uses them, OBJ does not (MuJoCo flips v when it
    reads an OBJ): an undeformed part written as OBJ must give MuJoCo the same coordinates."""
    import mujoco

    from vpro_assets.geometry.meshes import load_libero_object, normals_to_indexed
    from vpro_assets.objects.deformed import libero_object_xml

    xml = libero_object_xml("cream_cheese")
    part = load_libero_object("cream_cheese", xml).parts[0]
    v, f, uv, uvf = soup_to_indexed(part.corners, part.uv)
    n, nf = normals_to_indexed(part.normals)
    (tmp_path / "part.obj").write_bytes(obj_bytes(v, f, uv, uvf, normals=n, normal_faces=nf))
    mesh_el = next(m for m in __import__("xml.etree.ElementTree").etree.ElementTree.parse(xml).getroot().iter("mesh"))

    def texcoords(mesh_file, scale):
        model = mujoco.MjModel.from_xml_string(
            f'<mujoco><asset><mesh name="m" file="{mesh_file}" scale="{scale}"/></asset>'
            f'<worldbody><geom type="mesh" mesh="m" contype="0" conaffinity="0"/></worldbody></mujoco>'
        )
        coords = model.mesh_texcoord[model.mesh_texcoordadr[0] : model.mesh_texcoordadr[0] + model.mesh_texcoordnum[0]]
        return np.unique(np.round(coords, 4), axis=0)

    original = texcoords(xml.parent / mesh_el.get("file"), mesh_el.get("scale", "1 1 1"))
    written = texcoords(tmp_path / "part.obj", "1 1 1")
    np.testing.assert_allclose(written, original, atol=2e-4)


def test_a_single_supporting_hull_is_split_into_quadrants():
    import trimesh

    from vpro_assets.geometry.convex import split_support_hulls

    box = trimesh.creation.box((0.08, 0.04, 0.02))
    top = trimesh.creation.box((0.02, 0.02, 0.02))
    top.apply_translation((0, 0, 0.02))
    up, across = np.array([0, 0, 1.0]), (np.array([1.0, 0, 0]), np.array([0, 1.0, 0]))
    hulls = split_support_hulls([box, top], up, across, "test")
    assert len(hulls) == 5
    assert sum(h.volume for h in hulls) == pytest.approx(box.volume + top.volume, rel=1e-6)
    assert all(h.is_convex for h in hulls)
    many = [trimesh.creation.box((0.01, 0.01, 0.01)).apply_translation((x, 0, 0)) for x in (0, 0.02, 0.04)]
    assert split_support_hulls(many, up, across, "test") == many  # enough supports already
