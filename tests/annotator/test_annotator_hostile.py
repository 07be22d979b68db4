"""``mgdata annotate`` under hostile clients (issue 26 §4), against a real ``mgdata annotate`` process on
loopback with websockets clients speaking viser's protocol: malformed, oversized, wrong-typed and
out-of-order messages get one ``error:`` text frame (no traceback) and a close (1008; 1009 when too big),
the server goes on serving the clients it has and new ones, slow clients stall nobody, and nothing a browser
sends makes the server write anything but the grasp DB's category file and its export."""

from __future__ import annotations

import base64
import os
import random
import socket
import struct
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path
from typing import NamedTuple

import msgspec
import pytest
import viser
from websockets.exceptions import ConnectionClosed
from websockets.sync.client import ClientConnection, connect

from mgdata.viser_gate import MAX_MESSAGE_BYTES, MAX_TEXT_CHARS
from tests.helpers.annotator import CAMERA, START, free_port, gui_update, viser_messages, wait_for

MGDATA = str(Path(sys.executable).parent / "mgdata")
PROTOCOL = f"viser-v{viser.__version__}"
LABELS = {"depth (m)", "approach", "search", "jump to", "save grasp (Enter)", "export .npz"}
encode = msgspec.msgpack.encode


class Session(NamedTuple):
    proc: subprocess.Popen
    port: int
    root: Path  # the process's working folder is root/cwd, its grasp DB root/grasps
    controls: dict[str, str]  # label -> uuid


def client(port: int) -> ClientConnection:
    return connect(f"ws://127.0.0.1:{port}", subprotocols=[PROTOCOL], open_timeout=30, max_size=None,
                   compression=None)


def updates(ws: ClientConnection, seconds: float) -> Iterator[dict]:
    """The messages the server sends ``ws`` for ``seconds``."""
    end = time.monotonic() + seconds
    while (left := end - time.monotonic()) > 0:
        try:
            raw = ws.recv(timeout=left)
        except TimeoutError:
            return
        assert isinstance(raw, bytes), raw
        yield from viser_messages(raw)


@pytest.fixture(scope="module")
def session(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Session]:
    root = tmp_path_factory.mktemp("hostile")
    (root / "cwd").mkdir()
    stderr = (root / "stderr.txt").open("w")
    proc = subprocess.Popen([MGDATA, "annotate", "--family", "jar", "--category", "jar", "--object", START,
                             "--port", str(free_port()), "--dir", str(root / "grasps")],
                            cwd=root / "cwd", stdout=subprocess.PIPE, stderr=stderr, text=True,
                            env={**os.environ, "LP_NUM_THREADS": "1"})
    assert proc.stdout is not None
    for line in proc.stdout:
        if line.startswith("annotating "):
            port = int(line.split("http://127.0.0.1:")[1].split("/")[0])
            break
    else:
        pytest.fail(f"mgdata annotate did not start: {(root / 'stderr.txt').read_text()}")
    controls: dict[str, str] = {}
    with client(port) as ws:
        ws.send(CAMERA)
        for m in updates(ws, 60.0):
            label = (m.get("props") or {}).get("label")
            if m["type"].startswith("Gui") and label in LABELS:
                controls[label] = m["uuid"]
            if set(controls) == LABELS:
                break
    assert set(controls) == LABELS, controls
    yield Session(proc, port, root, controls)
    proc.terminate()
    try:
        proc.wait(timeout=30)
    except subprocess.TimeoutExpired:
        proc.kill()
        pytest.fail("mgdata annotate did not stop within 30 s of SIGTERM")
    finally:
        stderr.close()
    text = (root / "stderr.txt").read_text()
    assert "Traceback" not in text and "Share URL" not in text, text  # bad messages are not its failures


def bad_messages(c: dict[str, str]) -> dict[str, tuple[bytes | str, str, int]]:
    """name -> (message, a fragment of the error line, close code)."""
    click = {"type": "SceneNodeClickMessage", "name": "/object/part_0", "instance_index": None,
             "ray_origin": [0.0, 0.0, 0.5], "ray_direction": [0.0, 0.0, -1.0], "screen_pos": [0.5, 0.5],
             "modifier": None}
    gizmo = {"type": "TransformControlsUpdateMessage", "name": "/gizmo", "wxyz": [1.0, 0.0, 0.0, 0.0],
             "position": [0.0, 0.0, 0.1]}
    return {
        "random bytes": (random.Random(26).randbytes(64), "not msgpack", 1008),
        "a text frame": ("hello", "a text frame", 1008),
        "a msgpack list": (encode([1, 2, 3]), "got list", 1008),
        "a map without a type": (encode({"uuid": c["search"]}), "'type'", 1008),
        "an unknown type": (encode({"type": "LaunchMissiles"}), "not a message a browser sends", 1008),
        "a server's message": (encode({"type": "GuiRemoveMessage", "uuid": c["search"]}),
                               "not a message a browser sends", 1008),
        "a share link": (encode({"type": "ShareUrlRequest"}), "sharing is off", 1008),
        "a file upload": (encode({"type": "FileTransferStartUpload", "source_component_uuid": c["search"],
                                  "transfer_uuid": "t", "filename": "../../evil.json", "mime_type": "x",
                                  "part_count": 1, "size_bytes": 4}), "no file uploads", 1008),
        "a wrong-typed field": (encode({"type": "GuiUpdateMessage", "uuid": 5, "updates": {"value": 1}}),
                                "Expected `str`, got `int`", 1008),
        "a missing field": (encode({"type": "GuiUpdateMessage", "uuid": c["search"]}),
                            "missing required field `updates`", 1008),
        "a wrong-typed value": (gui_update(c["depth (m)"], "deep"), "expected a float, got str", 1008),
        "a NaN": (gui_update(c["depth (m)"], float("nan")), "not a finite number", 1008),
        "a value out of range": (gui_update(c["depth (m)"], 5.0), "outside", 1008),
        "not an option": (gui_update(c["approach"], "from below"), "not one of its options", 1008),
        "a path for a model": (gui_update(c["jump to"], "../../../etc/passwd"), "not one of its options",
                               1008),
        "too much text": (gui_update(c["search"], "x" * (MAX_TEXT_CHARS + 1)), "characters", 1008),
        "another property": (encode({"type": "GuiUpdateMessage", "uuid": c["jump to"],
                                     "updates": {"options": ["../x"]}}), "only 'value'", 1008),
        "an unknown control": (gui_update("no-such-control", True), "no control", 1008),
        "a click with a NaN ray": (encode({**click, "ray_origin": [0.0, float("nan"), 0.5]}),
                                   "not a finite number", 1008),
        "a zero quaternion": (encode({**gizmo, "wxyz": [0.0, 0.0, 0.0, 0.0]}), "not a unit quaternion",
                              1008),
        "an oversized message": (b"\x00" * (MAX_MESSAGE_BYTES + 1), f"the limit is {MAX_MESSAGE_BYTES}",
                                 1009),
    }


NAMES = sorted(bad_messages({label: "u" for label in LABELS}))


def refused(ws: ClientConnection, fragment: str, code: int) -> None:
    """``ws`` gets one ``error:`` text frame containing ``fragment``, then a close with ``code``."""
    while isinstance(reply := ws.recv(timeout=30), bytes):  # the session's state may come first
        pass
    assert reply.startswith("error: ") and fragment in reply, reply
    assert "\n" not in reply and "Traceback" not in reply, reply
    with pytest.raises(ConnectionClosed) as closed:
        while True:
            ws.recv(timeout=30)
    assert closed.value.rcvd is not None and closed.value.rcvd.code == code, closed.value


def serves_a_new_client(port: int) -> None:
    with client(port) as ws:
        ws.send(CAMERA)
        assert isinstance(ws.recv(timeout=30), bytes)


@pytest.mark.parametrize("name", NAMES)
def test_a_bad_message_gets_one_error_line_and_the_annotator_serves_on(name: str, session: Session) -> None:
    message, fragment, code = bad_messages(session.controls)[name]
    with client(session.port) as ws:
        ws.send(CAMERA)
        ws.send(message)
        refused(ws, fragment, code)
    serves_a_new_client(session.port)


def test_an_event_before_the_camera_is_out_of_order(session: Session) -> None:
    with client(session.port) as ws:  # viser counts a client from its first camera message on
        ws.send(gui_update(session.controls["depth (m)"], 0.05))
        refused(ws, "before the client's first camera message", 1008)
    serves_a_new_client(session.port)


def test_a_click_on_a_node_that_is_gone_is_ignored(session: Session) -> None:
    click = encode({"type": "SceneNodeClickMessage", "name": "/object/part_99", "instance_index": None,
                    "ray_origin": [0.0, 0.0, 0.5], "ray_direction": [0.0, 0.0, -1.0],
                    "screen_pos": [0.5, 0.5], "modifier": None})  # a click on the previous object
    with client(session.port) as ws:
        ws.send(CAMERA)
        ws.send(click)
        ws.send(gui_update(session.controls["depth (m)"], 0.03))
        assert any(m["type"] == "GuiUpdateMessage" and "live check" in str(m["updates"])
                   for m in updates(ws, 15.0))


def test_a_client_keeps_being_served_while_another_is_refused(session: Session) -> None:
    with client(session.port) as good:
        good.send(CAMERA)
        list(updates(good, 2.0))
        with client(session.port) as bad:
            bad.send(CAMERA)
            bad.send(b"\xc1" * 100)
            refused(bad, "not msgpack", 1008)
        good.send(gui_update(session.controls["depth (m)"], 0.04))
        assert any(m["type"] == "GuiUpdateMessage" and "live check" in str(m["updates"])
                   for m in updates(good, 15.0))


def stalled_client(port: int) -> socket.socket:
    """A websocket client that sends its camera and then never reads (a 4 kB receive buffer)."""
    s = socket.socket()
    s.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 4096)
    s.connect(("127.0.0.1", port))
    key = base64.b64encode(os.urandom(16)).decode()
    s.sendall(f"GET / HTTP/1.1\r\nHost: 127.0.0.1:{port}\r\nUpgrade: websocket\r\nConnection: Upgrade\r\n"
              f"Sec-WebSocket-Key: {key}\r\nSec-WebSocket-Version: 13\r\n"
              f"Sec-WebSocket-Protocol: {PROTOCOL}\r\n\r\n".encode())
    mask = os.urandom(4)
    payload = bytes(b ^ mask[i % 4] for i, b in enumerate(CAMERA))
    s.sendall(struct.pack("!BB", 0x82, 0x80 | len(payload)) + mask + payload)  # one masked binary frame
    return s


def test_slow_clients_do_not_stall_the_others(session: Session) -> None:
    stalled = [stalled_client(session.port) for _ in range(3)]
    try:
        with client(session.port) as ws:
            ws.send(CAMERA)
            list(updates(ws, 2.0))
            for depth in (0.01, 0.06):
                t0 = time.monotonic()
                ws.send(gui_update(session.controls["depth (m)"], depth))
                assert any(m["type"] == "GuiUpdateMessage" and "live check" in str(m["updates"])
                           for m in updates(ws, 15.0))
                assert time.monotonic() - t0 < 15.0
    finally:
        for s in stalled:
            s.close()


def http_status(port: int, path: str) -> str:
    with socket.create_connection(("127.0.0.1", port), timeout=30) as s:
        s.sendall(f"GET {path} HTTP/1.1\r\nHost: x\r\nConnection: close\r\n\r\n".encode())
        return s.recv(64).split(b"\r\n", 1)[0].decode()


def test_the_only_files_a_browser_can_make_the_annotator_write(session: Session) -> None:
    for path in ("/../../../../etc/passwd", "/%2e%2e/%2e%2e/etc/passwd", "/..%5c..%5cetc%5cpasswd"):
        assert " 404 " in http_status(session.port, path), path
    c = session.controls
    with client(session.port) as ws:
        ws.send(CAMERA)
        for label, value in (("search", "../../../../tmp/evil"), ("search", "/etc/passwd"),
                             ("approach", "side from +X"), ("save grasp (Enter)", True),
                             ("export .npz", True)):
            ws.send(gui_update(c[label], value))
            list(updates(ws, 1.0))
        wait_for(lambda: (session.root / "grasps" / "export" / "jar.npz").exists(), 30.0, "the export")
    written = {p.relative_to(session.root).as_posix() for p in session.root.rglob("*") if p.is_file()}
    assert written == {"grasps/jar.json", "grasps/export/jar.npz", "stderr.txt"}, written


def listening_addresses(port: int) -> set[str]:
    """The local addresses of the sockets listening on ``port`` (Linux's /proc/net/tcp and tcp6)."""
    found = set()
    for table in ("/proc/net/tcp", "/proc/net/tcp6"):
        for row in Path(table).read_text().splitlines()[1:]:
            local, state = row.split()[1], row.split()[3]
            address, hex_port = local.split(":")
            if state == "0A" and int(hex_port, 16) == port:  # 0A: LISTEN
                found.add(socket.inet_ntop(socket.AF_INET, bytes.fromhex(address)[::-1]) if len(address) == 8
                          else address)
    return found


@pytest.mark.skipif(not Path("/proc/net/tcp").exists(), reason="reads Linux's socket table")
def test_the_annotator_listens_on_loopback_only(session: Session) -> None:
    assert listening_addresses(session.port) == {"127.0.0.1"}
