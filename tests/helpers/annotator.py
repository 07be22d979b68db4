"""Helpers of the annotator tests (a module of its own: test files import it, conftest holds fixtures)."""

from __future__ import annotations

import shutil
import socket
import time

import numpy as np
import pytest

START = "jar/hinged_03"


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
