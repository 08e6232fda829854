"""MuJoCo's warnings through Python logging (logger "mujoco") instead of its default handler, which
prints them and appends them to MUJOCO_LOG.TXT in the working directory: a user's `vpro validate`
of a scene that makes MuJoCo warn would leave that file wherever they ran it, and the toolkit
writes nothing outside its tree and the output the user named. The checks that care about
warnings count them in `MjData.warning` themselves (`scene.validate`, `objects.mjcf`).

Set once per process where a toolkit process starts (the CLI, and each pool worker: build,
validate, settle, rollout, the deformed-object child); a handler installed before, by a fork's
own code, is kept."""

from __future__ import annotations

import logging

import mujoco

log = logging.getLogger("mujoco")


def _to_log(text: str) -> None:
    log.warning("%s", text.strip())


def route_warnings() -> None:
    if mujoco.get_mju_user_warning() is None:
        mujoco.set_mju_user_warning(_to_log)
