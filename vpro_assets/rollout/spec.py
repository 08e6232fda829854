"""`--policy SPEC`: the one string that names a policy, rebuilt inside every worker.

- `noop`, `random`, `oracle`: reference policies (`oracle` only if the scripted policy exists);
- `openpi:HOST:PORT` or `ws://HOST:PORT`: an openpi websocket policy server;
- `py:MODULE:ATTR` (or plain `MODULE:ATTR`): an in-process Python callable or class.

Options (timeouts, replanning) travel as a JSON-able dict next to the spec.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from vpro_assets.core.errors import VProError
from vpro_assets.rollout.policies.callable import load_attribute, make_python_policy
from vpro_assets.rollout.policies.openpi import OpenpiPolicy
from vpro_assets.rollout.policies.reference import REFERENCE_POLICIES

OPENPI_OPTIONS = ("replan_steps", "connect_timeout", "infer_timeout", "resize", "api_key", "policy_id", "episode_reset")


def parse_openpi(spec: str) -> tuple[str, int]:
    rest = spec.split("://", 1)[1] if "://" in spec else spec.split(":", 1)[1]
    host, _, port = rest.rpartition(":")
    if not host or not port.isdigit():
        raise VProError(f"policy {spec!r}: expected openpi:HOST:PORT or ws://HOST:PORT")
    return host, int(port)


def make_policy(spec: str, options: Mapping[str, Any] | None = None):
    options = {k: v for k, v in (options or {}).items() if v is not None}
    if spec in REFERENCE_POLICIES:
        return REFERENCE_POLICIES[spec]()
    if spec.startswith(("openpi:", "ws://")):
        host, port = parse_openpi(spec)
        return OpenpiPolicy(host, port, **{k: options[k] for k in OPENPI_OPTIONS if k in options})
    target = spec[3:] if spec.startswith("py:") else spec
    if ":" in target:
        return make_python_policy(target)
    raise VProError(
        f"unknown policy {spec!r}: use noop, random, oracle, openpi:HOST:PORT, ws://HOST:PORT or py:MODULE:ATTR"
    )


def check_spec(spec: str) -> None:
    """Fail fast on a spec that cannot work, without building the policy (no model is loaded)."""

    if spec in REFERENCE_POLICIES:
        return
    if spec.startswith(("openpi:", "ws://")):
        parse_openpi(spec)
        return
    target = spec[3:] if spec.startswith("py:") else spec
    if ":" not in target:
        make_policy(spec)  # raises the "unknown policy" error
    load_attribute(target)


def policy_label(spec: str, options: Mapping[str, Any] | None = None) -> str:
    """The policy id recorded in every row (the user's --policy-id if given)."""
    options = options or {}
    return str(options.get("policy_id") or spec)
