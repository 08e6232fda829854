"""The openpi adapter against a loopback server speaking openpi's protocol: what reaches the
server (keys, orientation, shapes, state, prompt), and every fault ending as a recorded error."""

from __future__ import annotations

import socket

import numpy as np
import pytest
from openpi_client import image_tools

from vpro_assets.benchmark.catalog import find_case, load_catalog
from vpro_assets.core import paths
from vpro_assets.rollout.episode import EpisodeSettings, run_episode
from vpro_assets.rollout.policies.base import (
    EpisodeInfo,
    Observation,
    PolicyConnectionError,
    PolicyOutputError,
    PolicyTimeoutError,
)
from vpro_assets.rollout.policies.openpi import OpenpiPolicy, build_request, quat2axisangle
from vpro_assets.rollout.policies.openpi_server import LoopbackPolicyServer

KEYS = {"observation/image", "observation/wrist_image", "observation/state", "prompt"}
FAST = EpisodeSettings(resolution=64, wait_steps=1, max_steps_override=6)


@pytest.fixture(scope="module")
def normal_case():
    return find_case(load_catalog(paths.catalog_path()), "libero_goal-03/normal")


def _obs(images) -> Observation:
    return Observation(
        images=images,
        eef_pos=np.array([0.1, 0.2, 0.3]),
        eef_quat=np.array([0.0, 0.0, 0.0, 1.0]),
        gripper_qpos=np.array([0.04, -0.04]),
        joint_pos=np.zeros(7),
        step=0,
    )


def test_request_rotates_180_pads_to_224_and_sends_8d_state():
    raw = np.zeros((128, 128, 3), np.uint8)
    raw[:16, :16] = (255, 0, 0)  # raw frame is bottom-up: this block is at the image's top-left in memory
    req = build_request(_obs({"agentview": raw, "robot0_eye_in_hand": None}), "do it")
    assert set(req) == KEYS
    img = req["observation/image"]
    assert img.shape == (224, 224, 3) and img.dtype == np.uint8
    # Rotated 180 degrees: the block ends at the bottom-right corner.
    assert img[-10:, -10:, 0].min() > 200 and img[:10, :10].max() == 0
    assert np.array_equal(req["observation/wrist_image"], np.zeros((224, 224, 3), np.uint8))  # unavailable view
    assert req["observation/state"].shape == (8,)
    assert np.allclose(req["observation/state"], [0.1, 0.2, 0.3, 0, 0, 0, 0.04, -0.04])
    assert np.allclose(quat2axisangle(np.array([0, 0, np.sin(0.5), np.cos(0.5)])), [0, 0, 1.0])


def test_adapter_drives_an_episode_and_server_sees_openpi_request(normal_case):
    seen_raw = []

    class Recording(OpenpiPolicy):
        def act(self, obs):
            seen_raw.append(obs.images["agentview"].copy())
            return super().act(obs)

    with LoopbackPolicyServer() as server:
        policy = Recording("127.0.0.1", server.port)
        result = run_episode(normal_case, 0, policy, FAST)
        policy.close()
    assert result["steps"] == 6
    # Replanning every 5 steps: 6 policy steps need 2 requests.
    assert len(server.requests) == 2 == len(seen_raw)
    for req, raw in zip(server.requests, seen_raw):
        assert set(req) == KEYS
        for key in ("observation/image", "observation/wrist_image"):
            assert req[key].shape == (224, 224, 3) and req[key].dtype == np.uint8
        assert req["observation/state"].shape == (8,)
        expected = image_tools.resize_with_pad(np.ascontiguousarray(raw[::-1, ::-1]), 224, 224)
        unflipped = image_tools.resize_with_pad(np.ascontiguousarray(raw), 224, 224)
        assert np.array_equal(req["observation/image"], expected)
        assert not np.array_equal(req["observation/image"], unflipped)
    # LIBERO's benchmark language (what openpi's example sends), not the BDDL's wording.
    assert server.requests[0]["prompt"] == normal_case.get("instruction", normal_case["language"])


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


@pytest.mark.parametrize(
    "fault,error,message",
    [
        ("refused", PolicyConnectionError, "cannot connect"),
        ("slow", PolicyTimeoutError, "no reply within 0.3 s"),
        ("nan", PolicyOutputError, "non-finite action value nan at chunk index 0, dimension 2"),
        ("shape", PolicyOutputError, "expected actions of shape (H, 7) with H >= 1, got shape (10, 6)"),
        ("error", PolicyOutputError, "error reply: Traceback"),
    ],
)
def test_adapter_turns_each_fault_into_a_clear_infrastructure_error(fault, error, message):
    server = None if fault == "refused" else LoopbackPolicyServer(fault=fault, fault_count=1, delay=1.0).start()
    policy = OpenpiPolicy(
        "127.0.0.1", _free_port() if server is None else server.port, infer_timeout=0.3, connect_timeout=2.0
    )
    obs = _obs({"agentview": np.zeros((64, 64, 3), np.uint8), "robot0_eye_in_hand": np.zeros((64, 64, 3), np.uint8)})
    try:
        with pytest.raises(error) as caught:
            policy.reset(EpisodeInfo("x", "c", 0, 0, "s", "t"))
            policy.act(obs)
        assert message in str(caught.value)
        if server is not None:  # the next request succeeds, on a new connection after a broken stream
            assert policy.act(obs).actions.shape == (10, 7)
            assert server.connections == (2 if fault in ("slow", "error") else 1)
    finally:
        policy.close()
        if server is not None:
            server.stop()


@pytest.mark.parametrize(
    "fault,kind,message",
    [
        ("refused", "PolicyConnectionError", "cannot connect"),
        ("nan", "PolicyOutputError", "non-finite action value"),
    ],
)
def test_faults_are_recorded_errors_retried_and_the_run_goes_on(eval_on_server, normal_case, fault, kind, message):
    server = None if fault == "refused" else LoopbackPolicyServer(fault=fault, fault_count=10**6).start()
    port = _free_port() if server is None else server.port
    try:
        rows = eval_on_server(
            normal_case,
            port,
            FAST,
            trials=2,
            retries=1,
            policy_options={"infer_timeout": 5.0, "connect_timeout": 2.0},
        )
    finally:
        if server is not None:
            server.stop()
    assert [(r["case_id"], r["trial"]) for r in rows] == [(normal_case["id"], t) for t in range(2)]
    for row in rows:  # both trials ran: the first failure did not stop the run
        assert row["status"] == "error" and row["success"] is None
        assert row["error_kind"] == kind and message in row["error"] and "after 2 attempt(s)" in row["error"]
        assert row["attempts"] == 2
    if server is not None:
        assert server.connections == 4  # a fresh connection for each attempt


def test_transient_fault_is_retried_into_a_result(eval_on_server, normal_case):
    with LoopbackPolicyServer(fault="nan", fault_count=1) as server:
        (row,) = eval_on_server(normal_case, server.port, FAST, retries=2)
    assert row["status"] == "ok" and row["attempts"] == 2 and row["success"] in (0, 1) and row["error"] is None


def test_validate_rejects_nan_with_position():
    from vpro_assets.rollout.policies.base import validate_actions

    bad = np.zeros((3, 7))
    bad[1, 4] = np.inf
    with pytest.raises(PolicyOutputError, match="chunk index 1, dimension 4"):
        validate_actions(bad)
