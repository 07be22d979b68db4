"""The 3D view: the object (clickable) in its own frame with world axes, the Panda hand as a ghost at the
draft pose tinted by the live verdict, the clicked contact point, and the free-mode transform gizmo.

The view's world frame is the object's frame (origin at the bottom centre, +Z up), so every pose the
browser shows or sends is already object-local.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import trimesh
import viser

from mgdata.annotator.objectscene import ObjectScene
from mgdata.motion import Pose

GHOST = {"green": (67, 160, 71), "amber": (255, 160, 0), "red": (229, 57, 53), "pending": (150, 150, 150)}
"""Ghost colours (RGB) per verdict level; ``pending`` while the checks of the newest pose run."""
GHOST_OPACITY = 0.8


def _rgb(rgba: tuple[float, ...]) -> tuple[int, int, int]:
    return tuple(round(255 * c) for c in rgba[:3])  # type: ignore[return-value]


class View:
    """Scene nodes of one server. ``on_click(origin, direction)`` gets object-frame rays of mesh clicks;
    ``on_gizmo(pose, phase)`` gets the gizmo's pose on every drag update."""

    def __init__(self, server: viser.ViserServer, on_click: Callable[[np.ndarray, np.ndarray], None],
                 on_gizmo: Callable[[Pose, str], None]) -> None:
        self.server = server
        self._on_click, self._on_gizmo = on_click, on_gizmo
        scene = server.scene
        scene.set_up_direction("+z")
        # No HDRI environment and no shadow maps: with software WebGL (headless Chromium, remote desktops)
        # their first render blocks the page for many seconds; two lights look the same for CAD-like meshes.
        scene.configure_environment_map(hdri=None)
        scene.configure_default_lights(enabled=True, cast_shadow=False)
        scene.add_light_hemisphere("/fill", intensity=1.2)
        scene.add_grid("/grid", width=0.4, height=0.4, cell_size=0.02, section_size=0.1,
                       position=(0.0, 0.0, -1e-4))
        scene.add_frame("/axes", axes_length=0.08, axes_radius=0.002)
        self._object: list[viser.MeshHandle] = []
        self.pick_mesh: trimesh.Trimesh | None = None
        self._hand = scene.add_frame("/hand", show_axes=False)
        self._hand_parts: list[viser.MeshHandle] = []
        self._marker = scene.add_icosphere("/contact", radius=0.004, color=(30, 30, 200), visible=False)
        self.gizmo = scene.add_transform_controls("/gizmo", scale=0.15, depth_test=False, visible=False)
        self.gizmo.on_update(self._gizmo_event)
        self._ignore_gizmo = False

    def show_object(self, obj: ObjectScene) -> None:
        """Replace the object meshes and the hand meshes (the hand comes from the same scene's Panda)."""
        for h in self._object + self._hand_parts:
            h.remove()
        self._object, self._hand_parts = [], []
        for i, (mesh, rgba) in enumerate(obj.visual):
            h = self.server.scene.add_mesh_simple(f"/object/part_{i}", np.asarray(mesh.vertices, np.float32),
                                                  np.asarray(mesh.faces, np.uint32), color=_rgb(rgba),
                                                  opacity=min(1.0, max(0.35, rgba[3])), side="double")
            h.on_click(self._click)
            self._object.append(h)
        self.pick_mesh = trimesh.util.concatenate([m for m, _ in obj.visual])
        for i, (mesh, _) in enumerate(obj.hand):
            self._hand_parts.append(self.server.scene.add_mesh_simple(
                f"/hand/part_{i}", np.asarray(mesh.vertices, np.float32), np.asarray(mesh.faces, np.uint32),
                color=GHOST["pending"], opacity=GHOST_OPACITY))
        size = float(np.max(self.pick_mesh.extents))
        cam = self.server.initial_camera
        cam.look_at = (0.0, 0.0, size / 2.0)
        dist = 0.22 + 1.2 * size  # m: the hand (~0.2 m) and the object both in view
        cam.position = (0.62 * dist, -0.62 * dist, size / 2.0 + 0.48 * dist)

    def _click(self, event: viser.SceneNodePointerEvent) -> None:
        self._on_click(np.asarray(event.ray_origin, float), np.asarray(event.ray_direction, float))

    async def _gizmo_event(self, event: viser.TransformControlsEvent) -> None:
        # async: viser runs it on the event loop in message order (thread-pool callbacks may reorder)
        if self._ignore_gizmo:
            return
        g = event.target
        self._on_gizmo(Pose(np.asarray(g.position), np.asarray(g.wxyz)), event.phase)

    def set_pose(self, pose: Pose, move_gizmo: bool) -> None:
        """Put the hand (and, unless the gizmo moved it, the gizmo) at ``pose``."""
        with self.server.atomic():
            self._hand.position, self._hand.wxyz = tuple(pose.pos), tuple(pose.quat)
            if move_gizmo:
                self._ignore_gizmo = True
                try:
                    self.gizmo.position, self.gizmo.wxyz = tuple(pose.pos), tuple(pose.quat)
                finally:
                    self._ignore_gizmo = False

    def set_level(self, level: str) -> None:
        """Tint the ghost: green / amber / red, or pending."""
        with self.server.atomic():
            for h in self._hand_parts:
                h.color = GHOST[level]

    def set_contact(self, point: np.ndarray | None) -> None:
        if point is None:
            self._marker.visible = False
        else:
            self._marker.position, self._marker.visible = tuple(point), True

    def set_free_mode(self, free: bool) -> None:
        self.gizmo.visible = free
