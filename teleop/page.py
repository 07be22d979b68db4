"""The operator's page: the live monitor pushed straight from Python, the session's buttons and hotkeys,
and viser's 3D view (with the camera images) beside it in an iframe.

The monitor does not travel through viser's scene stream: viser's client worker paces every batch to its
Python timestamp (up to 100 ms behind by design) and keeps batches in order behind the 3D updates, and its
page applies them between 3D frames. Here each monitor state is one server-sent event (``text/event-stream``)
written by the publisher straight to every open page's socket, and the page's own few lines of script put it
into the DOM. The page is served with ``Origin-Agent-Cluster: ?1``, so a browser may run it in a process
of its own, apart from the iframe's WebGL (Chromium does).

Routes: ``GET /`` the page; ``GET /events`` the monitor stream (the current state at once, then each new
one); ``POST /command/<name>`` a session command (needs the ``X-Mgdata`` header, which a cross-origin page
cannot send without a CORS preflight this server never grants).

Example::

    page = OperatorPage("127.0.0.1", 8080, scene_port=8081, on_command=session.command,
                        buttons=(("Record", "record", "r"),), title="gello · jar task 0")
    page.publish(b'{"step": 3, ...}')
"""

from __future__ import annotations

import contextlib
import http.server
import json
import socket
import threading
from collections.abc import Callable, Sequence
from importlib.resources import files

from mgdata.errors import OutputError

_HTML = files("mgdata.teleop") / "operator_page.html"
SEND_TIMEOUT_S = 0.5
"""A page whose socket does not take an event within this long (s) is dropped (it reconnects by itself)."""
MAX_BODY_BYTES = 4096
"""The largest request body read (a command's is empty); a larger one is refused with 413."""
REQUEST_TIMEOUT_S = 10.0
"""A client that has not sent its whole request within this long (s) is disconnected (the default of
``OperatorPage(request_timeout_s=…)``; a kept-alive connection that sends nothing more ends then too)."""


class _Client:
    """One open event stream: its socket and a lock so the publisher and the handler never interleave."""

    def __init__(self, sock: socket.socket) -> None:
        self.sock, self.lock = sock, threading.Lock()

    def send(self, payload: bytes) -> bool:
        with self.lock:
            return self.write(payload)

    def write(self, payload: bytes) -> bool:
        """Send one event (the caller holds ``lock``); False if the page is gone or stalled."""
        try:
            self.sock.sendall(b"data: " + payload + b"\n\n")
            return True
        except OSError:
            return False


class OperatorPage:
    """Serves the operator's page on ``host:port`` (see the module docstring).

    Attributes:
        url: where to point a browser; ``scene_port``: viser's port (the iframe's).
        clients: how many pages hold the event stream open now.
    """

    def __init__(self, host: str, port: int, scene_port: int, on_command: Callable[[str], None],
                 buttons: Sequence[tuple[str, str, str]], title: str,
                 request_timeout_s: float = REQUEST_TIMEOUT_S) -> None:
        self.url = f"http://{host}:{port}/"
        self.request_timeout_s = request_timeout_s
        self.scene_port = scene_port
        self._commands = {cmd for _label, cmd, _key in buttons}
        self._on_command = on_command
        config = json.dumps({"scenePort": scene_port, "title": title,
                             "buttons": [{"label": lab, "command": c, "key": k} for lab, c, k in buttons]})
        config = config.replace("<", "\\u003c")  # a title with "</script>" in it stays text
        self._html = _HTML.read_text(encoding="utf-8").replace("/*CONFIG*/null", config).encode()
        self._clients: list[_Client] = []
        self._lock = threading.Lock()
        self._last: bytes | None = None
        try:
            self._httpd = http.server.ThreadingHTTPServer((host, port), self._handler_class())
        except OSError as err:
            raise OutputError(f"cannot serve the operator page on {host}:{port}: {err.strerror}; choose "
                              "another --http-port") from err
        self._httpd.daemon_threads = True
        self._thread = threading.Thread(target=self._httpd.serve_forever, args=(0.1,), name="operator-page",
                                        daemon=True)
        self._thread.start()

    @property
    def clients(self) -> int:
        with self._lock:
            return len(self._clients)

    def publish(self, payload: bytes) -> None:
        """Send one monitor state (one line of JSON, no newline) to every open page, now."""
        with self._lock:
            self._last = payload
            clients = list(self._clients)
        dead = [c for c in clients if not c.send(payload)]
        if dead:
            with self._lock:
                self._clients = [c for c in self._clients if c not in dead]
            for c in dead:
                with contextlib.suppress(OSError):
                    c.sock.shutdown(socket.SHUT_RDWR)

    def close(self) -> None:
        self._httpd.shutdown()
        with self._lock:
            clients, self._clients = self._clients, []
        for c in clients:  # ends the handlers waiting on these streams
            with contextlib.suppress(OSError):
                c.sock.shutdown(socket.SHUT_RDWR)
        self._httpd.server_close()
        self._thread.join(timeout=5.0)

    # -- HTTP ----------------------------------------------------------------------------------------------
    def _handler_class(self) -> type[http.server.BaseHTTPRequestHandler]:
        page = self

        class Handler(http.server.BaseHTTPRequestHandler):
            protocol_version = "HTTP/1.1"
            timeout = page.request_timeout_s  # a slow or silent client ties up only its own thread, briefly
            # malformed requests (bad request line, unknown method) get one plain line, not an HTML page
            error_message_format = "error: %(code)d %(message)s\n"
            error_content_type = "text/plain; charset=utf-8"

            def log_message(self, format: str, *args: object) -> None:  # no access log on the terminal
                return

            def _reply(self, code: int, body: bytes, ctype: str = "text/plain; charset=utf-8") -> None:
                self.send_response(code)
                self.send_header("Content-Type", ctype)
                self.send_header("Content-Length", str(len(body)))
                self.send_header("Cache-Control", "no-store")
                if ctype.startswith("text/html"):
                    self.send_header("Origin-Agent-Cluster", "?1")
                self.end_headers()
                self.wfile.write(body)

            def do_GET(self) -> None:
                if self.path == "/":
                    self._reply(200, page._html, "text/html; charset=utf-8")
                elif self.path == "/events":
                    self._stream()
                else:
                    self._reply(404, b"error: not found\n")

            def do_POST(self) -> None:
                name = self.path.removeprefix("/command/")
                try:
                    length = int(self.headers.get("Content-Length") or 0)
                except ValueError:
                    length = -1
                if not 0 <= length <= MAX_BODY_BYTES:  # unread: the connection closes after the reply
                    self.close_connection = True
                    self._reply(413 if length > 0 else 400,
                                f"error: a command's body is at most {MAX_BODY_BYTES} bytes\n".encode())
                    return
                if length:
                    self.rfile.read(length)
                if not self.path.startswith("/command/") or name not in page._commands:
                    self._reply(404, b"error: unknown command\n")
                elif self.headers.get("X-Mgdata") != "1":
                    self._reply(403, b"error: missing X-Mgdata header\n")
                else:
                    page._on_command(name)
                    self._reply(204, b"")

            def _stream(self) -> None:
                self.send_response(200)
                self.send_header("Content-Type", "text/event-stream")
                self.send_header("Cache-Control", "no-store")
                self.end_headers()
                self.wfile.flush()
                self.connection.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
                self.connection.settimeout(SEND_TIMEOUT_S)
                client = _Client(self.connection)
                with client.lock:  # the current state first: a newer one published meanwhile waits for it
                    with page._lock:
                        last = page._last
                        page._clients.append(client)
                    if last is not None:
                        client.write(last)
                self.close_connection = True
                while True:  # the page sends nothing more: wait for it (or close()) to end the stream
                    try:
                        if not self.connection.recv(1024):
                            break
                    except TimeoutError:
                        continue
                    except OSError:
                        break
                with page._lock:
                    if client in page._clients:
                        page._clients.remove(client)

        return Handler
