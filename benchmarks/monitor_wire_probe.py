"""A second client of the operator page's monitor stream that timestamps the wire (used by
``bench_teleop.py --wire``): it reads ``GET /events`` and prints ``step time.time()`` for every monitor state
as it comes off the socket, until the server closes.

Run: ``.venv/bin/python benchmarks/monitor_wire_probe.py http://127.0.0.1:8765/``
"""

from __future__ import annotations

import http.client
import json
import sys
import time
from urllib.parse import urlsplit


def main() -> None:
    url = urlsplit(sys.argv[1])
    conn = http.client.HTTPConnection(url.hostname, url.port)
    conn.request("GET", "/events")
    stream = conn.getresponse()
    try:
        for line in stream:
            t = time.time()
            if line.startswith(b"data: "):
                print(json.loads(line[6:])["step"], f"{t:.6f}", flush=True)
    except OSError:  # the server stopped
        return


if __name__ == "__main__":
    main()
