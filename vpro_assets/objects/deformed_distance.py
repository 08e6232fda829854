"""How much each deformation changes a target's shape: the symmetric Hausdorff distance between
the original solid and its deformed copy, over the original's bounding-box diagonal
(`vpro_assets.geometry.distance`), for every deformation and severity of the taxonomy.

The solids are the pipeline's own (`repair_solid`, then the setting's map applied to the closed
solid as `deformed_build.deform` does), so the figure measures what the scene cases carry.
"""

from __future__ import annotations

import numpy as np
import trimesh

from vpro_assets.benchmark import taxonomy
from vpro_assets.core.seeding import derive_seed
from vpro_assets.geometry import deform as deform_mod
from vpro_assets.geometry.distance import DEFAULT_SAMPLES, hausdorff_over_diagonal
from vpro_assets.geometry.solid import manifold_arrays
from vpro_assets.objects.deformed import GENERATOR, SEVERITIES, geometry_setting, libero_object_xml, up_axis
from vpro_assets.objects.deformed_build import repair_solid

DEFORMATIONS = tuple(taxonomy.GEOMETRY_SEVERITY)


def shape_distances(category: str, samples: int = DEFAULT_SAMPLES) -> dict[tuple[str, int], float]:
    """{(deformation, severity): Hausdorff distance / bbox diagonal} of LIBERO object `category`."""
    original = repair_solid(category, libero_object_xml(category), up_axis(category))
    before = trimesh.Trimesh(original.vertices, original.faces, process=False)
    out = {}
    for deformation in DEFORMATIONS:
        for severity in SEVERITIES:
            params = geometry_setting(deformation, severity).param_dict
            warp = deform_mod.deformation_map(
                deformation,
                deform_mod.amount_of(deformation, params),
                original.frame,
                **deform_mod.extra_params_of(deformation, params),
            )
            after = trimesh.Trimesh(
                *manifold_arrays(original.solid.warp_batch(lambda p, warp=warp: warp(np.asarray(p)))), process=False
            )
            seed = derive_seed(GENERATOR, category, deformation, severity, "shape_distance")
            out[(deformation, severity)] = hausdorff_over_diagonal(before, after, seed, samples)
    return out
