"""A policy server speaking openpi's websocket protocol (``openpi.serving.websocket_policy_server``).

* ``GET /healthz`` answers ``200 OK`` (the health check openpi's server has).
* On connect the server sends one binary frame: the policy's metadata (msgpack, :mod:`mgdata.evaluate.wire`).
* Then, per query, the client sends an observation (binary frame) and the server replies with the action
  dict (binary frame), to which it adds ``server_timing`` (``infer_ms``) as openpi does.
* If the policy raises, the server sends the traceback as a **text** frame and closes the connection with
  code 1011 (internal error); a client surfaces that text as the error.

Example::

    server = PolicyServer(HoldPolicy(16), port=0)
    print(server.url)          # ws://127.0.0.1:<port>
    server.serve_forever()
"""

from __future__ import annotations

import http
import sys
import time
import traceback
from typing import Any, Protocol

from websockets.exceptions import ConnectionClosed
from websockets.frames import CloseCode
from websockets.http11 import Request, Response
from websockets.sync.server import Server, ServerConnection, serve

from mgdata.evaluate.wire import packb, unpackb


class Policy(Protocol):
    """What a server serves: ``metadata`` (sent on connect) and ``infer(observation) -> {"actions": …}``."""

    @property
    def metadata(self) -> dict[str, Any]: ...

    def infer(self, obs: dict[str, Any]) -> dict[str, Any]: ...


def _health(connection: ServerConnection, request: Request) -> Response | None:
    if request.path == "/healthz":
        return connection.respond(http.HTTPStatus.OK, "OK\n")
    return None


class PolicyServer:
    """Serves ``policy`` on ``host:port`` (``port`` 0: any free port; see :attr:`url`)."""

    def __init__(self, policy: Policy, host: str = "127.0.0.1", port: int = 8000) -> None:
        self.policy = policy
        self._server: Server = serve(self._handle, host, port, compression=None, max_size=None,
                                     process_request=_health)
        self.host, self.port = self._server.socket.getsockname()[:2]

    @property
    def url(self) -> str:
        return f"ws://{self.host}:{self.port}"

    def serve_forever(self) -> None:
        self._server.serve_forever()

    def shutdown(self) -> None:
        self._server.shutdown()

    def _handle(self, ws: ServerConnection) -> None:
        ws.send(packb(self.policy.metadata))
        while True:
            try:
                obs = unpackb(ws.recv())
            except ConnectionClosed:
                return
            try:
                start = time.perf_counter()
                action = dict(self.policy.infer(obs))
                action["server_timing"] = {"infer_ms": 1000.0 * (time.perf_counter() - start)}
                ws.send(packb(action))
            except ConnectionClosed:
                return
            except Exception:  # openpi's protocol: any policy error goes to the client as a text frame
                # (the client prints it as one error line and stops the run), then the connection closes
                traceback.print_exc(file=sys.stderr)
                ws.send(traceback.format_exc())
                ws.close(code=CloseCode.INTERNAL_ERROR,
                         reason="Internal server error. Traceback included in previous frame.")
                return
