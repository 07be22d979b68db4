"""The operator page's server over real HTTP: the page, the monitor event stream, the command endpoint."""

from __future__ import annotations

import http.client
import json
import socket

import pytest

from mgdata.errors import OutputError
from mgdata.teleop.page import OperatorPage

BUTTONS = (("Record", "record", "r"), ("Quit", "quit", "q"))


def _port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


@pytest.fixture
def page() -> tuple[OperatorPage, list[str]]:
    got: list[str] = []
    served = OperatorPage("127.0.0.1", _port(), 9999, got.append, BUTTONS, "gello · jar task 0")
    yield served, got  # type: ignore[misc]
    served.close()


def _conn(page: OperatorPage) -> http.client.HTTPConnection:
    host, port = page.url.removeprefix("http://").rstrip("/").split(":")
    return http.client.HTTPConnection(host, int(port), timeout=10)


def _events(stream: http.client.HTTPResponse, n: int) -> list[dict]:
    out = []
    while len(out) < n:
        line = stream.readline()
        assert line, "the stream ended early"
        if line.startswith(b"data: "):
            out.append(json.loads(line[6:]))
    return out


def test_page_is_served_origin_keyed_with_its_scene_port(page: tuple[OperatorPage, list[str]]) -> None:
    conn = _conn(page[0])
    conn.request("GET", "/")
    r = conn.getresponse()
    body = r.read().decode()
    assert r.status == 200 and r.getheader("Origin-Agent-Cluster") == "?1"
    assert '"scenePort": 9999' in body and '"command": "record"' in body and "/*CONFIG*/" not in body
    conn.request("GET", "/nothing")
    assert conn.getresponse().status == 404


def test_stream_starts_with_the_current_state_then_follows(page: tuple[OperatorPage, list[str]]) -> None:
    served, _ = page
    served.publish(b'{"step":1}')
    conn = _conn(served)
    conn.request("GET", "/events")
    stream = conn.getresponse()
    assert stream.getheader("Content-Type") == "text/event-stream"
    assert _events(stream, 1) == [{"step": 1}]
    assert served.clients == 1  # registered before its first event was written
    for k in range(2, 40):
        served.publish(json.dumps({"step": k}).encode())
    assert [e["step"] for e in _events(stream, 38)] == list(range(2, 40))
    served.close()  # ends the open stream
    assert stream.read().strip() == b""


def test_commands_need_the_header_and_a_known_name(page: tuple[OperatorPage, list[str]]) -> None:
    served, got = page
    conn = _conn(served)
    conn.request("POST", "/command/record", headers={"X-Mgdata": "1"})
    r = conn.getresponse()
    assert r.status == 204 and r.read() == b""
    conn.request("POST", "/command/record")  # what a cross-origin form could send
    r = conn.getresponse()
    assert r.status == 403 and b"X-Mgdata" in r.read()
    conn.request("POST", "/command/format_disk", headers={"X-Mgdata": "1"})
    r = conn.getresponse()
    r.read()
    assert r.status == 404
    assert got == ["record"]


def test_the_title_stays_text() -> None:
    page = OperatorPage("127.0.0.1", _port(), 9999, print, BUTTONS, "</script><script>alert(1)</script>")
    try:
        conn = _conn(page)
        conn.request("GET", "/")
        body = conn.getresponse().read().decode()
    finally:
        page.close()
    assert "alert(1)" in body and "</script><script>alert" not in body


def test_a_busy_port_is_one_clear_error(page: tuple[OperatorPage, list[str]]) -> None:
    port = int(page[0].url.rstrip("/").rsplit(":", 1)[1])
    with pytest.raises(OutputError, match=f"127.0.0.1:{port}.*--http-port"):
        OperatorPage("127.0.0.1", port, 9999, print, BUTTONS, "t")
