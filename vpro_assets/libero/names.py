"""Names LIBERO and robosuite give things that the toolkit reads: the two cameras, the gripper prefix.

Standard library only (part of the run-time layer copied into packs, `vpro_assets.packs.vendor`).
"""

from __future__ import annotations

CAMERAS = ("agentview", "robot0_eye_in_hand")
GRIPPER_PREFIX = "gripper0_"  # robosuite's prefix of every body and geom of the first robot's gripper
