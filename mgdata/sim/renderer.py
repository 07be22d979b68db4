"""CameraRig: headless RGB observations from the scene's cameras with one GL context and MuJoCo's classic
renderer.

CPU rendering (EGL or OSMesa on llvmpipe) is fast only with shadows, reflections and MSAA off and decimated
visual meshes (the scene builder does both); ``mgdata`` sets ``MUJOCO_GL=egl`` before MuJoCo is imported.
The rig builds its GL context from a private copy of the model with coarser tessellation of planes, spheres,
cylinders, boxes and the skybox (:class:`~mgdata.sim.render_config.RenderConfig`) and an offscreen buffer the
size of its images; fixed cameras far from the robot draw its far level of detail. docs/render.md measures
what each costs. Always close the rig (or use it as a context manager): an unclosed GL context errors at
interpreter exit.

Example::

    with CameraRig(scene) as rig:
        images = rig.render()          # {"front": (256, 256, 3) uint8, ...}
"""

from __future__ import annotations

import copy
import os
from collections.abc import Mapping, Sequence
from types import TracebackType
from typing import Any

import mujoco
import numpy as np

from mgdata.errors import SceneError
from mgdata.sim import robot
from mgdata.sim.appearance_draw import AppearanceDraw
from mgdata.sim.cameras import CAMERA_NAMES
from mgdata.sim.render_config import RenderConfig
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


MAX_SIZE = 4096
"""Largest image side the rig renders (pixels)."""


def context_model(model: mujoco.MjModel, size: int, config: RenderConfig) -> mujoco.MjModel:
    """A copy of ``model`` to build a GL context from: ``config``'s tessellation, a ``size``² offscreen
    buffer.

    Only what ``mjr_makeContext`` reads differs (plane grid spacing, ``vis.quality``, buffer size), so scenes
    updated from ``model`` render with it.
    """
    ctx = copy.copy(model)
    ctx.vis.global_.offwidth = ctx.vis.global_.offheight = size
    ctx.vis.quality.offsamples = 0
    ctx.vis.quality.numslices = config.numslices
    ctx.vis.quality.numstacks = config.numstacks
    ctx.vis.quality.numquads = config.numquads
    planes = ctx.geom_type == mujoco.mjtGeom.mjGEOM_PLANE
    ctx.geom_size[planes, 2] = config.plane_grid
    return ctx


def camera_option(model: mujoco.MjModel, camera: int, config: RenderConfig) -> mujoco.MjvOption:
    """The visualisation options for ``camera``: MuJoCo's defaults, with the robot's far level of detail
    (``robot.FAR_LOD_GROUP`` instead of ``robot.NEAR_LOD_GROUP``) for a fixed camera at least
    ``config.far_lod_distance`` from the robot base, if the model has that level (a model built without it
    keeps the near level everywhere)."""
    option = mujoco.MjvOption()
    has_far = bool((model.geom_group == robot.FAR_LOD_GROUP).any())
    if config.far_lod > 0 and has_far and model.cam_bodyid[camera] == 0:
        base = model.body(robot.ROOT_BODY).pos  # the base is welded to the world
        if np.linalg.norm(model.cam_pos[camera] - base) >= config.far_lod_distance:
            option.geomgroup[robot.NEAR_LOD_GROUP] = 0
            option.geomgroup[robot.FAR_LOD_GROUP] = 1
    return option


_ORPHANS: list[tuple[Any, Any]] = []
"""(GL context, MjrContext) of rigs garbage-collected without :meth:`CameraRig.close`. A finalizer runs at any
allocation, possibly in the middle of another rig's frame: switching the current GL context there would make
that rig draw into the wrong one. So finalizers only queue their contexts; a rig frees them at a safe point
(before it makes its own context current)."""


def _free_orphans() -> None:
    while _ORPHANS:
        gl, context = _ORPHANS.pop()
        gl.make_current()
        context.free()
        gl.free()


class CameraRig:
    """Renders ``cameras`` of ``scene`` at ``size``×``size`` (default: the task's ``image_size``).

    Attributes:
        model, data: what it renders (the scene's, unless built with :meth:`of_model`).
        cameras: the camera names, in render order.
        size: image side in pixels.
    """

    def __init__(self, scene: Scene, cameras: Sequence[str] = CAMERA_NAMES, size: int | None = None) -> None:
        self._setup(scene.model, scene.data, cameras, int(size or scene.task.image_size), scene.sim.render)

    @classmethod
    def of_model(cls, model: mujoco.MjModel, cameras: Sequence[str], size: int,
                 config: RenderConfig) -> CameraRig:
        """A rig for a bare model (e.g. a dataset's stored MJB scene) without a :class:`Scene`; it renders
        its own ``MjData`` unless :meth:`render` is given one."""
        rig = cls.__new__(cls)
        rig._setup(model, mujoco.MjData(model), cameras, int(size), config)
        return rig

    def _setup(self, model: mujoco.MjModel, data: mujoco.MjData, cameras: Sequence[str], size: int,
               config: RenderConfig) -> None:
        self._context: mujoco.MjrContext | None = None
        self.model, self.data = model, data
        self.cameras = tuple(cameras)
        self.size = size
        unknown = [c for c in self.cameras if mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_CAMERA, c) < 0]
        if unknown or not self.cameras:
            raise SceneError(
                f"unknown camera(s) {unknown or '(none given)'}; cameras: {', '.join(CAMERA_NAMES)}"
            )
        if not 8 <= self.size <= MAX_SIZE:
            raise SceneError(f"image size {self.size} outside 8…{MAX_SIZE}")
        _check_gl_backend()
        _free_orphans()
        self._gl: Any = mujoco.GLContext(self.size, self.size)
        self._gl.make_current()
        self._context = mujoco.MjrContext(context_model(model, self.size, config),
                                          mujoco.mjtFontScale.mjFONTSCALE_100)
        mujoco.mjr_setBuffer(mujoco.mjtFramebuffer.mjFB_OFFSCREEN, self._context)
        self._scene = mujoco.MjvScene(model, maxgeom=max(1000, 2 * model.ngeom))
        shadows = bool(model.light_castshadow.any())  # recipes/sim.toml [look] shadows
        self._scene.flags[mujoco.mjtRndFlag.mjRND_SHADOW] = shadows
        self._scene.flags[mujoco.mjtRndFlag.mjRND_REFLECTION] = False
        self._rect = mujoco.MjrRect(0, 0, self.size, self.size)
        self._camera = mujoco.MjvCamera()
        self._camera.type = mujoco.mjtCamera.mjCAMERA_FIXED
        self._ids = [model.camera(c).id for c in self.cameras]
        self._options = [camera_option(model, cam, config) for cam in self._ids]
        self._buffer = np.empty((self.size, self.size, 3), dtype=np.uint8)
        self._look: tuple[mujoco.MjModel, mujoco.MjData, AppearanceDraw] | None = None

    def set_appearance(self, draw: AppearanceDraw | None) -> None:
        """Render with ``draw`` applied to a copy of the model (``None``: as built). Physics never sees it:
        each frame's state is copied into the rig's own data, whose camera and light poses are recomputed
        from the copy."""
        if self._context is None:
            raise SceneError("CameraRig.set_appearance() called after close()")
        self._gl.make_current()
        if draw is None:
            if self._look is not None:
                for tex in range(self.model.ntex):  # put the model's own pixels back
                    mujoco.mjr_uploadTexture(self.model, self._context, tex)
            self._look = None
            return
        look = copy.copy(self.model)
        for tex in draw.apply(look):
            mujoco.mjr_uploadTexture(look, self._context, tex)
        self._look = (look, mujoco.MjData(look), draw)

    def render(self, data: mujoco.MjData | None = None) -> dict[str, np.ndarray]:
        """One RGB image (size, size, 3) uint8 per camera, of ``data`` (default: the scene's current data;
        positions must be computed, e.g. by ``mj_forward``)."""
        if self._context is None:
            raise SceneError("CameraRig.render() called after close()")
        _free_orphans()
        self._gl.make_current()
        model, data = self.model, self.data if data is None else data
        draw = None
        if self._look is not None:
            model, view, draw = self._look
            mujoco.mj_copyData(view, model, data)
            mujoco.mj_camlight(model, view)
            data = view
        out: dict[str, np.ndarray] = {}
        for name, cam, option in zip(self.cameras, self._ids, self._options, strict=True):
            self._camera.fixedcamid = cam
            mujoco.mjv_updateScene(model, data, option, None, self._camera, mujoco.mjtCatBit.mjCAT_ALL,
                                   self._scene)
            if draw is not None:
                draw.add_distractors(self._scene)
            mujoco.mjr_render(self._rect, self._scene, self._context)
            mujoco.mjr_readPixels(self._buffer, None, self._rect, self._context)
            out[name] = self._buffer[::-1].copy()  # OpenGL's rows run bottom to top
        return out

    def close(self) -> None:
        """Free the GL context (idempotent)."""
        if getattr(self, "_context", None) is not None:
            _free_orphans()
            self._gl.make_current()
            self._context.free()
            self._context = None
            self._gl.free()

    def __enter__(self) -> CameraRig:
        return self

    def __exit__(self, exc_type: type[BaseException] | None, exc: BaseException | None,
                 tb: TracebackType | None) -> None:
        self.close()

    def __del__(self) -> None:
        """Queue the GL context for freeing at a safe point (see ``_ORPHANS``); never switch contexts here."""
        if getattr(self, "_context", None) is not None:
            _ORPHANS.append((self._gl, self._context))
            self._context = None
