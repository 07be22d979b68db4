"""A client of openpi's websocket policy protocol (:mod:`mgdata.evaluate.server` describes it).

One :class:`PolicyClient` is one websocket connection; the evaluator opens one per rollout, so a reply that
arrives after a timeout dies with its connection and is never executed.

Example::

    check_url("ws://127.0.0.1:8000"); check_health("ws://127.0.0.1:8000", 5.0)
    with PolicyClient("ws://127.0.0.1:8000", timeout=10.0) as policy:
        chunk = decode_actions(policy.infer(request))
"""

from __future__ import annotations

import urllib.error
import urllib.parse
import urllib.request
from typing import Any

from websockets.exceptions import ConnectionClosed, InvalidHandshake, InvalidURI
from websockets.sync.client import ClientConnection, connect

from mgdata.errors import PolicyError
from mgdata.evaluate.wire import packb, unpackb


class PolicyTimeout(Exception):
    """The policy did not answer within the timeout (the rollout fails; not a user error)."""


def check_url(url: str) -> tuple[str, int]:
    """Host and port of a ``ws://HOST:PORT`` policy URL, or a :class:`PolicyError` saying what is wrong."""
    parts = urllib.parse.urlsplit(url)
    try:
        port = parts.port
    except ValueError:
        port = None
    if parts.scheme not in ("ws", "wss") or not parts.hostname or port is None:
        raise PolicyError(f"--policy {url!r}: expected ws://HOST:PORT (e.g. ws://127.0.0.1:8000)")
    return parts.hostname, port


def check_health(url: str, timeout: float) -> None:
    """``GET /healthz`` of the server behind ``url``; a :class:`PolicyError` if it does not answer 200."""
    host, port = check_url(url)
    scheme = "https" if url.startswith("wss") else "http"
    try:
        with urllib.request.urlopen(f"{scheme}://{host}:{port}/healthz", timeout=timeout) as reply:
            if reply.status != 200:
                raise PolicyError(f"policy server {url}: /healthz answered {reply.status}")
    except urllib.error.HTTPError as err:
        raise PolicyError(f"policy server {url}: /healthz answered {err.code} (is it an openpi-style "
                          "policy server?)") from None
    except (urllib.error.URLError, OSError) as err:
        reason = getattr(err, "reason", err)
        raise PolicyError(f"cannot reach the policy server at {url}: {reason}") from None


def _server_error(text: str) -> PolicyError:
    lines = [ln.strip() for ln in text.strip().splitlines() if ln.strip()]
    last = lines[-1].removeprefix("error: ") if lines else "no message"
    return PolicyError(f"the policy server failed: {last}")


class PolicyClient:
    """One connection to a policy server; :attr:`metadata` is the server's first frame."""

    def __init__(self, url: str, *, timeout: float, connect_timeout: float = 10.0) -> None:
        check_url(url)
        self.url, self.timeout = url, timeout
        try:
            self._ws: ClientConnection = connect(url, compression=None, max_size=None,
                                                 open_timeout=connect_timeout)
        except (OSError, InvalidHandshake, InvalidURI, TimeoutError) as err:
            raise PolicyError(f"cannot connect to the policy server at {url}: {err}") from None
        try:
            first = self._ws.recv(timeout=connect_timeout)
        except (TimeoutError, ConnectionClosed) as err:
            self.close()
            raise PolicyError(f"policy server {url} sent no metadata frame ({err})") from None
        if isinstance(first, str):
            self.close()
            raise _server_error(first)
        self.metadata: dict[str, Any] = unpackb(first)

    def infer(self, obs: dict[str, Any]) -> dict[str, Any]:
        """Send one observation and return the decoded reply.

        Raises:
            PolicyTimeout: no reply within ``timeout`` s (the connection is closed: no stale reply later).
            PolicyError: the server reported an error (text frame) or closed the connection.
        """
        try:
            self._ws.send(packb(obs))
            reply = self._ws.recv(timeout=self.timeout)
        except TimeoutError:
            self.close()
            raise PolicyTimeout(f"no reply from {self.url} within {self.timeout:g} s") from None
        except ConnectionClosed as err:
            raise PolicyError(f"the policy server at {self.url} closed the connection ({err})") from None
        if isinstance(reply, str):
            self.close()
            raise _server_error(reply)
        return unpackb(reply)

    def close(self) -> None:
        self._ws.close()

    def __enter__(self) -> PolicyClient:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
