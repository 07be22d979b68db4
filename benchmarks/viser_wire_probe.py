"""A second viser client that timestamps the wire (used by ``bench_teleop.py --wire``): it connects to the
operator view's websocket, decodes each batch (viser's header, zstd-compressed msgpack) and prints
``step time.time()`` for every monitor state it carries, until the server closes.

Run: ``.venv/bin/python benchmarks/viser_wire_probe.py ws://127.0.0.1:8765``
"""

from __future__ import annotations

import re
import sys
import time

import viser
import zstandard
from websockets.sync.client import connect

STEP = re.compile(rb"data-step='(\d+)'")


def main() -> None:
    dctx = zstandard.ZstdDecompressor()
    with connect(sys.argv[1], subprotocols=[f"viser-v{viser.__version__}"], max_size=None,  # type: ignore[list-item]
                 compression=None) as ws:
        try:
            for frame in ws:
                t = time.time()
                if not isinstance(frame, bytes) or len(frame) < 16:
                    continue
                inner = int.from_bytes(frame[:8], "little")
                size = int.from_bytes(frame[8:16], "little")
                payload = dctx.decompress(frame[16:16 + size], max_output_size=inner)
                for m in STEP.finditer(payload):
                    print(int(m.group(1)), f"{t:.6f}", flush=True)
        except Exception:  # the server stopped
            return


if __name__ == "__main__":
    main()
