"""``mgdata serve`` under hostile clients (issue 26 §4), against a real ``mgdata serve random`` process on
loopback: malformed, text, wrong-typed and out-of-order requests get one ``error:`` line (no traceback)
and the server goes on serving others; an oversized one is refused by the websocket layer (1009); 32
concurrent clients for a bounded time all get the right replies; a slow client stalls nobody else."""

from __future__ import annotations

import os
import socket
import threading
import time

import msgpack
import numpy as np
import pytest
from websockets.exceptions import ConnectionClosed
from websockets.sync.client import connect

from mgdata.evaluate.config import load_eval_config
from mgdata.evaluate.policies import RandomPolicy
from mgdata.evaluate.server import MAX_MESSAGE_BYTES
from mgdata.evaluate.wire import packb, unpackb
from tests.helpers.evaluate import serve_process

COMMAND = np.array([0.1, -0.5, 0.0, -2.0, 0.0, 1.6, 0.7, 1.0], np.float32)


def request(seed: int, step: int) -> dict:
    return {"mgdata/command": COMMAND, "episode_seed": seed, "mgdata/step": step, "prompt": "x"}


@pytest.fixture(scope="module")
def server() -> tuple[str, RandomPolicy]:
    proc, url = serve_process("random", "--seed", "5")
    yield url, RandomPolicy(5, load_eval_config().random)
    proc.terminate()
    proc.wait(timeout=30)
    assert proc.returncode == 0
    stderr = proc.stderr.read() if proc.stderr else ""
    assert "Traceback" not in stderr, stderr  # bad requests are not the server's failures


def good_reply_ok(url: str, policy: RandomPolicy, seed: int = 1, step: int = 3) -> None:
    with connect(url, compression=None, max_size=None, open_timeout=20) as ws:
        assert unpackb(ws.recv(timeout=20))["policy"] == "random"
        ws.send(packb(request(seed, step)))
        reply = unpackb(ws.recv(timeout=20))
        assert np.array_equal(reply["actions"], policy.infer(request(seed, step))["actions"])


BAD = {
    "random bytes": (os.urandom(64), "not msgpack-numpy"),
    "a text frame": ("hello", "got a text frame"),
    "a msgpack list": (msgpack.packb([1, 2, 3]), "msgpack map, got list"),
    "no command": (packb({"prompt": "x"}), "'mgdata/command'"),
    "a wrong-typed command": (packb({**request(1, 0), "mgdata/command": "eight floats"}), "ValueError"),
    "a wrong-shaped command": (packb({**request(1, 0), "mgdata/command": np.zeros(3, np.float32)}),
                               "shape (8,)"),
    "a wrong-typed seed": (packb({**request(1, 0), "episode_seed": "seven"}), "ValueError"),
    "a bad ndarray": (msgpack.packb({b"__ndarray__": True, b"data": b"xx", b"dtype": "<f4", b"shape": [9]}),
                      "not msgpack-numpy"),
}


@pytest.mark.parametrize("name", sorted(BAD))
def test_a_bad_request_gets_one_error_line_and_the_server_serves_on(name: str, server: tuple) -> None:
    url, policy = server
    message, fragment = BAD[name]
    with connect(url, compression=None, max_size=None, open_timeout=20) as ws:
        unpackb(ws.recv(timeout=20))  # the metadata
        ws.send(message)
        text = ws.recv(timeout=20)
        assert isinstance(text, str) and text.startswith("error: ") and fragment in text, text
        assert "\n" not in text and "Traceback" not in text
        with pytest.raises(ConnectionClosed) as closed:
            ws.recv(timeout=20)
        assert closed.value.rcvd is not None and closed.value.rcvd.code == 1008
    good_reply_ok(url, policy)


def test_out_of_order_a_request_before_reading_the_metadata_and_two_at_once(server: tuple) -> None:
    url, policy = server
    with connect(url, compression=None, max_size=None, open_timeout=20) as ws:
        ws.send(packb(request(2, 0)))  # before reading the metadata frame
        ws.send(packb(request(2, 1)))  # and a second before the first reply
        assert unpackb(ws.recv(timeout=20))["policy"] == "random"
        for step in (0, 1):
            reply = unpackb(ws.recv(timeout=20))
            assert np.array_equal(reply["actions"], policy.infer(request(2, step))["actions"])


def test_an_oversized_request_is_refused(server: tuple) -> None:
    url, policy = server
    with connect(url, compression=None, max_size=None, open_timeout=20) as ws:
        unpackb(ws.recv(timeout=20))
        ws.send(b"\0" * (MAX_MESSAGE_BYTES + 1))
        with pytest.raises(ConnectionClosed) as closed:
            ws.recv(timeout=60)
        assert closed.value.rcvd is not None and closed.value.rcvd.code == 1009
    good_reply_ok(url, policy)


def test_32_concurrent_clients_all_get_the_right_replies(server: tuple) -> None:
    url, policy = server
    deadline = time.monotonic() + 8.0  # a bounded time, and a bounded number of requests per client
    counts, errors = [0] * 32, []

    def client(k: int) -> None:
        try:
            with connect(url, compression=None, max_size=None, open_timeout=60) as ws:
                unpackb(ws.recv(timeout=60))
                for step in range(200):
                    if time.monotonic() > deadline and step >= 2:
                        break
                    ws.send(packb(request(100 + k, step)))
                    reply = unpackb(ws.recv(timeout=60))
                    if not np.array_equal(reply["actions"], policy.infer(request(100 + k, step))["actions"]):
                        errors.append(f"client {k} step {step}: wrong actions")
                        return
                    counts[k] += 1
        except Exception as err:  # reported below
            errors.append(f"client {k}: {err!r}")

    threads = [threading.Thread(target=client, args=(k,)) for k in range(32)]
    for t in threads:
        t.start()
    for t in threads:
        t.join(timeout=180)
    assert not errors, errors[:5]
    assert all(c >= 2 for c in counts), counts


def test_a_slow_client_stalls_nobody_else(server: tuple) -> None:
    url, policy = server
    host, port = url.removeprefix("ws://").split(":")
    stalled = []
    try:
        # one that opens TCP and never finishes the handshake, one that sends half a frame and stops
        half_open = socket.create_connection((host, int(port)), timeout=10)
        stalled.append(half_open)
        half_frame = connect(url, compression=None, max_size=None, open_timeout=20)
        unpackb(half_frame.recv(timeout=20))
        half_frame.socket.sendall(b"\x82\x7e\x10\x00" + os.urandom(4) + b"\0" * 100)  # 4096 promised
        # and one that sends requests but never reads the replies
        deaf = connect(url, compression=None, max_size=None, open_timeout=20)
        for step in range(50):
            deaf.send(packb(request(9, step)))
        t0 = time.monotonic()
        for k in range(5):
            good_reply_ok(url, policy, seed=k)
        assert time.monotonic() - t0 < 30
        half_frame.close()
        deaf.close()
    finally:
        for s in stalled:
            s.close()
