"""openpi's wire format and websocket protocol, against a real server process (`mgdata serve hold`)."""

from __future__ import annotations

import json
import urllib.request

import msgpack
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp
from websockets.sync.client import connect

from mgdata.errors import PolicyError
from mgdata.evaluate.client import PolicyClient
from mgdata.evaluate.wire import packb, unpackb
from tests.helpers.evaluate import serve_process

DTYPES = st.sampled_from(["<f4", "<f8", "|u1", "<i8", "<i4", "|b1", "<f2"])


@given(hnp.arrays(DTYPES, hnp.array_shapes(min_dims=0, max_dims=4, max_side=5)))
@settings(max_examples=60, deadline=None)
def test_arrays_travel_as_openpi_tagged_maps(arr: np.ndarray) -> None:
    blob = packb({"a": arr, "s": arr.dtype.type(0), "text": "close the jar", "n": [1, 2.5]})
    raw = msgpack.unpackb(blob)  # what any msgpack reader sees: openpi's msgpack_numpy layout
    tagged = raw["a"]
    assert tagged[b"__ndarray__"] is True and tagged[b"dtype"] == arr.dtype.str
    assert tuple(tagged[b"shape"]) == arr.shape and tagged[b"data"] == arr.tobytes()
    back = unpackb(blob)
    assert back["a"].dtype == arr.dtype and back["a"].shape == arr.shape
    assert back["a"].tobytes() == arr.tobytes()  # bit for bit, NaNs included
    assert back["text"] == "close the jar" and back["n"] == [1, 2.5]
    if arr.dtype == np.float64:  # np.float64 is a Python float: msgpack packs it natively (as openpi's does)
        assert raw["s"] == 0.0 and back["s"] == 0.0
    else:
        assert raw["s"][b"__npgeneric__"] is True and raw["s"][b"dtype"] == arr.dtype.str
        assert type(back["s"]) is arr.dtype.type


def test_object_and_complex_arrays_are_refused() -> None:
    for bad in (np.array([1 + 2j]), np.array([object()], dtype=object)):
        with pytest.raises(ValueError, match="unsupported dtype"):
            packb({"x": bad})


def test_a_served_policy_speaks_the_protocol() -> None:
    proc, url = serve_process("hold")
    try:
        host_port = url.removeprefix("ws://")
        with urllib.request.urlopen(f"http://{host_port}/healthz", timeout=10) as reply:
            assert reply.status == 200 and reply.read() == b"OK\n"
        command = np.array([0.1, -0.5, 0.0, -2.0, 0.0, 1.6, 0.7, 1.0], np.float32)
        with PolicyClient(url, timeout=10) as client:
            assert client.metadata["policy"] == "hold" and client.metadata["chunk"] == 16
            reply = client.infer({"observation/state": np.zeros(8, np.float32), "mgdata/command": command,
                                  "prompt": "x", "episode_seed": 7})
            assert reply["actions"].shape == (16, 8) and reply["actions"].dtype == np.float32
            assert (reply["actions"] == command).all() and "infer_ms" in reply["server_timing"]
        # a policy error arrives as a one-line text frame and the connection is closed
        with connect(url, compression=None, max_size=None) as ws:
            assert unpackb(ws.recv(timeout=10))["policy"] == "hold"
            ws.send(packb({"prompt": "no command"}))
            text = ws.recv(timeout=10)
            assert isinstance(text, str) and text.startswith("error: ") and "mgdata/command" in text
            assert "\n" not in text and "Traceback" not in text
        with PolicyClient(url, timeout=10) as client, pytest.raises(PolicyError) as err:
            client.infer({"prompt": "no command"})
        message = str(err.value)
        assert message.startswith("the policy server failed:") and "'mgdata/command'" in message
        assert "\n" not in message and json.dumps(message)
    finally:
        proc.terminate()
        proc.wait(timeout=30)
    assert proc.returncode == 0


def test_observation_keys_follow_each_convention() -> None:
    from mgdata.evaluate.conventions import Observation, decode_actions, encode

    img = {c: np.full((4, 4, 3), i, np.uint8) for i, c in enumerate(("front", "left", "wrist"))}
    state = np.arange(8, dtype=np.float32)
    obs = Observation(img, state, state + 1, "close the jar", 42, 7, "jar/task_0000/base")
    extra = {"episode_seed", "mgdata/step", "mgdata/scenario", "mgdata/command"}
    pi0 = encode("pi0", ("front", "wrist"), obs)
    assert set(pi0) == {"observation/image", "observation/wrist_image", "observation/state", "prompt"} | extra
    assert (pi0["observation/wrist_image"] == 2).all() and pi0["episode_seed"] == 42
    smol = encode("smolvla", ("left", "wrist"), obs)
    assert (smol["observation.images.top"] == 1).all() and smol["task"] == "close the jar"
    groot = encode("groot", ("front", "left", "wrist"), obs)
    assert groot["video.left"].shape == (1, 4, 4, 3) and groot["state.gripper"].tolist() == [[7.0]]
    assert groot["annotation.human.task_description"] == ["close the jar"]
    split = decode_actions({"action.single_arm": np.zeros((5, 7)), "action.gripper": np.ones((5, 1))})
    assert split.shape == (5, 8) and split.dtype == np.float32 and (split[:, 7] == 1).all()
    assert decode_actions({"actions": np.arange(8.0)}).shape == (1, 8)
    for bad in ({"actions": np.zeros((3, 7))}, {"action": np.zeros((3, 8))}, [1, 2]):
        with pytest.raises(PolicyError):
            decode_actions(bad)
    from mgdata.errors import RecipeError
    from mgdata.evaluate.conventions import check_cameras, default_cameras

    cams = ["front", "left", "wrist"]
    assert default_cameras("pi0", cams) == ("front", "wrist")
    check_cameras("groot", ("front", "left", "wrist"), cams)
    for convention, chosen, message in (("pi0", ("front", "left"), "an overview and then 'wrist'"),
                                        ("smolvla", ("top", "wrist"), "'top' is not a scenario camera"),
                                        ("octo", ("front", "wrist"), "--convention 'octo'")):
        with pytest.raises(RecipeError, match=message):
            check_cameras(convention, chosen, cams)
