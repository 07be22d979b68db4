"""Helpers of the annotator tests (a module of its own: test files import it, conftest holds fixtures)."""

from __future__ import annotations

import shutil
import socket
import time

import msgspec
import numpy as np
import pytest
import zstandard

START = "jar/hinged_03"
CAMERA = msgspec.msgpack.encode({
    "type": "ViewerCameraMessage", "wxyz": [1.0, 0.0, 0.0, 0.0], "position": [0.3, -0.3, 0.3], "fov": 1.0,
    "near": 0.01, "far": 100.0, "image_height": 800, "image_width": 1280, "look_at": [0.0, 0.0, 0.0],
    "up_direction": [0.0, 0.0, 1.0]})
"""The first message viser's browser client sends (a client counts as connected from then on)."""


def chromium_path() -> str:
    path = shutil.which("chromium") or shutil.which("chromium-browser")
    if path is None:
        pytest.fail("Debian's chromium is not installed: run scripts/setup.sh --dev "
                    "(apt-get install chromium)")
    return path


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def wait_for(predicate, timeout: float = 10.0, what: str = "condition"):
    """Poll ``predicate`` until it returns something truthy; fail after ``timeout`` seconds."""
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        value = predicate()
        if value:
            return value
        time.sleep(0.02)
    pytest.fail(f"timed out after {timeout} s waiting for {what}")


def project(app, point, size: tuple[int, int]) -> tuple[float, float]:
    """Pixel (x, y) of a world point in the connected browser's view, from the camera the client reports
    (position, look-at, up, vertical field of view); ``size`` is the page's viewport in pixels."""
    cam = next(iter(app.server.get_clients().values())).camera
    pos, look = np.asarray(cam.position, float), np.asarray(cam.look_at, float)
    forward = (look - pos) / np.linalg.norm(look - pos)
    right = np.cross(forward, np.asarray(cam.up_direction, float))
    right /= np.linalg.norm(right)
    up = np.cross(right, forward)
    d = np.asarray(point, float) - pos
    depth = float(d @ forward)
    half = np.tan(cam.fov / 2.0) * depth
    ndc_x, ndc_y = float(d @ right) / (half * size[0] / size[1]), float(d @ up) / half
    return (ndc_x + 1.0) / 2.0 * size[0], (1.0 - ndc_y) / 2.0 * size[1]


def viser_messages(raw: bytes) -> list[dict]:
    """The messages of one frame viser's server sends (zstd-compressed msgpack after two 8-byte sizes;
    binary buffers after it are left out)."""
    size, compressed = int.from_bytes(raw[:8], "little"), int.from_bytes(raw[8:16], "little")
    inner = zstandard.ZstdDecompressor().decompress(raw[16:16 + compressed], max_output_size=size)
    return msgspec.msgpack.decode(inner)["messages"]


def gui_update(uuid: str, value: object) -> bytes:
    """What the browser sends when the control ``uuid`` takes ``value`` (a button click: ``True``)."""
    return msgspec.msgpack.encode({"type": "GuiUpdateMessage", "uuid": uuid, "updates": {"value": value}})
