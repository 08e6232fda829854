"""A settled LIBERO start as data: what a settled-scene fingerprint records and how two are compared.

After `reset()`, `set_init_state(row)` and the no-op wait steps, a start is the pose of every
movable object (`objects_dict`: position, quaternion w x y z, rounded to POSE_DECIMALS) and the
position of every articulated joint (hinge and slide joints that are not the robot's: drawers,
doors, knobs). Two starts of the same trial differ by the largest object displacement (cm), the
largest tilt change (degrees between the bodies' up axes) and the largest joint change; beyond
TOLERANCES a case has drifted.

One definition for every place a start is checked: `vpro settle` / `vpro drift`
(`vpro_assets.rollout.settle`, `vpro_assets.benchmark.fingerprints`) and the pack runtime a LIBERO
fork runs without the toolkit (`vpro_assets.packs.fork_drift`, shipped in every pack), so this
module imports only numpy and mujoco.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping, Sequence
from importlib import metadata
from typing import Any

import mujoco
import numpy as np

#: The wait steps' action: arm still, gripper open.
NOOP_ACTION = np.array([0, 0, 0, 0, 0, 0, -1], dtype=np.float64)
POSE_DECIMALS = 5  # 10 micrometres; far below every tolerance of the drift check
# Beyond any of these a case has drifted (docs/simulator.md). Reruns under one simulator agree
# exactly; between MuJoCo 3.8.1 and 3.2.3 the 36 unaffected Normal baselines differ by at most
# 0.56 cm (libero_spatial-08: the same resting place, a few mm over) and 0.3 deg, the affected ones
# by 3.5 cm / 12.5 deg (libero_spatial-05) and 54 cm (libero_10-00, -01, -07).
TOLERANCES = {"displacement_cm": 0.75, "tilt_deg": 5.0, "joint_change": 0.01}
ROBOT_PREFIXES = ("robot0_", "gripper0_")
#: The fingerprint file (beside the catalog, and in every pack) and its schema.
FILE_NAME = "settle_fingerprints.json"
SCHEMA_VERSION = 1
#: The packages whose versions decide a scene's physics (a fingerprint records them).
SIMULATOR_PACKAGES = ("mujoco", "robosuite", "hf-libero")


def keep_property_samplers(inner, copies: int) -> None:
    """Keep `copies` copies of LIBERO's articulation samplers, as a new env has them.

    LIBERO adds a sampler to `object_property_initializers` for every articulation state in the
    BDDL's :init (an open drawer, a closed microwave, a stove turned off) at every model load, and
    never clears the list. At a reset every sampler in it draws from numpy's seeded stream before
    the fixtures (cabinets, racks, microwaves) are placed, so each hard reset of one env drew more
    and placed the fixtures elsewhere (up to ~1 cm): the scene of a trial depended on how many
    trials the env had run before it. A new env has one copy from its construction; its first reset
    adds the second.
    """
    while not hasattr(inner, "object_property_initializers"):  # through wrappers (a fork's, ours)
        if not hasattr(inner, "env"):
            return  # a LIBERO without the list: nothing accumulates
        inner = inner.env
    samplers = inner.object_property_initializers
    # Every load appends the same samplers in the same order: the distinct ones are one load's (a
    # sampler without LIBERO's name and state counts as its own, so nothing unknown is dropped).
    per_load = len({(getattr(s, "name", id(s)), getattr(s, "state_type", None)) for s in samplers})
    samplers[:] = samplers[:per_load] * copies


def seeded_reset(env, seed: int):
    """A trial's reset: `env.seed(seed)`, then `reset()` placing the fixtures as the first reset of
    a new env does, whatever the env ran before (`env`: LIBERO's env or a wrapper); its observation."""
    keep_property_samplers(env, 1)
    env.seed(int(seed))
    return env.reset()


def movable_objects(inner) -> dict[str, int]:
    """Name -> body id of a LIBERO env's movable objects (`inner`: the robosuite env, `env.env`)."""
    return {name: inner.obj_body_id[name] for name in inner.objects_dict}


def articulated_joints(model) -> dict[str, int]:
    """Name -> qpos address of the scene's hinge and slide joints, the robot's excluded."""
    joints = {}
    for joint in range(model.njnt):
        name = mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_JOINT, joint) or ""
        if model.jnt_type[joint] in (mujoco.mjtJoint.mjJNT_HINGE, mujoco.mjtJoint.mjJNT_SLIDE) and not name.startswith(
            ROBOT_PREFIXES
        ):
            joints[name] = int(model.jnt_qposadr[joint])
    return joints


def pose(data, body: int) -> list[float]:
    """A body's position and quaternion, rounded (`+ 0.0` turns -0.0 into 0.0: stable text)."""
    return [round(float(v), POSE_DECIMALS) + 0.0 for v in (*data.xpos[body], *data.xquat[body])]


def joint_positions(model, data) -> dict[str, float]:
    """The articulated joints' positions, rounded like poses."""
    return {name: round(float(data.qpos[adr]), POSE_DECIMALS) + 0.0 for name, adr in articulated_joints(model).items()}


def read_start(inner) -> dict:
    """`{"objects": name -> {"pose": ...}, "joints": name -> position}` of a LIBERO env now."""
    model, data = inner.sim.model._model, inner.sim.data._data
    return {
        "objects": {name: {"pose": pose(data, body)} for name, body in movable_objects(inner).items()},
        "joints": joint_positions(model, data),
    }


def tilt_deg(quat_a, quat_b) -> float:
    """Angle between the bodies' up axes, in degrees."""
    ups = []
    for quat in (quat_a, quat_b):
        quat = np.asarray(quat, dtype=np.float64)
        up = np.zeros(3)
        mujoco.mju_rotVecQuat(up, np.array([0.0, 0.0, 1.0]), quat / np.linalg.norm(quat))  # poses are rounded
        ups.append(up)
    return float(np.degrees(np.arctan2(np.linalg.norm(np.cross(ups[0], ups[1])), ups[0] @ ups[1])))


def pose_difference(a: Mapping, b: Mapping) -> dict:
    """Largest object displacement (cm, with its object), tilt change (deg) and joint change between
    two settled records of the same trial (`objects` with `pose`, `joints`)."""
    worst: dict[str, Any] = {
        "displacement_cm": 0.0,
        "object": None,
        "tilt_deg": 0.0,
        "tilt_object": None,
        "joint_change": 0.0,
        "joint": None,
        "missing": [],
    }
    for name, obj in a["objects"].items():
        other = b["objects"].get(name)
        if other is None:
            worst["missing"].append(name)
            continue
        pa, pb = np.asarray(obj["pose"]), np.asarray(other["pose"])
        moved = float(np.linalg.norm(pa[:3] - pb[:3]) * 100)
        tilt = tilt_deg(pa[3:], pb[3:])
        if moved > worst["displacement_cm"]:
            worst["displacement_cm"], worst["object"] = moved, name
        if tilt > worst["tilt_deg"]:
            worst["tilt_deg"], worst["tilt_object"] = tilt, name
    for name, value in a["joints"].items():
        change = abs(value - b["joints"].get(name, value))
        if change > worst["joint_change"]:
            worst["joint_change"], worst["joint"] = change, name
    worst["missing"] += [name for name in b["objects"] if name not in a["objects"]]
    return worst


def empty_row(case: str) -> dict:
    """A `compare` row with nothing measured yet."""
    return {
        "case": case,
        "trials": 0,
        "displacement_cm": 0.0,
        "object": None,
        "tilt_deg": 0.0,
        "tilt_object": None,
        "joint_change": 0.0,
        "joint": None,
        "worst_trial": None,
        "status": "ok",
        "note": "",
    }


def compare(fingerprints: Mapping, records: Iterable[Mapping], tolerances: Mapping | None = None) -> list[dict]:
    """One row per case: largest displacement, tilt and joint change over its trials against the
    fingerprints (`cases`: id -> {inputs, trials}), `status` drifted / ok / stale / missing, the
    worst trial. A record: `case`, `trial`, `seed`, `inputs` (bddl and init_states sha256,
    init_row), `objects` (name -> {pose}), `joints`."""
    tol = dict(TOLERANCES, **(tolerances or {}))
    rows: dict[str, dict] = {}
    for rec in records:
        row = rows.setdefault(rec["case"], empty_row(rec["case"]))
        entry = fingerprints["cases"].get(rec["case"])
        recorded = entry["trials"].get(str(rec["trial"])) if entry else None
        if recorded is None:
            row["status"], row["note"] = "missing", f"no fingerprint for trial {rec['trial']}"
            continue
        inputs = {"bddl": rec["inputs"]["bddl"], "init_states": rec["inputs"]["init_states"]}
        if (
            entry["inputs"] != inputs
            or recorded["init_row"] != rec["inputs"]["init_row"]
            or recorded["seed"] != rec["seed"]
        ):
            row["status"], row["note"] = (
                "stale",
                "the case's BDDL, initial states or seed changed since the fingerprint",
            )
            continue
        diff = pose_difference(
            rec, {"objects": {n: {"pose": p} for n, p in recorded["objects"].items()}, "joints": recorded["joints"]}
        )
        row["trials"] += 1
        if diff["displacement_cm"] > row["displacement_cm"]:
            row.update(displacement_cm=diff["displacement_cm"], object=diff["object"], worst_trial=rec["trial"])
        if diff["tilt_deg"] > row["tilt_deg"]:
            row.update(tilt_deg=diff["tilt_deg"], tilt_object=diff["tilt_object"])
            row["worst_trial"] = rec["trial"] if row["worst_trial"] is None else row["worst_trial"]
        if diff["joint_change"] > row["joint_change"]:
            row.update(joint_change=diff["joint_change"], joint=diff["joint"])
        if diff["missing"]:
            row["status"], row["note"] = "drifted", f"objects not in both: {', '.join(diff['missing'])}"
    for row in rows.values():
        if row["status"] == "ok" and any(row[k] > tol[k] for k in ("displacement_cm", "tilt_deg", "joint_change")):
            row["status"] = "drifted"
    return list(rows.values())


def simulator_versions() -> dict[str, str]:
    """Installed versions of the packages that decide a scene's physics, read without importing them."""
    versions = {}
    for name in SIMULATOR_PACKAGES:
        try:
            versions[name] = metadata.version(name)
        except metadata.PackageNotFoundError:
            versions[name] = "not installed"
    return versions


def simulator_label(versions: Mapping) -> str:
    """One short name for a simulator: `mujoco 3.2.3 / robosuite 1.4.1 / hf-libero 0.1.4`."""
    return " / ".join(f"{name} {versions.get(name, '?')}" for name in SIMULATOR_PACKAGES)


def table_lines(rows: Iterable[Mapping]) -> list[str]:
    """The drift table, one Markdown row per case (`compare`'s rows)."""
    lines = [
        "| case | trials | displacement (cm) | object | tilt change (deg) | object | joint change | status |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for row in rows:
        lines.append(
            f"| {row['case']} | {row['trials']} | {row['displacement_cm']:.2f} | {row['object'] or '-'} "
            f"| {row['tilt_deg']:.1f} | {row['tilt_object'] or '-'} | {row['joint_change']:.4f} {row['joint'] or ''} "
            f"| {row['status']}{': ' + row['note'] if row['note'] else ''} |"
        )
    return lines


def summary_lines(rows: Sequence[Mapping]) -> list[str]:
    """The verdict under the table: how many drifted (beyond TOLERANCES), which, and what was not checked."""
    drifted = [r for r in rows if r["status"] == "drifted"]
    unchecked = [r for r in rows if r["status"] in ("stale", "missing")]
    tol = TOLERANCES
    lines = [
        f"{len(drifted)} of {len(rows)} case(s) drifted beyond {tol['displacement_cm']} cm / {tol['tilt_deg']} deg / "
        f"joint {tol['joint_change']}"
        + (f"; {len(unchecked)} not checked (stale or missing fingerprints)" if unchecked else "")
    ]
    if drifted:
        lines.append("drifted: " + " ".join(r["case"] for r in drifted))
    return lines
