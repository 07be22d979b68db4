"""CameraRig: headless RGB observations from the scene's cameras with one reused ``mujoco.Renderer``.

CPU rendering (EGL or OSMesa on llvmpipe) is fast only with shadows, reflections and MSAA off and decimated
visual meshes (the scene builder does both); ``mgdata`` sets ``MUJOCO_GL=egl`` before MuJoCo is imported.
Always close the rig (or use it as a context manager): an unclosed renderer errors at interpreter exit.

Example::

    with CameraRig(scene) as rig:
        images = rig.render()          # {"front": (256, 256, 3) uint8, ...}
"""

from __future__ import annotations

import contextlib
import os
from collections.abc import Mapping, Sequence
from types import TracebackType

import mujoco
import numpy as np

from mgdata.errors import SceneError
from mgdata.sim.cameras import CAMERA_NAMES
from mgdata.sim.scene import Scene


def _check_gl_backend() -> None:
    """Fail clearly when MuJoCo was imported before ``mgdata`` chose a headless GL backend."""
    from mujoco.rendering.classic import gl_context

    chosen = getattr(gl_context, "_MUJOCO_GL", None)
    if chosen in ("", "glfw") and not os.environ.get("DISPLAY"):
        raise SceneError(
            "MuJoCo was imported before a headless GL backend was chosen, and there is no display: "
            "import mgdata before mujoco, or set MUJOCO_GL=egl (or osmesa) in the environment"
        )


def contact_sheet(images: Mapping[str, np.ndarray], *, labels: bool = True) -> np.ndarray:
    """The images side by side (in the mapping's order), each captioned with its camera name."""
    import cv2

    tiles = []
    for name, img in images.items():
        tile = np.array(img, dtype=np.uint8, copy=True, order="C")
        if labels:
            cv2.putText(tile, name, (6, 18), cv2.FONT_HERSHEY_SIMPLEX, 0.5, (0, 0, 0), 3, cv2.LINE_AA)
            cv2.putText(tile, name, (6, 18), cv2.FONT_HERSHEY_SIMPLEX, 0.5, (255, 255, 255), 1, cv2.LINE_AA)
        tiles.append(tile)
    return np.concatenate(tiles, axis=1)


class CameraRig:
    """Renders ``cameras`` of ``scene`` at ``size``×``size`` (default: the task's ``image_size``).

    Attributes:
        cameras: the camera names, in render order.
        size: image side in pixels.
    """

    def __init__(self, scene: Scene, cameras: Sequence[str] = CAMERA_NAMES, size: int | None = None) -> None:
        self.scene = scene
        self.cameras = tuple(cameras)
        self.size = int(size or scene.task.image_size)
        model = scene.model
        unknown = [c for c in self.cameras if mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_CAMERA, c) < 0]
        if unknown or not self.cameras:
            raise SceneError(
                f"unknown camera(s) {unknown or '(none given)'}; cameras: {', '.join(CAMERA_NAMES)}"
            )
        if self.size > min(model.vis.global_.offwidth, model.vis.global_.offheight) or self.size < 8:
            raise SceneError(f"image size {self.size} outside 8…{model.vis.global_.offheight} for this scene")
        self._ids = [model.camera(c).id for c in self.cameras]
        _check_gl_backend()
        self._renderer: mujoco.Renderer | None = mujoco.Renderer(model, self.size, self.size)
        flags = self._renderer.scene.flags
        flags[mujoco.mjtRndFlag.mjRND_SHADOW] = False
        flags[mujoco.mjtRndFlag.mjRND_REFLECTION] = False

    def render(self) -> dict[str, np.ndarray]:
        """One RGB image (size, size, 3) uint8 per camera, of the scene's current ``data``."""
        if self._renderer is None:
            raise SceneError("CameraRig.render() called after close()")
        out: dict[str, np.ndarray] = {}
        for name, cam in zip(self.cameras, self._ids, strict=True):
            self._renderer.update_scene(self.scene.data, camera=cam)
            out[name] = self._renderer.render().copy()
        return out

    def close(self) -> None:
        """Free the GL context (idempotent)."""
        if self._renderer is not None:
            self._renderer.close()
            self._renderer = None

    def __enter__(self) -> CameraRig:
        return self

    def __exit__(self, exc_type: type[BaseException] | None, exc: BaseException | None,
                 tb: TracebackType | None) -> None:
        self.close()

    def __del__(self) -> None:
        with contextlib.suppress(Exception):  # interpreter shutdown: GL may already be gone
            self.close()
