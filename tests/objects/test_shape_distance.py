"""Every deformation changes every target's shape, more at each severity: the symmetric Hausdorff
distance between the original and the deformed solid, over the original's bounding-box diagonal,
is above its documented floor (docs/geometry.md, "How far each deformation moves the surface")
and grows from severity 1 to 3. Twist included: since version 2 it makes the slices elliptical
before turning them, so round targets (cans, bowls, plates) change shape too.

The default run measures three round targets; the slow marker every target category.
"""

from __future__ import annotations

import functools

import numpy as np
import pytest
import trimesh

from vpro_assets.geometry import deform
from vpro_assets.geometry.distance import hausdorff_over_diagonal
from vpro_assets.geometry.solid import manifold_arrays
from vpro_assets.objects.deformed import UP_AXES, libero_object_xml, up_axis
from vpro_assets.objects.deformed_build import repair_solid
from vpro_assets.objects.deformed_distance import DEFORMATIONS, shape_distances

# Floors per (deformation, severity): the smallest value over the 17 target categories in the
# table of docs/geometry.md, times 0.9, rounded down (room for other library versions' meshes).
FLOORS = {
    ("taper", 1): 0.008,
    ("taper", 2): 0.019,
    ("taper", 3): 0.031,
    ("multipeak", 1): 0.007,
    ("multipeak", 2): 0.014,
    ("multipeak", 3): 0.021,
    ("twist", 1): 0.009,
    ("twist", 2): 0.018,
    ("twist", 3): 0.027,
    ("asymmetric", 1): 0.007,
    ("asymmetric", 2): 0.015,
    ("asymmetric", 3): 0.022,
}
ROUND = ("alphabet_soup", "akita_black_bowl", "plate")  # solids of revolution: twist v1 left them in place
OTHERS = tuple(sorted(set(UP_AXES) - set(ROUND)))


@functools.cache
def distances(category: str) -> dict[tuple[str, int], float]:
    return shape_distances(category)


def check_category(category: str) -> None:
    measured = distances(category)
    for deformation in DEFORMATIONS:
        by_severity = [measured[(deformation, s)] for s in (1, 2, 3)]
        for severity, value in enumerate(by_severity, start=1):
            floor = FLOORS[(deformation, severity)]
            assert value >= floor, f"{category} {deformation}-s{severity}: {value:.4f} < floor {floor}"
        assert by_severity[0] < by_severity[1] < by_severity[2], f"{category} {deformation}: {by_severity}"


@pytest.mark.parametrize("category", ROUND)
def test_every_deformation_moves_a_round_target_more_at_each_severity(category):
    check_category(category)


@pytest.mark.slow
@pytest.mark.parametrize("category", OTHERS)
def test_every_deformation_moves_every_target_more_at_each_severity(category):
    check_category(category)


def test_a_rotation_of_the_slices_alone_leaves_a_bowl_in_place():
    """Why twist changed: turning each slice of a solid of revolution gives back nearly the same
    solid (the bowl: 0.5% of its diagonal, from the scan's small asymmetries), while version 2
    moves its surface by more than the twist-s3 floor. (The can reads 3.9% for a rotation alone,
    all of it from the tab on its lid: the 99th percentile of its distances is 0.5%.)"""
    category = "akita_black_bowl"
    original = repair_solid(category, libero_object_xml(category), up_axis(category))
    before = trimesh.Trimesh(original.vertices, original.faces, process=False)

    def twisted(**extra):
        warp = deform.deformation_map("twist", 60.0, original.frame, **extra)
        solid = original.solid.warp_batch(lambda p: warp(np.asarray(p)))
        return trimesh.Trimesh(*manifold_arrays(solid), process=False)

    rotation_only = hausdorff_over_diagonal(before, twisted(), seed=0)
    version2 = hausdorff_over_diagonal(before, twisted(twist_ellipticity=0.18), seed=0)
    assert rotation_only < 0.01 < FLOORS[("twist", 3)] <= version2


def test_hausdorff_of_two_spheres_is_the_radius_difference():
    small, large = trimesh.creation.icosphere(5, 1.0), trimesh.creation.icosphere(5, 1.2)
    value = hausdorff_over_diagonal(small, large, seed=0, samples=500)
    assert value == pytest.approx(0.2 / np.linalg.norm(small.extents), rel=0.02)
