"""One unit of work, `execute_job(job) -> row`, run the same way by every backend.

A job is a JSON-able dict (case record, trial, run id, policy spec and options, episode settings,
retry budget). The worker keeps one policy per spec (one websocket connection per worker), runs the
episode, and turns every outcome into a row:
- `ok`: the episode ran; `success` is the task's verdict;
- `unavailable`: the case cannot run in this checkout (not built, layer missing); not retried;
- `error`: an infrastructure error (server down or slow, NaN or misshapen actions, simulator
  exception) that persisted through `retries` further attempts; never a policy failure.
"""

from __future__ import annotations

import json
import logging
import os
import socket
import time
import traceback

from vpro_assets.core import mjlog, provenance
from vpro_assets.core.errors import VProError
from vpro_assets.libero.bridge import simulator_versions
from vpro_assets.rollout.case_env import CaseUnavailableError
from vpro_assets.rollout.episode import EpisodeSettings, run_episode
from vpro_assets.rollout.policies.base import InfrastructureError, Policy
from vpro_assets.rollout.spec import make_policy, policy_label
from vpro_assets.rollout.store import utc_now

log = logging.getLogger(__name__)

_POLICIES: dict[str, Policy] = {}


def _policy(spec: str, options: dict):
    key = spec + "|" + json.dumps(options, sort_keys=True)
    if key not in _POLICIES:
        _POLICIES[key] = make_policy(spec, options)
    return _POLICIES[key]


def _drop_policy(spec: str, options: dict) -> None:
    policy = _POLICIES.pop(spec + "|" + json.dumps(options, sort_keys=True), None)
    if policy is not None:
        try:
            policy.close()
        except Exception:
            log.debug("policy close failed", exc_info=True)


def make_job(
    run_id: str,
    case: dict,
    trial: int,
    policy_spec: str,
    policy_options: dict,
    settings: EpisodeSettings,
    retries: int,
    retry_delay: float,
) -> dict:
    return {
        "run_id": run_id,
        "case": case,
        "trial": trial,
        "policy_spec": policy_spec,
        "policy_options": dict(policy_options),
        "settings": settings.to_json(),
        "retries": retries,
        "retry_delay": retry_delay,
        "prior_attempts": 0,
    }


def base_row(job: dict) -> dict:
    case = job["case"]
    normal = not case.get("setting")
    return {
        "run_id": job["run_id"],
        "case_id": case["id"],
        "trial": job["trial"],
        "seed": int(case["trial_seeds"][job["trial"]]),
        "policy_id": policy_label(job["policy_spec"], job["policy_options"]),
        "suite": case["suite"],
        "task": case["task"],
        "dimension": None if normal else case.get("dimension"),
        "category": "normal" if normal else case.get("category"),
        "setting": case.get("setting"),
        "indicator": None if normal else case.get("indicator"),
        "level": "normal" if normal else case.get("level"),
        "worker": f"{socket.gethostname()}:{os.getpid()}",
        "simulator": simulator_versions(),
        "code_version": provenance.code_version(),
    }


def execute_job(job: dict) -> dict:
    mjlog.route_warnings()  # a Ray worker starts here
    settings = EpisodeSettings(**job["settings"])
    row = base_row(job)
    attempts = job.get("prior_attempts", 0)
    budget = 1 + max(0, int(job["retries"]))
    last_error, kind = None, None
    for attempt in range(budget):
        attempts += 1
        try:
            policy = _policy(job["policy_spec"], job["policy_options"])
            result = run_episode(job["case"], job["trial"], policy, settings)
        except CaseUnavailableError as exc:
            row.update(status="unavailable", error=str(exc), error_kind=type(exc).__name__)
            break
        except InfrastructureError as exc:
            last_error, kind = str(exc), type(exc).__name__
            log.warning("%s trial %d attempt %d/%d: %s", row["case_id"], row["trial"], attempt + 1, budget, exc)
            _drop_policy(job["policy_spec"], job["policy_options"])
            if attempt + 1 < budget and job.get("retry_delay"):
                time.sleep(float(job["retry_delay"]) * (attempt + 1))
            continue
        except VProError as exc:  # a configuration problem: retrying will not help
            row.update(status="error", error=str(exc), error_kind=type(exc).__name__)
            break
        except Exception as exc:  # a bug or an unexpected failure: record it with its origin
            last_error = f"{type(exc).__name__}: {exc} | {traceback.format_exc(limit=3).strip().splitlines()[-3:]}"
            kind = "UnexpectedError"
            _drop_policy(job["policy_spec"], job["policy_options"])
            continue
        row.update(
            status="ok",
            success=bool(result["success"]),
            steps=result["steps"],
            phase_timeline=result["phase_timeline"],
            contact=result["contact"]["composition"],
            contact_detail=result["contact"],
            wall_time=result["wall_time"],
            artifact_hashes=result["artifact_hashes"],
            video=result["video"],
            final_state=result["final_state"],
            error=None,
            error_kind=None,
        )
        break
    else:
        row.update(status="error", error=f"{last_error} (after {budget} attempt(s))", error_kind=kind)
    row["attempts"] = attempts
    row["finished_at"] = utc_now()
    return row
