"""Does the 3D view's iframe hold up the operator page's main thread? An outer page embeds an iframe from
another origin (another port) whose script busy-loops 300 ms of every 400 ms (a slow WebGL frame, as
software-rendered viser draws them); the outer page's 10 ms timer measures how late it fires, with and
without the ``Origin-Agent-Cluster: ?1`` header on the outer page (``teleop/page.py`` sends it). Also prints
whether Chromium made the iframe an out-of-process target.

Run: ``.venv/bin/python benchmarks/iframe_isolation.py`` (Debian ``chromium`` and ``playwright``).
"""

from __future__ import annotations

import http.server
import shutil
import socket
import threading

from playwright.sync_api import sync_playwright

BUSY = ("<p>busy iframe</p><script>setInterval(() => { const end = Date.now() + 300; "
        "while (Date.now() < end); }, 400)</script>")
LATE = """() => new Promise((done) => {
  const late = []; let last = performance.now();
  const timer = setInterval(() => {
    const now = performance.now(); late.push(now - last - 10); last = now; }, 10);
  setTimeout(() => { clearInterval(timer); late.sort((a, b) => a - b);
    done([late[Math.floor(late.length / 2)], late[Math.floor(late.length * 0.95)], late[late.length - 1]]); },
    4000);
})"""


def _serve(body: str, oac: bool) -> tuple[http.server.ThreadingHTTPServer, int]:
    class Handler(http.server.BaseHTTPRequestHandler):
        def log_message(self, format: str, *args: object) -> None:
            return

        def do_GET(self) -> None:
            data = body.encode()
            self.send_response(200)
            self.send_header("Content-Type", "text/html")
            self.send_header("Content-Length", str(len(data)))
            if oac:
                self.send_header("Origin-Agent-Cluster", "?1")
            self.end_headers()
            self.wfile.write(data)

    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    server = http.server.ThreadingHTTPServer(("127.0.0.1", port), Handler)
    threading.Thread(target=server.serve_forever, daemon=True).start()
    return server, port


def main() -> None:
    chromium = shutil.which("chromium") or "/usr/bin/chromium"
    with sync_playwright() as pw:
        for oac in (False, True):
            inner, inner_port = _serve(BUSY, False)
            outer, outer_port = _serve(f"<iframe src='http://127.0.0.1:{inner_port}/'></iframe>", oac)
            browser = pw.chromium.launch(executable_path=chromium, headless=True,
                                         args=["--no-sandbox", "--disable-gpu"])
            page = browser.new_page()
            page.goto(f"http://127.0.0.1:{outer_port}/")
            page.wait_for_timeout(1000)
            targets = page.context.new_cdp_session(page).send("Target.getTargets")["targetInfos"]
            p50, p95, worst = page.evaluate(LATE)
            browser.close()
            outer.shutdown()
            inner.shutdown()
            oopif = any(t["type"] == "iframe" for t in targets)
            print(f"Origin-Agent-Cluster {'on ' if oac else 'off'}: iframe out of process: {oopif}; the "
                  f"outer page's 10 ms timer fired late by p50 {p50:.1f}  p95 {p95:.1f}  max {worst:.1f} ms")


if __name__ == "__main__":
    main()
