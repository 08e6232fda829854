"""Objects derived from a LIBERO object's MJCF file (recoloured, visual-only copies): the files the
source references, found as MuJoCo finds them, copied beside the edited XML, then the XML written.

A mesh (or height field, skin) is looked up under the compiler's `meshdir`, a texture under its
`texturedir` (either falling back to `assetdir`), every other file beside the XML. Copies keep the
same paths relative to the new XML, so the compiler settings stay valid and the object folder is
self-contained.
"""

from __future__ import annotations

import shutil
import xml.etree.ElementTree as ET
from collections.abc import Iterator
from pathlib import Path

_DIR_ATTRS = {"mesh": "meshdir", "hfield": "meshdir", "skin": "meshdir", "texture": "texturedir"}


def referenced_files(root: ET.Element) -> Iterator[tuple[ET.Element, str]]:
    """(element, path relative to the XML's folder) of every file the MJCF references, in document
    order."""
    compiler = root.find("compiler")
    for element in root.iter():
        rel = element.get("file")
        if not rel:
            continue
        folder = ""
        if compiler is not None and element.tag in _DIR_ATTRS:
            folder = compiler.get(_DIR_ATTRS[element.tag], compiler.get("assetdir", ""))
        yield element, str(Path(folder) / rel) if folder else rel


def copy_referenced_files(root: ET.Element, src_xml: Path, directory: Path) -> None:
    """Copy the files `root` (parsed from `src_xml`, perhaps edited) references into `directory`,
    at the same paths relative to the XML."""
    directory.mkdir(parents=True, exist_ok=True)
    for _element, rel in referenced_files(root):
        (directory / rel).parent.mkdir(parents=True, exist_ok=True)
        shutil.copyfile(src_xml.parent / rel, directory / rel)


def write_object_xml(root: ET.Element, name: str, directory: Path) -> Path:
    """Write `root` as `directory/<name>.xml` (model named `name`, indented, UTF-8); return the path."""
    root.set("model", name)
    ET.indent(root)
    out = directory / f"{name}.xml"
    out.write_bytes(ET.tostring(root, encoding="utf-8") + b"\n")
    return out


def write_derived(root: ET.Element, src_xml: Path, name: str, directory: Path) -> Path:
    """The derived object in `directory`: the source's referenced files, then the XML."""
    copy_referenced_files(root, src_xml, directory)
    return write_object_xml(root, name, directory)
