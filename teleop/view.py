"""The operator view in the browser: the operator's page (``teleop/page.py``: the live monitor, the buttons
and hotkeys) with viser's view beside it (the scene streamed from the MjModel and the recorded camera views).

The scene is built once from the model's visual geoms (meshes, boxes, spheres, capsules, cylinders) under one
frame per body; after each control step the body frames that moved go to ``data.xpos/xquat``. The monitor
shows each constraint's formula and DFA state, a banner at the first violation, engagement, success and the
gate's streak, and the step number the state belongs to (the benchmark measures its latency in the browser).
It is pushed to the page as its own event stream, not through viser, whose client paces its batches.
The session's commands are the page's buttons and hotkeys, and viser commands (the same letters) inside the
3D view.

The control loop only hands a snapshot over (:meth:`OperatorView.update`: the status, a copy of the body
poses; microseconds): a publisher thread at a lower OS priority sends the newest snapshot, monitor first,
and drops the ones it had no time for (a bounded, latest-value handoff), so the browser never slows the
20 Hz loop down and never falls behind it.

Example::

    view = OperatorView(session, host="127.0.0.1", port=8080)  # the page; viser on port + 1
    session.on_status = view.update
"""

from __future__ import annotations

import contextlib
import dataclasses
import json
import os
import threading
import time
from collections import deque
from typing import Any

import mujoco
import numpy as np

from mgdata.teleop.config import ViewConfig, load_teleop_config
from mgdata.teleop.page import OperatorPage
from mgdata.teleop.sdk import require
from mgdata.teleop.session import SessionStatus, TeleopSession

_BUTTONS = (("Record", "record", "r"), ("Stop", "stop", "s"), ("Mark done", "done", "m"),
            ("Discard", "discard", "d"), ("Reset task", "reset", "t"), ("Clutch", "clutch", "c"),
            ("Gripper", "grip", "g"), ("Quit", "quit", "q"))
"""(label, session command, hotkey in the terminal and in the browser)."""

PUBLISHER_NICE = 5
"""How much lower than the control loop the publisher thread runs (Linux nice increment)."""

_POSE_EPS = 1e-6
"""A body pose component that changed by less than this (m, or quaternion units) is not resent."""


@dataclasses.dataclass(frozen=True)
class _Snapshot:
    status: SessionStatus
    pos: np.ndarray | None  # (n_bodies, 3) xpos of the drawn bodies, or None (not this step)
    quat: np.ndarray | None  # (n_bodies, 4) xquat
    images: dict[str, np.ndarray] | None  # camera images to show, or None (not this step)


def _geom_mesh(model: mujoco.MjModel, g: int) -> tuple[np.ndarray, np.ndarray] | None:
    """Vertices and faces of visual geom ``g`` in its own frame, or ``None`` for a type not drawn."""
    import trimesh

    t, size = model.geom_type[g], model.geom_size[g]
    if t == mujoco.mjtGeom.mjGEOM_MESH:
        m = model.geom_dataid[g]
        v0, nv = model.mesh_vertadr[m], model.mesh_vertnum[m]
        f0, nf = model.mesh_faceadr[m], model.mesh_facenum[m]
        return model.mesh_vert[v0:v0 + nv].copy(), model.mesh_face[f0:f0 + nf].copy()
    if t == mujoco.mjtGeom.mjGEOM_BOX:
        mesh = trimesh.creation.box(extents=2 * size)
    elif t == mujoco.mjtGeom.mjGEOM_SPHERE:
        mesh = trimesh.creation.icosphere(subdivisions=2, radius=size[0])
    elif t == mujoco.mjtGeom.mjGEOM_ELLIPSOID:
        mesh = trimesh.creation.icosphere(subdivisions=2, radius=1.0)
        mesh.apply_scale(size)
    elif t == mujoco.mjtGeom.mjGEOM_CAPSULE:
        mesh = trimesh.creation.capsule(height=2 * size[1], radius=size[0], count=[12, 12])
    elif t == mujoco.mjtGeom.mjGEOM_CYLINDER:
        mesh = trimesh.creation.cylinder(radius=size[0], height=2 * size[1], sections=20)
    else:
        return None
    return np.asarray(mesh.vertices, dtype=np.float32), np.asarray(mesh.faces, dtype=np.int32)


class OperatorView:
    """Serves the operator view of ``session`` (see the module docstring).

    Attributes:
        page: the operator's page; ``url``: where to point a browser (the page).
        server: the viser server (``scene_port``, by default ``port + 1``), shown in the page's iframe.
        image_every, scene_every: control steps between camera-image and 3D scene updates
            (``[view]`` in ``recipes/teleop.toml``).
    """

    def __init__(self, session: TeleopSession, host: str = "127.0.0.1", port: int = 8080,
                 config: ViewConfig | None = None, scene_port: int | None = None) -> None:
        viser = require("viser")
        from mgdata.viser_gate import guard
        config = config or load_teleop_config().view
        self.session = session
        self.image_every, self.scene_every = config.image_every, config.scene_every
        self.shadows, self.environment = config.shadows, config.environment
        self.server: Any = viser.ViserServer(host=host, port=port + 1 if scene_port is None else scene_port,
                                             label="mgdata teleop", verbose=False)  # the next free port
        guard(self.server)  # what a browser sends the scene is checked before viser's handlers see it
        job = session.job
        try:
            self.page = OperatorPage(host, port, self.server.get_port(), session.command, _BUTTONS,
                                     f"{job.arm} · {job.family} task {job.task} → {job.out}")
        except BaseException:
            self.close_scene()
            raise
        self.url = self.page.url
        scene = session.scene
        self._model, self._data = scene.model, scene.data
        self._bodies: dict[int, Any] = {}
        self._build_scene()
        self._build_gui(session)
        self._n = 0
        self._cond = threading.Condition()
        self._next: _Snapshot | None = None
        self._stop = False
        self.published = 0  # snapshots pushed to viser
        self.superseded = 0  # snapshots replaced by a newer one before the publisher got to them
        self.flushed: deque[tuple[int, float]] = deque(maxlen=20_000)  # (step, time.time()) monitor sent
        self._send_monitor(session.status)
        self._thread = threading.Thread(target=self._publish_loop, name="operator-view", daemon=True)
        self._thread.start()

    # -- scene ---------------------------------------------------------------------------------------------
    def _build_scene(self) -> None:
        model, s = self._model, self.server.scene
        s.add_grid("/grid", width=2.0, height=2.0, position=(0.4, 0.0, -0.001))
        s.configure_default_lights(cast_shadow=self.shadows)
        if not self.environment:  # image-based lighting: per-pixel cost a software-rendered browser feels
            s.configure_environment_map(hdri=None)
        cam = self.server.initial_camera
        cam.position, cam.look_at = (1.55, -0.95, 0.85), (0.45, 0.0, 0.1)
        for g in range(model.ngeom):
            if model.geom_group[g] > 2 or model.geom_rgba[g, 3] < 0.05:
                continue
            if model.geom_type[g] == mujoco.mjtGeom.mjGEOM_PLANE:
                continue
            mesh = _geom_mesh(model, g)
            if mesh is None:
                continue
            b = int(model.geom_bodyid[g])
            if b not in self._bodies:
                self._bodies[b] = s.add_frame(f"/world/b{b}", show_axes=False)
            rgba = model.geom_rgba[g]
            mat = model.geom_matid[g]
            if mat >= 0:
                rgba = model.mat_rgba[mat]
            s.add_mesh_simple(f"/world/b{b}/g{g}", mesh[0], mesh[1],
                              color=tuple(int(255 * c) for c in rgba[:3]),
                              opacity=float(rgba[3]) if rgba[3] < 1 else None,
                              cast_shadow=self.shadows, receive_shadow=self.shadows,
                              wxyz=tuple(model.geom_quat[g]), position=tuple(model.geom_pos[g]))
        self._ids = np.array(list(self._bodies), dtype=np.int64)
        self._frames = [self._bodies[int(b)] for b in self._ids]
        self._sent_pos = np.full((len(self._ids), 3), np.inf)
        self._sent_quat = np.full((len(self._ids), 4), np.inf)
        self._move_bodies(self._data.xpos[self._ids], self._data.xquat[self._ids])

    def _move_bodies(self, pos: np.ndarray, quat: np.ndarray) -> int:
        """Send the poses of the bodies that moved since the last send; returns how many."""
        moved = np.flatnonzero((np.abs(pos - self._sent_pos).max(axis=1) > _POSE_EPS)
                               | (np.abs(quat - self._sent_quat).max(axis=1) > _POSE_EPS))
        if len(moved):
            with self.server.atomic():
                for i in moved:
                    frame = self._frames[i]
                    frame.position = tuple(pos[i])
                    frame.wxyz = tuple(quat[i])
            self._sent_pos[moved], self._sent_quat[moved] = pos[moved], quat[moved]
        return len(moved)

    # -- panel ---------------------------------------------------------------------------------------------
    def _build_gui(self, session: TeleopSession) -> None:
        gui = self.server.gui
        gui.add_markdown(f"Live monitor and buttons: the operator page, {self.url}")
        for label, cmd, key in _BUTTONS:  # hotkeys while the 3D view has the keyboard focus
            hotkey = gui.add_command(label, hotkey=key.upper())  # type: ignore[arg-type]
            hotkey.on_trigger(lambda _event, c=cmd: session.command(c))
        self._images = {}
        with gui.add_folder("Cameras"):
            for cam in session.cameras.cameras:
                blank = np.zeros((session.cameras.size, session.cameras.size, 3), dtype=np.uint8)
                self._images[cam] = gui.add_image(blank, label=cam, format="jpeg", jpeg_quality=80)

    @staticmethod
    def monitor_state(s: SessionStatus) -> dict[str, Any]:
        """The monitor as the page shows it (JSON-serialisable)."""
        mode = "settling" if s.settling else "recording" if s.recording else "idle"
        if s.recording and s.clutch_out:
            mode += " · CLUTCH OUT (the robot holds; press c to re-engage)"
        constraints = [{"id": cid, "formula": s.formulas[k],
                        "violated": bool(s.violated[k]) if k < len(s.violated) else False,
                        "state": int(s.dfa_state[k]) if k < len(s.dfa_state) else 0}
                       for k, cid in enumerate(s.constraints)]
        return {"step": s.step, "sent_at": s.sent_at, "mode": mode, "constraints": constraints,
                "first_violation": s.first_violation, "engaged": s.engaged, "success": s.success,
                "streak": s.streak, "hold_steps": s.hold_steps, "kept": s.kept, "failed": s.failed,
                "message": s.message}

    # -- per step ------------------------------------------------------------------------------------------
    def update(self, status: SessionStatus) -> None:
        """Hand the state after a control step to the publisher (called by the control loop; cheap).

        Body poses go every ``scene_every`` steps and camera images every ``image_every``; a newer snapshot
        replaces one not yet published (keeping its poses or images where the newer one has none)."""
        self._n += 1
        images = status.images if self._n % self.image_every == 0 and status.images else None
        pos = quat = None
        if self._n % self.scene_every == 0:
            pos, quat = self._data.xpos[self._ids].copy(), self._data.xquat[self._ids].copy()
        snap = _Snapshot(dataclasses.replace(status), pos, quat, images)
        with self._cond:
            old = self._next
            if old is not None:
                self.superseded += 1
                if snap.images is None and old.images is not None:
                    snap = dataclasses.replace(snap, images=old.images)
                if snap.pos is None and old.pos is not None:
                    snap = dataclasses.replace(snap, pos=old.pos, quat=old.quat)
            self._next = snap
            self._cond.notify()

    def _publish_loop(self) -> None:
        with contextlib.suppress(OSError, AttributeError):  # Linux: a per-thread priority below the loop's
            os.setpriority(os.PRIO_PROCESS, threading.get_native_id(), PUBLISHER_NICE)
        while True:
            with self._cond:
                while self._next is None and not self._stop:
                    self._cond.wait()
                if self._stop:
                    return
                snap, self._next = self._next, None
            self._send_monitor(snap.status)
            if snap.pos is not None and snap.quat is not None:
                self._move_bodies(snap.pos, snap.quat)
            if snap.images is not None:
                for cam, handle in self._images.items():
                    handle.image = snap.images[cam]
            self.published += 1

    def _send_monitor(self, status: SessionStatus) -> None:
        """Push the monitor state to every open operator page at once (its own stream, not viser's)."""
        self.page.publish(json.dumps(self.monitor_state(status), separators=(",", ":")).encode())
        self.flushed.append((status.step, time.time()))

    def close(self) -> None:
        with self._cond:
            self._stop = True
            self._cond.notify()
        self._thread.join(timeout=5.0)
        self.page.close()
        self.close_scene()

    def close_scene(self) -> None:
        """Stop the viser server and its gate."""
        from mgdata.viser_gate import unguard

        unguard(self.server)
        self.server.stop()
