"""A policy server speaking openpi's websocket protocol (``openpi.serving.websocket_policy_server``).

* ``GET /healthz`` answers ``200 OK`` (the health check openpi's server has).
* On connect the server sends one binary frame: the policy's metadata (msgpack, :mod:`mgdata.evaluate.wire`).
* Then, per query, the client sends an observation (binary frame) and the server replies with the action
  dict (binary frame), to which it adds ``server_timing`` (``infer_ms``) as openpi does.
* A request that is not an observation (not msgpack, a text frame, not a map) or that the policy refuses
  (a missing or wrong-typed key) is answered with one **text** frame, one line ``error: <what was wrong>``
  (never a traceback: that goes to the server's stderr when the policy itself failed), and the connection
  is closed (1008 policy violation for a bad request, 1011 internal error for a failing policy); a client
  surfaces that line as the error. A message over :data:`MAX_MESSAGE_BYTES` is refused by the websocket
  layer, which closes with 1009 (message too big) and says so in the close reason. Every connection has
  its own thread, so a slow or hostile client stalls only itself.

Example::

    server = PolicyServer(HoldPolicy(16), port=0)
    print(server.url)          # ws://127.0.0.1:<port>
    server.serve_forever()
"""

from __future__ import annotations

import contextlib
import http
import sys
import time
import traceback
from typing import Any, Protocol

from websockets.exceptions import ConnectionClosed
from websockets.frames import CloseCode
from websockets.http11 import Request, Response
from websockets.sync.server import Server, ServerConnection, serve

from mgdata.errors import MgdataError
from mgdata.evaluate.wire import packb, unpackb

MAX_MESSAGE_BYTES = 64 * 1024 * 1024
"""The largest request the server reads (64 MiB: five 256² cameras are ~1 MiB, ten 512² ~8 MiB)."""


class BadRequest(MgdataError):
    """A client sent something that is not an observation."""


def observation(message: bytes | str) -> dict[str, Any]:
    """The observation in one client message, or :class:`BadRequest` saying what it is instead."""
    if isinstance(message, str):
        raise BadRequest("expected a binary msgpack observation, got a text frame")
    try:
        obs = unpackb(message)
    except Exception as err:  # msgpack's and numpy's many decoding errors
        raise BadRequest(f"the request is not msgpack-numpy ({type(err).__name__}: {err})") from None
    if not isinstance(obs, dict):
        raise BadRequest(f"an observation is a msgpack map, got {type(obs).__name__}")
    return obs


REQUEST_ERRORS = (MgdataError, ValueError, TypeError, KeyError, IndexError)
"""What a policy raises on a request with a missing or wrong-typed value (a bad request, not a failure)."""


def error_line(err: BaseException) -> str:
    """``error: <message>`` on one line (a user error's message; otherwise its type, then its message)."""
    text = str(err) if isinstance(err, MgdataError) else f"{type(err).__name__}: {err}"
    if not isinstance(err, REQUEST_ERRORS):
        text = f"the policy failed: {text}"
    return "error: " + " ".join(text.split())[:2000]


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
        self._server: Server = serve(self._handle, host, port, compression=None, max_size=MAX_MESSAGE_BYTES,
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
        try:
            ws.send(packb(self.policy.metadata))
        except ConnectionClosed:
            return
        while True:
            try:
                message = ws.recv()
            except ConnectionClosed:
                return
            try:
                obs = observation(message)
                start = time.perf_counter()
                action = dict(self.policy.infer(obs))
                action["server_timing"] = {"infer_ms": 1000.0 * (time.perf_counter() - start)}
                ws.send(packb(action))
            except ConnectionClosed:
                return
            except Exception as err:  # openpi's protocol: the error goes to the client as a text frame (the
                # client prints it as one error line and stops the run), then the connection closes
                bad_request = isinstance(err, REQUEST_ERRORS)
                if not bad_request:  # the policy itself failed: its traceback is for the operator
                    traceback.print_exc(file=sys.stderr)
                with contextlib.suppress(ConnectionClosed):  # a client already gone needs no reply
                    ws.send(error_line(err))
                    ws.close(code=CloseCode.POLICY_VIOLATION if bad_request else CloseCode.INTERNAL_ERROR,
                             reason="bad request" if bad_request else "internal server error")
                return
