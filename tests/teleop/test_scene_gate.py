"""The teleop operator's 3D scene (a viser server) is behind mgdata's message gate, like the annotator's: a
hostile frame gets one ``error:`` line and a 1008 close, no traceback, and the scene goes on serving."""

from __future__ import annotations

import os
from pathlib import Path

from websockets.exceptions import ConnectionClosed
from websockets.sync.client import connect

from mgdata.teleop.gello import GelloCalibration
from tests.teleop.browser import served_session


def test_the_scene_refuses_garbage_and_serves_on(gello_cal: GelloCalibration, tmp_path: Path) -> None:
    import viser

    protocol = [f"viser-v{viser.__version__}"]  # the version check viser's own client passes
    with served_session(gello_cal, tmp_path) as served:
        url = f"ws://127.0.0.1:{served.view.server.get_port()}"
        for junk in (os.urandom(256), b"\x81\xa4type\xafShareUrlRequest", "not msgpack"):
            with connect(url, open_timeout=20, subprotocols=protocol) as ws:
                ws.send(junk)
                lines = []
                try:
                    while True:  # viser's first messages, then the gate's one line and the close
                        frame = ws.recv(timeout=20)
                        if isinstance(frame, str):
                            lines.append(frame)
                except ConnectionClosed as closed:
                    assert closed.rcvd is not None and closed.rcvd.code == 1008
                assert len(lines) == 1 and lines[0].startswith("error: "), lines
                assert "Traceback" not in lines[0]
        with connect(url, open_timeout=20, subprotocols=protocol) as ws:
            assert isinstance(ws.recv(timeout=20), bytes)  # a fresh client is served the scene
        assert not served.errors
