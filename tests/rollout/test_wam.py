"""World-action models over the wire: openpi's protocol with the opt-in extension of
`vpro_assets.rollout.policies.wam` (episode reset, predicted frames), against a loopback
stateful, frame-predicting server; a plain openpi server sees nothing new."""

from __future__ import annotations

import numpy as np
import pytest
from openpi_client import image_tools

from vpro_assets.benchmark.catalog import find_case, load_catalog
from vpro_assets.core import paths
from vpro_assets.rollout.episode import EpisodeSettings, run_episode
from vpro_assets.rollout.policies.base import EpisodeInfo, Observation, PolicyOutputError
from vpro_assets.rollout.policies.openpi import OpenpiPolicy
from vpro_assets.rollout.policies.openpi_server import EchoWorldModel, LoopbackPolicyServer
from vpro_assets.rollout.policies.wam import decode_predicted_frames

PRD = "libero_spatial-00/prediction_reality_divergence/recursive_self_prediction-v1"
KEYS = {"observation/image", "observation/wrist_image", "observation/state", "prompt"}
CAMS = ("agentview", "robot0_eye_in_hand")
RES = 64
# 11 policy steps, 5 executed per request: requests at policy steps 0, 5 and 10.
FAST = EpisodeSettings(resolution=RES, wait_steps=1, max_steps_override=11)


@pytest.fixture(scope="module")
def catalog():
    return load_catalog(paths.catalog_path())


def _obs(size=RES) -> Observation:
    rng = np.random.default_rng(0)
    images = {cam: rng.integers(0, 256, (size, size, 3), dtype=np.uint8) for cam in CAMS}
    return Observation(
        images=images,
        eef_pos=np.zeros(3),
        eef_quat=np.array([0, 0, 0, 1.0]),
        gripper_qpos=np.zeros(2),
        joint_pos=np.zeros(7),
        step=0,
    )


def _decode(frames, orientation="raw", shapes=None):
    reply = {"actions": np.zeros((5, 7)), "predicted_frames": frames, "predicted_frames_orientation": orientation}
    return decode_predicted_frames(reply, shapes or dict.fromkeys(CAMS, (RES, RES, 3)), 224, "server x")


def test_frames_come_back_in_raw_orientation_whatever_orientation_they_were_sent_in():
    raw = _obs().images
    sent = {
        "raw": raw,
        "rot180": {c: f[::-1, ::-1] for c, f in raw.items()},
        "flipud": {c: f[::-1] for c, f in raw.items()},
    }
    for orientation, frames in sent.items():
        out = _decode(frames, orientation)
        assert all(np.array_equal(out[c], raw[c]) and out[c].flags.c_contiguous for c in CAMS), orientation
    # A chunk of K frames keeps its K; each frame is mapped.
    chunk = {c: np.stack([f, f[::-1, ::-1]]) for c, f in raw.items()}
    out = _decode(chunk, "rot180")
    assert out["agentview"].shape == (2, RES, RES, 3) and np.array_equal(out["agentview"][1], raw["agentview"])


def test_frames_in_the_request_size_are_mapped_back_to_the_camera_size():
    # The loopback model's frame, as the server sends it, in each orientation: the same raw frame.
    upright = EchoWorldModel.frame(3, 224)
    decoded = [
        _decode(dict.fromkeys(CAMS, f), o)["agentview"]
        for o, f in (("rot180", upright), ("raw", upright[::-1, ::-1]), ("flipud", upright[:, ::-1]))
    ]
    assert all(np.array_equal(d, decoded[0]) for d in decoded)
    frame = decoded[0]
    assert frame.shape == (RES, RES, 3) and frame.dtype == np.uint8
    mark = EchoWorldModel.MARK * RES // 224
    # Upright top-left corner = raw bottom-right corner; the rest keeps the predicted value 30.
    assert frame[-mark + 1 :, -mark + 1 :].min() == 255
    assert np.all(frame[: RES - mark - 2] == 30) and np.all(frame[:, : RES - mark - 2] == 30)
    # Padding added by resize_with_pad for a non-square camera is cropped before resizing back.
    wide = np.zeros((32, 64, 3), np.uint8)
    wide[:, :, 0] = 200
    padded = image_tools.resize_with_pad(wide, 224, 224)
    assert padded[:50].max() == 0  # openpi pads top and bottom
    out = decode_predicted_frames({"predicted_frames": {"agentview": padded}}, {"agentview": (32, 64, 3)}, 224, "s")
    assert out["agentview"].shape == (32, 64, 3) and np.all(out["agentview"][:, :, 0] == 200)


@pytest.mark.parametrize(
    "reply,message",
    [
        ({"actions": np.zeros((5, 7))}, "reply has no 'predicted_frames' although the server declares predicts_frames"),
        (
            {"predicted_frames": np.zeros((RES, RES, 3), np.uint8)},
            "must map camera names to uint8 arrays, got a ndarray",
        ),
        (
            {"predicted_frames": {"agentview": np.zeros((RES, RES, 3), np.uint8)}},
            "no predicted frame for camera robot0_eye_in_hand",
        ),
        (
            {"predicted_frames": {c: np.zeros((RES, RES, 3), np.uint8) for c in CAMS + ("frontview",)}},
            "predicted frame for unknown camera 'frontview'",
        ),
        (
            {"predicted_frames": {c: np.zeros((RES, RES, 3), np.float32) for c in CAMS}},
            "predicted frame for agentview has dtype float32; expected uint8",
        ),
        (
            {"predicted_frames": {c: np.zeros((RES, RES - 1, 3), np.uint8) for c in CAMS}},
            "predicted frame for agentview has shape (64, 63, 3); expected (h, w, 3) or (K, h, w, 3)",
        ),
        ({"predicted_frames": {c: np.zeros((0, RES, RES, 3), np.uint8) for c in CAMS}}, "has shape (0, 64, 64, 3)"),
        (
            {
                "predicted_frames": {c: np.zeros((RES, RES, 3), np.uint8) for c in CAMS},
                "predicted_frames_orientation": "up",
            },
            "predicted_frames_orientation 'up' is not one of raw, rot180, flipud",
        ),
    ],
)
def test_each_bad_reply_is_an_error_naming_the_problem(reply, message):
    with pytest.raises(PolicyOutputError) as caught:
        decode_predicted_frames(reply, dict.fromkeys(CAMS, (RES, RES, 3)), 224, "policy server ws://h:1")
    assert str(caught.value).startswith("policy server ws://h:1: ") and message in str(caught.value)


def test_a_plain_openpi_server_gets_no_reset_and_its_frames_are_ignored():
    def infer(obs):  # a server that happens to send a key of that name without declaring predictions
        return {"actions": np.zeros((5, 7)), "predicted_frames": "not frames"}

    with LoopbackPolicyServer(infer) as server:
        policy = OpenpiPolicy("127.0.0.1", server.port)
        assert policy.predicts_frames is False
        policy.reset(EpisodeInfo("pick it", "c", 0, 0, "s", "t"))
        out = policy.act(_obs())
        policy.close()
    assert out.predicted_frames is None
    assert len(server.requests) == 1 and set(server.requests[0]) == KEYS


def test_bad_metadata_flag_is_a_clear_error():
    with LoopbackPolicyServer(metadata={"predicts_frames": "yes"}) as server:
        policy = OpenpiPolicy("127.0.0.1", server.port, connect_timeout=2.0)
        with pytest.raises(PolicyOutputError, match="metadata key 'predicts_frames' must be true or false, got 'yes'"):
            policy.reset(EpisodeInfo("x", "c", 0, 0, "s", "t"))


class Recording(OpenpiPolicy):
    """Keeps the raw views each request was built from."""

    def __init__(self, *args, **kwargs):
        super().__init__(*args, **kwargs)
        self.seen = []

    def act(self, obs):
        self.seen.append({cam: img.copy() for cam, img in obs.images.items()})
        return super().act(obs)


def test_prediction_reality_divergence_runs_against_a_stateful_world_model_server(catalog):
    case = find_case(catalog, PRD)
    model = EchoWorldModel()
    with LoopbackPolicyServer(model, metadata=model.metadata) as server:
        policy = Recording("127.0.0.1", server.port)
        assert policy.predicts_frames
        first = run_episode(case, 0, policy, FAST)
        seen_first = policy.seen
        policy.seen = []
        second = run_episode(case, 1, policy, FAST)
        policy.close()
    assert first["steps"] == second["steps"] == 11
    # Each episode starts with a reset message carrying the instruction and the episode's identity.
    resets = [r for r in server.requests if r.get("reset")]
    assert len(resets) == 2 and len(server.requests) == 2 + 2 * 3
    assert server.requests[0]["reset"] is True and server.requests[4]["reset"] is True
    assert [r["prompt"] for r in resets] == [case.get("instruction", case["language"])] * 2
    assert [(r["episode"]["case_id"], r["episode"]["trial"]) for r in resets] == [(PRD, 0), (PRD, 1)]
    assert [r["episode"]["seed"] for r in resets] == case["trial_seeds"][:2]
    assert all(set(r) == KEYS for r in server.requests if not r.get("reset"))
    # Ground truth at the first request, then the model's own predictions, mapped back to raw.
    expected = {n: _decode({c: EchoWorldModel.frame(n, 224) for c in CAMS}, "rot180") for n in (1, 2)}
    for seen in (seen_first, policy.seen):  # per-episode state: the second episode counts from 1 again
        assert len(seen) == 3
        assert seen[0]["agentview"].std() > 10  # a rendered scene
        for cam in CAMS:
            assert np.array_equal(seen[1][cam], expected[1][cam])
            assert np.array_equal(seen[2][cam], expected[2][cam])
    # The server receives its own prediction back as the next observation (value 10, then 20).
    obs_requests = [r for r in server.requests if not r.get("reset")]
    centre = slice(100, 200)
    assert np.all(obs_requests[1]["observation/image"][centre, centre] == 10)
    assert np.all(obs_requests[2]["observation/wrist_image"][centre, centre] == 20)
    assert model.episodes[1]["episode"]["trial"] == 1 and len(model.history) == 3


@pytest.mark.parametrize(
    "fault,message",
    [
        ("missing_frames", "reply has no 'predicted_frames' although the server declares predicts_frames"),
        ("frame_shape", "predicted frame for agentview has shape (223, 224, 3)"),
        ("frame_dtype", "predicted frame for agentview has dtype float32; expected uint8"),
    ],
)
def test_bad_replies_are_recorded_errors_naming_the_problem(eval_on_server, catalog, fault, message):
    case = find_case(catalog, PRD)
    model = EchoWorldModel(fault=fault, fault_count=10**6)
    with LoopbackPolicyServer(model, metadata=model.metadata) as server:
        (row,) = eval_on_server(case, server.port, FAST)
    assert row["status"] == "error" and row["success"] is None and row["error_kind"] == "PolicyOutputError"
    assert message in row["error"] and "after 1 attempt(s)" in row["error"]


def test_a_transient_bad_reply_is_retried_into_a_result(eval_on_server, catalog):
    case = find_case(catalog, PRD)
    model = EchoWorldModel(fault="frame_dtype", fault_count=1)
    with LoopbackPolicyServer(model, metadata=model.metadata) as server:
        (row,) = eval_on_server(case, server.port, FAST, retries=1)
    assert row["status"] == "ok" and row["attempts"] == 2 and row["steps"] == 11
    assert len(model.episodes) == 2  # the retry started its episode with a fresh reset


def test_prediction_case_with_a_plain_openpi_server_is_unavailable(eval_on_server, catalog):
    case = find_case(catalog, PRD)
    with LoopbackPolicyServer() as server:
        (row,) = eval_on_server(case, server.port, FAST)
    assert row["status"] == "unavailable" and "does not predict frames" in row["error"]
    assert server.requests == []  # metadata read, nothing sent
