"""Revisions of the generators' case records that depend only on the base task (`plugins`: a change
that concerns some of a generator's cases), read from LIBERO's BDDL without a simulator."""

from __future__ import annotations

from vpro_assets.libero import bridge as libero_bridge
from vpro_assets.libero.tasks import get_task
from vpro_assets.scene import bddl_doc

# Revision STUCK_REVISION of the generators that place an object where the task's target stands
# (`stuck_revision`): `stuck_objects` came after the scene cases were first built, and a scan of
# every built case's stored starts (what `vpro validate` checks) found it rejecting starts only where
# that object stands on libero_spatial-07's stove, through whose 1 mm top plate it had fallen: the
# deformed bowls of taper-s1/-s2/-s3, asymmetric-s1/-s3 and multipeak-s3, and familiar_position's
# ramekin in the bowl's place. Those generators' cases of a target on a thin plate are built again.
STUCK_REVISION = "stuck1"
THIN_PLATE_REGIONS = ("flat_stove_1_cook_region",)


def target_support(case: dict) -> str | None:
    """What the case's task stands its target on in LIBERO's BDDL (`(On target X)`: an object
    instance or a region), None where the init states none."""
    task = get_task(case["task"])
    for pred in bddl_doc.read_base(libero_bridge.bddl_path(task.suite, task.name)).init:
        words = pred.strip("()").split()
        if len(words) == 3 and words[0] == "On" and words[1] == task.target:
            return words[2]
    return None


def stuck_revision(case: dict) -> str:
    """STUCK_REVISION where the case's task stands its target on a thin plate, else ""."""
    return STUCK_REVISION if target_support(case) in THIN_PLATE_REGIONS else ""
