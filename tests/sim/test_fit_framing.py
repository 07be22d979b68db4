"""``benchmarks/fit_framing.py``, the tool that writes a family's ``[cameras]`` table: the framing it returns
keeps every point inside the margin it was given (projected here with an independent pinhole), keeps each
camera's azimuth and the eyes' limits, and is tight (a camera moved closer loses a point) where no limit
holds it back."""

from __future__ import annotations

import os
import sys

import numpy as np

from mgdata.sim.cameras import THIRD_PERSON, CameraLayout
from tests.helpers.repo import REPO

_threads = os.environ.get("LP_NUM_THREADS")
sys.path.insert(0, str(REPO / "benchmarks"))
import fit_framing  # noqa: E402  (bench_framing pins llvmpipe to one thread for timing; not for the suite)

if _threads is None:
    os.environ.pop("LP_NUM_THREADS", None)

MARGIN, REACH, LOD = 0.92, 1.0, 1.0
SHOULDER = np.array([0.0, 0.0, fit_framing.SHOULDER_HEIGHT])


def _worst(eye: np.ndarray, target: np.ndarray, pts: np.ndarray, fovy: float) -> float:
    """Largest |normalised image coordinate| of ``pts`` (1 = the frame's edge), camera −Z towards target."""
    z = (eye - target) / np.linalg.norm(eye - target)  # camera +Z points back, away from the scene
    x = np.cross([0.0, 0.0, 1.0], z)
    x /= np.linalg.norm(x)
    y = np.cross(z, x)
    rel = pts - eye
    depth = -(rel @ z)
    assert (depth > 0).all()
    t = np.tan(np.radians(fovy) / 2)
    return float(max(np.abs(rel @ x / depth).max(), np.abs(rel @ y / depth).max()) / t)


def test_the_fitted_framing_holds_every_point_tightly_within_the_limits() -> None:
    rng = np.random.default_rng(7)
    pts = rng.uniform([0.3, -0.35, 0.0], [0.75, 0.35, 0.2], size=(300, 3))
    base = CameraLayout()
    out, _ = fit_framing.fit(pts, base, np.arange(20.0, 59.0, 2.0), np.radians(np.arange(20.0, 46.0, 2.5)),
                             MARGIN, REACH, LOD)
    target, fovy = np.array(out["look_at"]), float(out["fovy"])
    tight = 0
    for name in THIRD_PERSON:
        eye = np.array(out[name])
        assert _worst(eye, target, pts, fovy) <= MARGIN + 0.01, name  # eyes are rounded to the millimetre
        was = np.subtract(base.eye(name), base.look_at)
        now = eye - target
        assert abs(np.arctan2(now[1], now[0]) - np.arctan2(was[1], was[0])) < 0.01, name
        elevation = np.degrees(np.arctan2(now[2], np.hypot(now[0], now[1])))
        assert 20.0 - 0.1 <= elevation <= 45.0 + 0.1, (name, elevation)
        assert np.linalg.norm(eye - SHOULDER) >= REACH - 0.002 and np.linalg.norm(eye) >= LOD - 0.002, name
        held = min(np.linalg.norm(eye - SHOULDER) - REACH, np.linalg.norm(eye) - LOD) < 0.01
        closer = target + 0.97 * (eye - target)
        if not held:
            assert _worst(closer, target, pts, fovy) > MARGIN, f"{name}: not tight"
            tight += 1
    assert tight >= 2
