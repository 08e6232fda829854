"""The distractor pool: LIBERO's movable objects with the attributes the distractor rules read.

The pool is every object category that LIBERO's four suites use as a movable object (read from
their BDDL files, not listed by hand). Each entry has:
- `category` and `family`: semantic class and coarser family (a table, stated here, because a
  mesh does not say that a ramekin is dishware);
- `grasp`: how a parallel gripper takes it (bowl rim, box, bottle, mug handle, can, flat);
- `extents`: sorted bounding-box extents (m) measured from the object's own MJCF in MuJoCo, and
  `footprint`/`height`: its extents as LIBERO places it (its class rotation, middle of the range);
- `color`: its dominant colour (mean texel under the mesh's texture coordinates).
"""

from __future__ import annotations

import functools
import glob
from dataclasses import dataclass

import mujoco
import numpy as np

from vpro_assets.core import mjcache
from vpro_assets.core.errors import VProError
from vpro_assets.core.mjgeom import colliding, geom_corners, quat_matrix
from vpro_assets.libero import bridge as libero_bridge
from vpro_assets.scene.pose import class_quat

# category, family, grasp class: the semantic table (stated data; the distractor rules read it).
SEMANTICS = {
    "akita_black_bowl": ("bowl", "dishware", "bowl"),
    "white_bowl": ("bowl", "dishware", "bowl"),
    "glazed_rim_porcelain_ramekin": ("ramekin", "dishware", "bowl"),
    "plate": ("plate", "dishware", "flat"),
    "wooden_tray": ("tray", "dishware", "flat"),
    "chefmate_8_frypan": ("pan", "cookware", "handle"),
    "moka_pot": ("pot", "cookware", "handle"),
    "basket": ("basket", "container", "handle"),
    "porcelain_mug": ("mug", "drinkware", "handle"),
    "red_coffee_mug": ("mug", "drinkware", "handle"),
    "white_yellow_mug": ("mug", "drinkware", "handle"),
    "wine_bottle": ("bottle", "drinkware", "bottle"),
    "alphabet_soup": ("can", "grocery", "can"),
    "tomato_sauce": ("can", "grocery", "can"),
    "bbq_sauce": ("sauce_bottle", "grocery", "bottle"),
    "ketchup": ("sauce_bottle", "grocery", "bottle"),
    "salad_dressing": ("sauce_bottle", "grocery", "bottle"),
    "new_salad_dressing": ("sauce_bottle", "grocery", "bottle"),
    "milk": ("carton", "grocery", "box"),
    "orange_juice": ("carton", "grocery", "box"),
    "butter": ("small_box", "grocery", "box"),
    "cream_cheese": ("small_box", "grocery", "box"),
    "chocolate_pudding": ("small_box", "grocery", "box"),
    "cookies": ("small_box", "grocery", "box"),
    "black_book": ("book", "book", "box"),
    "yellow_book": ("book", "book", "box"),
}


@dataclass(frozen=True)
class PoolObject:
    name: str  # LIBERO object category (registry key)
    category: str
    family: str
    grasp: str
    extents: tuple[float, float, float]  # sorted ascending, metres
    color: tuple[int, int, int]  # dominant RGB
    footprint: tuple[float, float] = (0.0, 0.0)  # x, y extents as LIBERO places it (class rotation)
    height: float = 0.0  # z extent as LIBERO places it

    @property
    def size(self) -> float:
        return float(np.prod(self.extents)) ** (1 / 3)

    @property
    def aspect(self) -> np.ndarray:
        e = np.asarray(self.extents)
        return e / e[-1]

    @property
    def footprint_radius(self) -> float:
        """Planning radius of its footprint as LIBERO places it: half its longer side plus 10%
        (exact for round objects; the spot margins cover the corners of boxes)."""
        return 0.55 * float(max(self.footprint))

    def to_json(self) -> dict:
        return {
            "name": self.name,
            "category": self.category,
            "family": self.family,
            "grasp": self.grasp,
            "extents": [round(x, 5) for x in self.extents],
            "color": list(self.color),
            "footprint": [round(x, 5) for x in self.footprint],
            "height": round(self.height, 5),
        }


def movable_categories() -> list[str]:
    """Categories used as movable objects anywhere in LIBERO's four suites, sorted."""
    parser = libero_bridge.bddl_parser()
    cats: set[str] = set()
    for suite in libero_bridge.SUITES:
        for path in sorted(glob.glob(str(libero_bridge.libero_root() / "bddl_files" / suite / "*.bddl"))):
            cats |= set(parser.robosuite_parse_problem(path)["objects"])
    return sorted(cats)


def measure_mjcf(
    path: str, quat: np.ndarray | None = None
) -> tuple[tuple[float, float, float], tuple[int, int, int], np.ndarray]:
    """Sorted bounding-box extents, dominant colour, and the (x, y, z) extents of the object
    turned by `quat` (w, x, y, z), e.g. LIBERO's placement rotation of its class."""
    model = mujoco.MjModel.from_xml_path(path)
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    # The geometry that touches the world, as scenes measure it (visual geoms where none collide).
    pts = geom_corners(model, data, colliding(model, range(model.ngeom)) or range(model.ngeom))
    lo, hi = pts.min(0), pts.max(0)
    extents = sorted(float(round(x, 5)) for x in hi - lo)
    turned = pts @ quat_matrix(quat if quat is not None else np.array([1.0, 0.0, 0.0, 0.0])).T
    return (extents[0], extents[1], extents[2]), dominant_color(model), turned.max(0) - turned.min(0)


def dominant_color(model) -> tuple[int, int, int]:
    """Mean colour over the visual geoms: texels under the mesh's own texture coordinates (a texture
    atlas has unused padding), or the material colour where a visual geom has no texture."""
    samples = []
    for g in range(model.ngeom):
        if model.geom_contype[g] or model.geom_conaffinity[g]:
            continue
        mat = model.geom_matid[g]
        tex = -1
        if mat >= 0:
            texids = np.atleast_1d(model.mat_texid[mat])
            tex = int(next((t for t in texids if t >= 0), -1))
        mesh = model.geom_dataid[g] if model.geom_type[g] == mujoco.mjtGeom.mjGEOM_MESH else -1
        if tex >= 0 and mesh >= 0 and model.mesh_texcoordnum[mesh] > 0:
            # Texels under the mesh's own texture coordinates (an atlas has unused padding).
            adr, w, h, nc = model.tex_adr[tex], model.tex_width[tex], model.tex_height[tex], model.tex_nchannel[tex]
            image = model.tex_data[adr : adr + w * h * nc].reshape(h, w, nc)[..., :3]
            a, n = model.mesh_texcoordadr[mesh], model.mesh_texcoordnum[mesh]
            uv = model.mesh_texcoord[a : a + n]
            cols = np.clip((uv[:, 0] % 1.0) * w, 0, w - 1).astype(int)
            rows = np.clip((uv[:, 1] % 1.0) * h, 0, h - 1).astype(int)
            samples.append(image[rows, cols])
        else:
            rgba = model.mat_rgba[mat] if mat >= 0 else model.geom_rgba[g]
            samples.append(np.tile((np.asarray(rgba[:3]) * 255).astype(np.uint8), (100, 1)))
    if not samples:
        return (128, 128, 128)
    r, g, b = (int(round(v)) for v in np.concatenate(samples).astype(np.float64).mean(0))
    return r, g, b


def object_file(category: str) -> str:
    envs = libero_bridge.libero_envs()
    if category not in envs.OBJECTS_DICT:
        raise VProError(f"unknown LIBERO object {category!r}: not in LIBERO's object registry")
    return envs.OBJECTS_DICT[category](name=f"vpro_probe_{category}").file


@functools.cache
def pool() -> dict[str, PoolObject]:
    out = {}
    # Each object is compiled once here: MuJoCo's asset cache would keep their decoded textures
    # (500 MB of them) for compiles that never come.
    with mjcache.capacity(mjcache.SMALLEST):
        for name in movable_categories():
            if name not in SEMANTICS:
                raise VProError(
                    f"LIBERO object {name!r} has no entry in the distractor pool's semantic table "
                    "(vpro_assets/scene/pool.py SEMANTICS)"
                )
            probe = libero_bridge.libero_envs().OBJECTS_DICT[name](name=f"vpro_probe_{name}")
            extents, color, placed = measure_mjcf(probe.file, class_quat(probe))
            out[name] = PoolObject(
                name,
                *SEMANTICS[name],
                extents=extents,
                color=color,
                footprint=(round(float(placed[0]), 5), round(float(placed[1]), 5)),
                height=round(float(placed[2]), 5),
            )
    return out


def get(name: str, case_id: str = "") -> PoolObject:
    table = pool()
    if name not in table:
        where = f"case {case_id}: " if case_id else ""
        raise VProError(f"{where}unknown object {name!r}: not in the distractor pool ({', '.join(table)})")
    return table[name]
