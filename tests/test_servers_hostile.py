"""Every server binds 127.0.0.1 unless ``--host`` says otherwise, and the teleop operator page and the
annotator's viser server survive hostile clients (issue 26 §4; the policy server's own tests are in
tests/evaluate/test_server_hostile.py, the annotator's behind its message gate in
tests/annotator/test_annotator_hostile.py)."""

from __future__ import annotations

import inspect
import os
import socket
import time
import urllib.request

import pytest
import typer

from mgdata import cli
from mgdata.evaluate.server import PolicyServer


def host_defaults() -> dict[str, object]:
    """The default of every ``--host`` option of every command."""
    cli._register_all()
    found: dict[str, object] = {}

    def walk(cmd: object, path: str) -> None:
        for param in getattr(cmd, "params", []):
            if "--host" in getattr(param, "opts", ()):
                found[path] = param.default
        for name, sub in getattr(cmd, "commands", {}).items():
            walk(sub, f"{path} {name}".strip())

    walk(typer.main.get_command(cli.app), "")
    return found


def test_every_server_binds_loopback_by_default() -> None:
    from mgdata.annotator.app import Annotator
    from mgdata.teleop.view import OperatorView

    defaults = host_defaults()
    servers = {"serve hold", "serve random", "serve replay", "serve lerobot", "annotate", "teleop"}
    assert servers <= set(defaults), defaults
    assert set(defaults.values()) == {"127.0.0.1"}, defaults
    for cls in (PolicyServer, Annotator, OperatorView):
        assert inspect.signature(cls).parameters["host"].default == "127.0.0.1", cls


@pytest.fixture(params=[10.0])
def page(request: pytest.FixtureRequest):
    """An operator page; its request timeout (s) is the param (the shipped 10 s unless a test says)."""
    from mgdata.teleop.page import OperatorPage

    commands: list[str] = []
    page = OperatorPage("127.0.0.1", 0, 1, commands.append, (("Record", "record", "r"),), "t",
                        request_timeout_s=request.param)
    yield page, page._httpd.server_address[1], commands
    page.close()


def raw(port: int, data: bytes, timeout: float = 10.0) -> bytes:
    with socket.create_connection(("127.0.0.1", port), timeout=timeout) as s:
        s.sendall(data)
        chunks = []
        while True:
            try:
                chunk = s.recv(65536)
            except TimeoutError:
                break
            if not chunk:
                break
            chunks.append(chunk)
        return b"".join(chunks)


def status(reply: bytes) -> str:
    """The status code of a reply (an HTTP/0.9-style reply to a garbled request line is the body alone)."""
    return reply.split(b"\r\n", 1)[0].split()[1].decode()  # "HTTP/1.1 413 …" or "error: 400 …"


def body_line(reply: bytes) -> str:
    body = (reply.split(b"\r\n\r\n", 1)[1] if reply.startswith(b"HTTP/") else reply).decode()
    assert body.count("\n") == 1 and body.startswith("error: ") and "Traceback" not in body, body
    return body.strip()


def command_works(port: int) -> None:
    req = urllib.request.Request(f"http://127.0.0.1:{port}/command/record", method="POST",
                                 headers={"X-Mgdata": "1"})
    with urllib.request.urlopen(req, timeout=10) as reply:
        assert reply.status == 204


@pytest.mark.parametrize("page", [1.0], indirect=True)  # a kept-alive reply's connection ends 1 s later
def test_the_operator_page_answers_hostile_requests_with_one_line(page: tuple) -> None:
    _, port, commands = page
    cases = [
        (b"GARBAGE\r\n\r\n", "400"),
        (b"PUT /command/record HTTP/1.1\r\nHost: x\r\n\r\n", "501"),
        (b"POST /command/record HTTP/1.1\r\nX-Mgdata: 1\r\nContent-Length: 99999999999\r\n\r\n", "413"),
        (b"POST /command/record HTTP/1.1\r\nX-Mgdata: 1\r\nContent-Length: lots\r\n\r\n", "400"),
        (b"POST /command/launch HTTP/1.1\r\nX-Mgdata: 1\r\nContent-Length: 0\r\n\r\n", "404"),
        (b"POST /command/record HTTP/1.1\r\nContent-Length: 0\r\n\r\n", "403"),
        (b"GET /" + b"a" * 70000 + b" HTTP/1.1\r\n\r\n", "414"),
    ]
    for request, code in cases:
        t0 = time.monotonic()
        reply = raw(port, request)
        assert time.monotonic() - t0 < 5.0, request[:60]  # closed by the server (at most 1 s idle), not us
        assert status(reply) == code, reply[:200]
        body_line(reply)
    assert commands == []
    command_works(port)
    assert commands == ["record"]


def test_a_slow_client_does_not_stall_the_operator_page(page: tuple) -> None:
    _, port, commands = page
    slow = [socket.create_connection(("127.0.0.1", port), timeout=10) for _ in range(4)]
    slow[0].sendall(b"POST /command/record HTTP/1.1\r\nX-Mgdata: 1\r\n")  # never finishes its headers
    slow[1].sendall(b"POST /command/record HTTP/1.1\r\nX-Mgdata: 1\r\nContent-Length: 100\r\n\r\nab")
    try:
        t0 = time.monotonic()
        for _ in range(3):
            command_works(port)
        assert time.monotonic() - t0 < 5.0
        assert commands == ["record"] * 3
    finally:
        for s in slow:
            s.close()


def test_the_annotator_s_viser_server_survives_garbage() -> None:
    viser = pytest.importorskip("viser")
    from websockets.exceptions import WebSocketException
    from websockets.sync.client import connect

    server = viser.ViserServer(host="127.0.0.1", port=0, verbose=False)
    port = server.get_port()
    protocol = [f"viser-v{viser.__version__}"]  # the version check viser's own client passes
    try:
        for junk in (os.urandom(256), b"\x00" * 4096, "not json"):
            try:
                with connect(f"ws://127.0.0.1:{port}", open_timeout=20, subprotocols=protocol) as ws:
                    ws.send(junk)
                    time.sleep(0.2)
            except (OSError, WebSocketException):  # the server may close on us: what matters is what follows
                pass
        with urllib.request.urlopen(f"http://127.0.0.1:{port}/", timeout=20) as reply:
            assert reply.status == 200
        with connect(f"ws://127.0.0.1:{port}", open_timeout=20, subprotocols=protocol) as ws:
            assert ws.recv(timeout=20)  # a fresh client is served its first messages
    finally:
        server.stop()
