"""Recoloured copies of LIBERO objects (the same-colour distractor).

The copy keeps the source object's meshes, collision geometry, sites and mass; every material
loses its texture and takes one flat colour. Files referenced by the source MJCF are copied next
to the new XML (same relative paths), so the object directory is self-contained.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from pathlib import Path

from vpro_assets.objects.derived import write_derived
from vpro_assets.scene.pool import object_file
from vpro_assets.scene.variant import GeneratedObject


def recolored_name(source: str, color: tuple[int, int, int]) -> str:
    return f"vpro_recolor_{source}_{bytes(color).hex()}"


def write_recolored(source: str, color: tuple[int, int, int], directory: Path) -> Path:
    src_xml = Path(object_file(source))
    root = ET.parse(src_xml).getroot()
    rgba = " ".join(f"{c / 255:.4f}" for c in color) + " 1"
    asset = root.find("asset")
    if asset is not None:
        for tex in asset.findall("texture"):
            asset.remove(tex)
    for mat in root.iter("material"):
        mat.attrib.pop("texture", None)
        mat.set("rgba", rgba)
    return write_derived(root, src_xml, recolored_name(source, color), directory)


def recolored_object(source: str, color: tuple[int, int, int]) -> GeneratedObject:
    return GeneratedObject(
        name=recolored_name(source, color),
        write=lambda directory: write_recolored(source, color, directory),
        template=source,
    )
