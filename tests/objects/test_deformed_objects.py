"""Generated deformed targets: mesh properties, severity, determinism, cache, MuJoCo, LIBERO, exports.

The default run generates the 12 variants of one small target (cream cheese: a scanned mesh with a
one-triangle hole, repaired by hole filling) and one variant of a multi-part, open-surface target
(wine bottle: level-set remesh and boolean union), with coacd's lighter FAST search (recorded in
each object's input key). The slow marker runs every geometry target category with the default
search.
"""

from __future__ import annotations

import json

import numpy as np
import pytest

from vpro_assets.geometry.convex import FAST, MAX_HULLS
from vpro_assets.objects.deformed import (
    UP_AXES,
    default_coacd_params,
    generate_deformed_object,
    load_generated,
    object_name,
    register_generated,
)
from vpro_assets.objects.mjcf import drop_test

DEFORMATIONS = ("taper", "multipeak", "twist", "asymmetric")
SMALL = "cream_cheese"
# Stated bands (ratios deformed / original solid; extents in the upright frame, height last).
VOLUME_BAND = (0.75, 1.30)
HORIZONTAL_EXTENT_BAND = (0.70, 2.00)  # twist-s3 of the flat box widens it most (1.90: its long side, 1.18x, turned)
HEIGHT_BAND = (0.999, 1.001)  # every map moves points horizontally only
REST_SPEED = 0.01  # m/s, largest body speed over the last 0.5 s of a 2 s drop


def fast(category, deformation, severity):
    return default_coacd_params(category, deformation, severity, **FAST)


@pytest.fixture(scope="module")
def out_dir(tmp_path_factory):
    return tmp_path_factory.mktemp("geometry")


@pytest.fixture(scope="module")
def small_objects(out_dir):
    return {
        (d, s): generate_deformed_object(SMALL, d, s, out_dir, coacd_params=fast(SMALL, d, s))
        for d in DEFORMATIONS
        for s in (1, 2, 3)
    }


@pytest.fixture(scope="module")
def original_solid():
    from vpro_assets.geometry.meshes import load_libero_object
    from vpro_assets.geometry.solid import manifold_arrays, repair_part, union
    from vpro_assets.objects.deformed import libero_object_xml

    source = load_libero_object(SMALL, libero_object_xml(SMALL))
    return manifold_arrays(union([repair_part(p.name, p.corners)[0] for p in source.parts]))


def solid_mesh(obj):
    import trimesh

    return trimesh.load(str(obj.path("solid_mesh")), force="mesh", process=False)


def upright(points, up="+z"):
    axis = {"+z": 2, "+y": 1}[up]
    others = [i for i in range(3) if i != axis]
    return points[:, others], points[:, axis]


@pytest.mark.parametrize("deformation", DEFORMATIONS)
@pytest.mark.parametrize("severity", (1, 2, 3))
def test_solid_is_a_closed_manifold_within_the_stated_bands(small_objects, original_solid, deformation, severity):
    obj = small_objects[(deformation, severity)]
    mesh = solid_mesh(obj)
    assert mesh.is_watertight and mesh.is_winding_consistent
    assert mesh.volume > 0
    import trimesh

    original = trimesh.Trimesh(*original_solid, process=False)
    assert VOLUME_BAND[0] <= mesh.volume / original.volume <= VOLUME_BAND[1]
    ratios = mesh.extents / original.extents  # cream cheese's up axis is +z: height is the last
    assert all(HORIZONTAL_EXTENT_BAND[0] <= r <= HORIZONTAL_EXTENT_BAND[1] for r in ratios[:2]), ratios
    assert HEIGHT_BAND[0] <= ratios[2] <= HEIGHT_BAND[1], ratios
    hulls = [f for f in obj.files if f.role == "hull_mesh"]
    assert 1 <= len(hulls) <= min(FAST["max_convex_hull"], MAX_HULLS)
    assert obj.record["measures"]["hull_count"] == len(hulls)


def _shape_measures(vertices, original):
    """Measures of each deformation taken from the written solid alone, against the original."""
    xy, z = upright(vertices)
    oxy, oz = upright(original)
    h0, h1 = z.min(), z.max()
    top, bottom = z > h0 + 0.8 * (h1 - h0), z < h0 + 0.2 * (h1 - h0)
    centre = oxy.mean(axis=0)

    def spread(points):
        return np.linalg.norm(points - centre, axis=1).mean()

    def angle(points):
        cov = np.cov((points - points.mean(axis=0)).T)
        major = np.linalg.eigh(cov)[1][:, -1]
        return np.arctan2(major[1], major[0]) % np.pi

    turn = (angle(xy[top]) - angle(xy[bottom]) + np.pi / 2) % np.pi - np.pi / 2
    radius = np.linalg.norm(xy - centre, axis=1)
    phi = np.arctan2(*(xy - centre).T[::-1])
    o_radius = np.linalg.norm(oxy - centre, axis=1)
    o_phi = np.arctan2(*(oxy - centre).T[::-1])
    lobes = abs(np.mean(radius * np.cos(5 * phi)) - np.mean(o_radius * np.cos(5 * o_phi)))
    return {
        "taper": spread(xy[bottom]) / spread(xy[top]),  # grows as the top narrows
        "twist": abs(turn),  # top slice turned against the bottom slice
        "multipeak": lobes,  # 5-lobe Fourier component of the outline
        "asymmetric": xy[:, 0].mean() - oxy[:, 0].mean(),  # centroid pushed towards the bulge
    }


@pytest.mark.parametrize("deformation", DEFORMATIONS)
def test_severity_increases_the_measured_deformation(small_objects, original_solid, deformation):
    measured, recorded = [], []
    for severity in (1, 2, 3):
        obj = small_objects[(deformation, severity)]
        vertices = np.asarray(solid_mesh(obj).vertices)
        measured.append(_shape_measures(vertices, original_solid[0])[deformation])
        recorded.append(obj.record["measures"]["mean_displacement"])
    baseline = _shape_measures(original_solid[0], original_solid[0])[deformation]
    assert baseline < measured[0] < measured[1] < measured[2], (baseline, measured)
    assert 0 < recorded[0] < recorded[1] < recorded[2], recorded


def test_regeneration_gives_identical_bytes_and_the_cache_skips_unchanged_inputs(small_objects, out_dir, tmp_path):
    first = small_objects[("twist", 2)]
    again = generate_deformed_object(SMALL, "twist", 2, tmp_path, coacd_params=fast(SMALL, "twist", 2))
    assert not again.cached
    assert first.file_hashes() == again.file_hashes()
    for f in first.files:
        assert (out_dir / f.path).read_bytes() == (tmp_path / f.path).read_bytes(), f.path
    mtimes = {f.path: (out_dir / f.path).stat().st_mtime_ns for f in first.files}
    cached = generate_deformed_object(SMALL, "twist", 2, out_dir, coacd_params=fast(SMALL, "twist", 2))
    assert cached.cached and cached.file_hashes() == first.file_hashes()
    assert mtimes == {f.path: (out_dir / f.path).stat().st_mtime_ns for f in cached.files}
    # another input (coacd parameters) is another key: regenerated, not served from the cache
    assert load_generated(out_dir, first.name, {**first.record["input_key"], "coacd": {}}) is None


def test_generation_in_a_child_process_gives_the_same_bytes(small_objects, out_dir, tmp_path):
    # The scene build generates in a child (`isolate`), so the native libraries' leftovers leave
    # with it; the bytes must be those of a generation in this process, and the check for a
    # current object stays here (a current object starts no child).
    first = small_objects[("multipeak", 3)]
    child = generate_deformed_object(
        SMALL, "multipeak", 3, tmp_path, coacd_params=fast(SMALL, "multipeak", 3), isolate=True
    )
    assert not child.cached and child.timings and child.peak_rss_mb > 0  # the child measured itself
    assert child.file_hashes() == first.file_hashes()
    for f in first.files:
        assert (out_dir / f.path).read_bytes() == (tmp_path / f.path).read_bytes(), f.path
    again = generate_deformed_object(
        SMALL, "multipeak", 3, tmp_path, coacd_params=fast(SMALL, "multipeak", 3), isolate=True
    )
    assert again.cached and again.file_hashes() == first.file_hashes()


def test_damaged_output_is_regenerated(small_objects, out_dir):
    obj = small_objects[("taper", 1)]
    hull = obj.path("hull_mesh")
    hull.write_text("damaged")
    regenerated = generate_deformed_object(SMALL, "taper", 1, out_dir, coacd_params=fast(SMALL, "taper", 1))
    assert not regenerated.cached and regenerated.file_hashes() == obj.file_hashes()


@pytest.mark.parametrize("deformation", DEFORMATIONS)
def test_mjcf_object_compiles_without_warning_and_rests_on_a_plane(small_objects, deformation):
    obj = small_objects[(deformation, 3)]
    result = drop_test(obj.xml_path, UP_AXES[SMALL])
    assert result.warnings == {}
    assert result.rests(), result  # no tipping, no drift, no turning over the last 0.5 s
    assert result.speed < REST_SPEED, result
    assert result.mass == pytest.approx(obj.record["measures"]["mass_kg"], rel=1e-5)


def test_mass_is_the_original_objects_mass_in_libero(small_objects):
    import mujoco

    from vpro_assets.objects.deformed import libero_object_xml
    from vpro_assets.objects.mjcf import drop_test_xml

    original = mujoco.MjModel.from_xml_string(drop_test_xml(libero_object_xml(SMALL)))
    mass = original.body_subtreemass[original.body("object").id]
    for obj in small_objects.values():
        assert obj.record["measures"]["mass_kg"] == pytest.approx(mass, rel=1e-5)


def test_exports_reopen_with_usd_core_yourdfpy_and_mujoco(small_objects):
    import mujoco
    import yourdfpy
    from pxr import Usd, UsdGeom, UsdPhysics

    obj = small_objects[("multipeak", 2)]
    hulls = sum(1 for f in obj.files if f.role == "hull_mesh")
    stage = Usd.Stage.Open(str(obj.usd_path))
    meshes = [p for p in stage.Traverse() if p.IsA(UsdGeom.Mesh)]
    assert len(meshes) == hulls + 1
    assert sum(p.HasAPI(UsdPhysics.CollisionAPI) for p in meshes) == hulls
    mass = UsdPhysics.MassAPI(stage.GetDefaultPrim()).GetMassAttr().Get()
    assert mass == pytest.approx(obj.record["measures"]["mass_kg"], rel=1e-5)
    urdf = yourdfpy.URDF.load(str(obj.urdf_path))
    assert len(urdf.robot.links) == 1 and len(urdf.robot.links[0].collisions) == hulls
    assert urdf.scene is not None and len(urdf.scene.geometry) >= 1
    model = mujoco.MjModel.from_xml_path(str(obj.urdf_path))
    assert model.nmesh == hulls and model.body_mass.sum() == pytest.approx(mass, rel=1e-5)


def test_generated_object_registers_and_builds_in_a_libero_scene(small_objects, tmp_path):
    from vpro_assets.libero import bridge as libero_bridge
    from vpro_assets.libero.tasks import get_task
    from vpro_assets.objects.registry import unregister_object

    obj = small_objects[("twist", 3)]
    cls = register_generated(obj)
    assert register_generated(obj) is cls  # idempotent
    try:
        task = get_task("libero_goal-06")  # put the cream cheese in the bowl
        assert task.target_category == SMALL
        text = libero_bridge.bddl_path(task.suite, task.name).read_text()
        bddl = tmp_path / "deformed.bddl"
        bddl.write_text(text.replace(f"{task.target} - {SMALL}", f"{task.target} - {obj.name}"))
        assert bddl.read_text() != text
        rest_original = _settle_in_libero(libero_bridge.bddl_path(task.suite, task.name), task.target)
        rest_deformed, geoms = _settle_in_libero(bddl, task.target, with_geoms=True)
        assert any(obj.name in g and "hull" in g for g in geoms), geoms
        # the deformation moves points horizontally only: it rests at the original's height
        assert abs(rest_deformed - rest_original) < 0.005, (rest_deformed, rest_original)
    finally:
        unregister_object(obj.name)


def _settle_in_libero(bddl, instance, steps=40, with_geoms=False):
    """Build LIBERO's env from `bddl`, step no-ops, return the resting height of `instance`."""
    from vpro_assets.libero import bridge as libero_bridge
    from vpro_assets.libero.env import NOOP_ACTION

    env = libero_bridge.libero_envs().OffScreenRenderEnv(
        bddl_file_name=str(bddl),
        has_offscreen_renderer=False,
        use_camera_obs=False,
        camera_heights=64,
        camera_widths=64,
    )
    try:
        env.reset()
        sim = env.sim
        body = sim.model.body_name2id(f"{instance}_main")
        for _ in range(steps):
            env.step(NOOP_ACTION)
        speed = np.linalg.norm(sim.data.get_body_xvelp(f"{instance}_main"))
        assert speed < 0.01, f"{instance} still moving at {speed:.3f} m/s"
        z = float(sim.data.body_xpos[body][2])
        geoms = [sim.model.geom_id2name(g) or "" for g in range(sim.model.ngeom) if sim.model.geom_bodyid[g] == body]
    finally:
        env.close()
    return (z, geoms) if with_geoms else z


def test_multi_part_open_surface_object(out_dir):
    """The wine bottle: three parts, two of them open surfaces (level-set remesh), joined by union."""
    import trimesh

    obj = generate_deformed_object(
        "wine_bottle", "asymmetric", 2, out_dir, coacd_params=fast("wine_bottle", "asymmetric", 2)
    )
    methods = [r["method"] for r in obj.record["repair"]]
    assert len(methods) == 3 and "level_set" in methods
    assert sum(f.role == "visual_mesh" for f in obj.files) == 3
    mesh = trimesh.load(str(obj.path("solid_mesh")), force="mesh", process=False)
    assert mesh.is_watertight and mesh.volume > 0
    result = drop_test(obj.xml_path, UP_AXES["wine_bottle"])
    assert result.warnings == {} and result.rests() and result.speed < REST_SPEED, result


def test_bad_inputs_give_clear_errors_and_write_nothing(tmp_path, monkeypatch):
    from vpro_assets.core.errors import InvalidParameterError, UnknownIdError
    from vpro_assets.geometry.meshes import MeshError
    from vpro_assets.objects.registry import register_mjcf_object, unregister_object

    with pytest.raises(UnknownIdError, match="akita_blak_bowl"):
        generate_deformed_object("akita_blak_bowl", "taper", 1, tmp_path / "a")
    with pytest.raises(InvalidParameterError, match="bend"):
        generate_deformed_object(SMALL, "bend", 1, tmp_path / "a")
    with pytest.raises(InvalidParameterError, match="severity 4"):
        generate_deformed_object(SMALL, "taper", 4, tmp_path / "a")
    assert not (tmp_path / "a").exists()

    # A LIBERO object whose visual mesh file is broken (a truncated .msh).
    broken = tmp_path / "broken_object"
    (broken / "visual").mkdir(parents=True)
    (broken / "visual" / "broken_vis.msh").write_bytes(np.array([10, 0, 0, 5], "<i4").tobytes() + b"\0" * 20)
    (broken / "broken.xml").write_text("""<mujoco model="broken"><asset>
  <mesh name="broken_vis" file="visual/broken_vis.msh"/></asset>
  <worldbody><body><body name="object">
    <geom type="mesh" mesh="broken_vis" group="1" contype="0" conaffinity="0"/>
    <geom type="box" size="0.02 0.02 0.02" group="0"/></body>
    <site name="bottom_site" pos="0 0 -0.02"/><site name="top_site" pos="0 0 0.02"/>
    <site name="horizontal_radius_site" pos="0.02 0.02 0"/></body></worldbody></mujoco>""")
    register_mjcf_object("vpro_test_broken_mesh", broken / "broken.xml")
    monkeypatch.setitem(UP_AXES, "vpro_test_broken_mesh", "+z")
    try:
        out = tmp_path / "b"
        with pytest.raises(MeshError, match="vpro_vpro_test_broken_mesh_taper_s1_v1: .*broken_vis.msh"):
            generate_deformed_object("vpro_test_broken_mesh", "taper", 1, out, coacd_params=fast("x", "taper", 1))
        assert not out.exists() or list(out.iterdir()) == []
        # Two triangles cannot enclose a volume: named, and nothing written either.
        two = np.array([[[0, 0, 0], [1, 0, 0], [0, 1, 0]], [[1, 0, 0], [1, 1, 0], [0, 1, 0]]], np.float32) * 0.05
        header = np.array([6, 0, 0, 2], "<i4").tobytes()
        (broken / "visual" / "broken_vis.msh").write_bytes(
            header + two.reshape(-1, 3).tobytes() + np.arange(6, dtype="<i4").tobytes()
        )
        unregister_object("vpro_test_broken_mesh")
        register_mjcf_object("vpro_test_broken_mesh", broken / "broken.xml")
        with pytest.raises(MeshError, match="broken_vis.*2 triangles"):
            generate_deformed_object("vpro_test_broken_mesh", "taper", 1, out, coacd_params=fast("x", "taper", 1))
        assert not out.exists() or list(out.iterdir()) == []
    finally:
        unregister_object("vpro_test_broken_mesh")


def test_record_lists_every_file_with_its_hash(small_objects, out_dir):
    from vpro_assets.core.hashing import sha256_file

    obj = small_objects[("asymmetric", 1)]
    assert obj.name == object_name(SMALL, "asymmetric", 1)
    record = json.loads((out_dir / obj.name / "record.json").read_text())
    listed = {f["path"] for f in record["files"]}
    on_disk = {str(p.relative_to(out_dir)) for p in (out_dir / obj.name).rglob("*") if p.is_file()}
    assert on_disk - listed == {f"{obj.name}/record.json"}
    for f in obj.files:
        assert sha256_file(out_dir / f.path) == f.sha256
    assert record["input_key"]["coacd"]["seed"] == fast(SMALL, "asymmetric", 1).seed
    assert record["input_key"]["versions"]["manifold3d"]


@pytest.mark.slow
@pytest.mark.parametrize("category", sorted(UP_AXES))
def test_every_geometry_target_category_generates_valid_objects(category, tmp_path_factory):
    """All 12 variants of every target category with the default coacd search (about an hour)."""
    import trimesh

    out = tmp_path_factory.mktemp(f"all-{category}")
    for deformation in DEFORMATIONS:
        for severity in (1, 2, 3):
            obj = generate_deformed_object(category, deformation, severity, out)
            mesh = trimesh.load(str(obj.path("solid_mesh")), force="mesh", process=False)
            assert mesh.is_watertight and mesh.volume > 0
            m = obj.record["measures"]
            assert VOLUME_BAND[0] <= m["volume_ratio"] <= VOLUME_BAND[1], (obj.name, m)
            assert 1 <= m["hull_count"] <= MAX_HULLS
            result = drop_test(obj.xml_path, UP_AXES[category])
            assert result.warnings == {} and result.rests() and result.speed < REST_SPEED, (obj.name, result)
