"""Register MJCF object files with LIBERO under explicit names, refusing clashes.

LIBERO looks objects up by snake_case category name in `libero.libero.envs.OBJECTS_DICT`, each a
`MujocoXMLObject` subclass. Its own `register_object` derives the name from the class name and a
later registration silently replaces an earlier one. Here a name is given explicitly, a name that
already means a different object is refused, and registering the identical object again returns
the class already registered (so a worker may register everything it needs at start-up).

"Identical" means: the same XML bytes, the same bytes of every file the XML references (meshes,
textures) and the same placement attributes, wherever the file lies (a rebuild in another folder
registers again without complaint; the first copy keeps serving while it exists). Any MJCF object file in LIBERO's layout works
(`<worldbody><body><body name="object">...</body><site name="bottom_site"/>...</body></worldbody>`):
generated deformed targets, recoloured distractors, visual-only copies.
"""

from __future__ import annotations

import copy
import hashlib
import logging
import re
import xml.etree.ElementTree as ET
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from vpro_assets.core.errors import UnknownIdError, VProError
from vpro_assets.libero import bridge as libero_bridge
from vpro_assets.objects.derived import referenced_files

log = logging.getLogger(__name__)

NAME_RE = re.compile(r"^[a-z][a-z0-9]*(_[a-z0-9]+)*$")
REQUIRED_SITES = ("bottom_site", "top_site", "horizontal_radius_site")
DEFAULT_JOINTS = ({"type": "free", "damping": "0.0005"},)
_PLACEMENT_KEYS = ("rotation", "rotation_axis")


class ObjectRegistryError(VProError):
    """An object name clashes, is malformed, or its MJCF file is not a LIBERO object."""


@dataclass(frozen=True)
class ObjectIdentity:
    """What makes two registrations the same object."""

    xml_path: str
    content_sha256: str  # over the XML and every file it references, in a fixed order
    placement: str  # repr of the placement attributes (rotation, rotation_axis, properties)


def _objects_dict() -> dict[str, type]:
    return libero_bridge.libero_envs().OBJECTS_DICT


def check_mjcf_object(xml_path: Path | str) -> ET.Element:
    """Parse `xml_path` and check it has LIBERO's object layout; return the root element."""
    xml_path = Path(xml_path)
    if not xml_path.is_file():
        raise ObjectRegistryError(f"MJCF object file {xml_path} does not exist")
    try:
        root = ET.parse(xml_path).getroot()
    except ET.ParseError as exc:
        raise ObjectRegistryError(f"MJCF object file {xml_path} is not valid XML: {exc}") from exc
    if root.tag != "mujoco":
        raise ObjectRegistryError(f"{xml_path}: root element is <{root.tag}>, expected <mujoco>")
    outer = root.find("./worldbody/body")
    if outer is None or outer.find("./body[@name='object']") is None:
        raise ObjectRegistryError(f"{xml_path}: no <worldbody><body><body name='object'> (LIBERO's object layout)")
    sites = {s.get("name") for s in outer.findall("./site")}
    missing = [s for s in REQUIRED_SITES if s not in sites]
    if missing:
        raise ObjectRegistryError(f"{xml_path}: missing placement site(s) {', '.join(missing)} under the outer body")
    for element, rel in referenced_files(root):
        if not (xml_path.parent / rel).is_file():
            raise ObjectRegistryError(f"{xml_path}: <{element.tag}> references {rel!r}, which does not exist")
    return root


def content_sha256(xml_path: Path | str) -> str:
    """sha256 over the XML bytes and the bytes of every file it references (in document order)."""
    xml_path = Path(xml_path)
    root = check_mjcf_object(xml_path)
    digest = hashlib.sha256()
    digest.update(xml_path.read_bytes())
    for element, rel in referenced_files(root):
        digest.update(b"\0" + element.get("file", "").encode() + b"\0")
        digest.update(hashlib.sha256((xml_path.parent / rel).read_bytes()).digest())
    return digest.hexdigest()


def _placement_from(template: str | None, overrides: Mapping[str, Any]) -> dict[str, Any]:
    placement: dict[str, Any] = {
        "rotation": (0.0, 0.0),
        "rotation_axis": "z",
        "object_properties": {"vis_site_names": {}},
    }
    if template is not None:
        objects = _objects_dict()
        if template not in objects:
            raise UnknownIdError("LIBERO object", template, objects)
        probe = objects[template]()  # LIBERO's objects all construct with default arguments
        for key in _PLACEMENT_KEYS + ("object_properties",):
            if hasattr(probe, key):
                placement[key] = getattr(probe, key)
    for key, value in overrides.items():
        if key not in _PLACEMENT_KEYS + ("object_properties",):
            raise ObjectRegistryError(
                f"unknown placement attribute {key!r}; allowed: rotation, rotation_axis, object_properties"
            )
        placement[key] = value
    return placement


def _class_name(name: str) -> str:
    return "Vpro" + "".join(part.capitalize() for part in name.split("_"))


def register_mjcf_object(
    name: str,
    xml_path: Path | str,
    *,
    template: str | None = None,
    **placement_overrides: Any,
) -> type:
    """Register the MJCF object at `xml_path` in LIBERO's `OBJECTS_DICT` as `name`; return its class.

    template: an existing LIBERO object name whose placement attributes (`rotation`,
        `rotation_axis`, `object_properties`) the new object copies, so it is placed and oriented
        exactly like the object it varies (e.g. "akita_black_bowl" for a deformed bowl).
    placement_overrides: `rotation=(a, b)`, `rotation_axis="z"`, `object_properties={...}`.

    Raises ObjectRegistryError when `name` is not snake_case, the file is not a LIBERO object, or
    `name` is already registered for a different object (LIBERO's own objects included).
    """
    if not isinstance(name, str) or not NAME_RE.match(name):
        raise ObjectRegistryError(f"object name {name!r} is not snake_case ([a-z][a-z0-9]* joined by '_')")
    xml_path = Path(xml_path).resolve()
    sha = content_sha256(xml_path)
    placement = _placement_from(template, placement_overrides)
    identity = ObjectIdentity(str(xml_path), sha, repr(sorted(placement.items())))
    objects = _objects_dict()
    existing = objects.get(name)
    if existing is not None:
        other = getattr(existing, "_vpro_identity", None)
        if other is not None and (other.content_sha256, other.placement) == (sha, identity.placement):
            # The identical object (same bytes, same placement), perhaps from another folder.
            if other.xml_path == identity.xml_path or _still_there(other):
                return existing
            cls = _make_class(name, xml_path, placement, identity)  # the first copy is gone: use this one
            objects[name] = cls
            return cls
        where = f"{other.xml_path} (content {other.content_sha256[:12]})" if other else f"LIBERO's {existing.__name__}"
        raise ObjectRegistryError(
            f"object name {name!r} is already registered for a different object: {where}; "
            f"refusing to replace it with {xml_path} (content {sha[:12]})"
        )
    cls = _make_class(name, xml_path, placement, identity)
    objects[name] = cls
    log.debug("registered LIBERO object %s from %s", name, xml_path)
    return cls


def _still_there(identity: ObjectIdentity) -> bool:
    try:
        return content_sha256(identity.xml_path) == identity.content_sha256
    except ObjectRegistryError:
        return False


def _make_class(name: str, xml_path: Path, placement: dict[str, Any], identity: ObjectIdentity) -> type:
    from robosuite.models.objects import MujocoXMLObject  # robosuite loads only once LIBERO is configured

    def __init__(self, name: str = name, joints: Any = "template", **_ignored: Any) -> None:
        if isinstance(joints, str) and joints == "template":
            joints = [dict(j) for j in DEFAULT_JOINTS]
        MujocoXMLObject.__init__(
            self, str(xml_path), name=name, joints=joints, obj_type="all", duplicate_collision_geoms=False
        )
        self.category_name = type(self).registered_name
        for key, value in placement.items():
            setattr(self, key, copy.deepcopy(value))

    return type(
        _class_name(name),
        (MujocoXMLObject,),
        {
            "__init__": __init__,
            "__doc__": f"LIBERO object {name!r} loaded from {xml_path} (registered by vpro_assets.objects.registry).",
            "__module__": __name__,
            "registered_name": name,
            "xml_path": str(xml_path),
            "_vpro_identity": identity,
        },
    )


def unregister_object(name: str) -> None:
    """Remove an object this module registered (LIBERO's own objects are never removed)."""
    objects = _objects_dict()
    cls = objects.get(name)
    if cls is None:
        return
    if getattr(cls, "_vpro_identity", None) is None:
        raise ObjectRegistryError(f"{name!r} is one of LIBERO's own objects; it cannot be unregistered")
    del objects[name]
