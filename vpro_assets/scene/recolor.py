"""Recoloured copies of LIBERO objects (the same-colour distractor).

The copy keeps the source object's meshes, collision geometry, sites and mass; every material
loses its texture and takes one flat colour. Files referenced by the source MJCF are copied next
to the new XML (same relative paths), so the object directory is self-contained.
"""
from __future__ import annotations

import shutil
import xml.etree.ElementTree as ET
from pathlib import Path

from vpro_assets.scene.pool import object_file
from vpro_assets.scene.variant import GeneratedObject


def recolored_name(source: str, color: tuple[int, int, int]) -> str:
    return f"vpro_recolor_{source}_{bytes(color).hex()}"


def write_recolored(source: str, color: tuple[int, int, int], directory: Path) -> Path:
    src_xml = Path(object_file(source))
    root = ET.parse(src_xml).getroot()
    rgba = " ".join(f"{c / 255:.4f}" for c in color) + " 1"
    asset = root.find("asset")
    for tex in list(asset.findall("texture")) if asset is not None else []:
        asset.remove(tex)
    for mat in root.iter("material"):
        mat.attrib.pop("texture", None)
        mat.set("rgba", rgba)
    directory.mkdir(parents=True, exist_ok=True)
    for element in root.iter():
        rel = element.get("file")
        if rel:
            dst = directory / rel
            dst.parent.mkdir(parents=True, exist_ok=True)
            shutil.copyfile(src_xml.parent / rel, dst)
    root.set("model", recolored_name(source, color))
    out = directory / f"{recolored_name(source, color)}.xml"
    ET.indent(root)
    out.write_bytes(ET.tostring(root, encoding="utf-8") + b"\n")
    return out


def recolored_object(source: str, color: tuple[int, int, int]) -> GeneratedObject:
    return GeneratedObject(
        name=recolored_name(source, color),
        write=lambda directory: write_recolored(source, color, directory),
        template=source,
        fingerprint=f"recolor-v1|{source}|{bytes(color).hex()}|{Path(object_file(source)).read_bytes().hex()[:0]}",
    )
