"""The annotator app: GUI state and callbacks over a viser server (``mgdata annotate``).

One annotation session per server (a reloaded page shows the same object, draft and counts). Everything the
browser sends is a GUI value or a pose: object keys are checked against the catalog and the only files
written are the grasp DB's category files (:class:`~mgdata.annotator.store.GraspStore`) and the export
``<grasp dir>/export/<category>.npz``, paths the server derives itself.

Server-side event times (``time.monotonic``) are kept in :attr:`Annotator.events` for tests and benchmarks:
``("pose", seq, source)``, ``("verdict", seq, level)``, ``("drag_end", seq, "")``, ``("saved", n, id)``.

Example::

    app = Annotator(Catalog.build(family="jar"), GraspStore(grasps_dir()), host="127.0.0.1", port=8080)
    app.serve_forever()
"""

from __future__ import annotations

import html
import threading
import time
from pathlib import Path

import numpy as np
import viser

from mgdata.annotator.catalog import Catalog
from mgdata.annotator.config import AnnotateSettings, load_annotate_config
from mgdata.annotator.draft import PRESETS, guided_pose, preset_frame, ray_hit
from mgdata.annotator.export import export_grasps
from mgdata.annotator.live import LiveChecker, Verdict
from mgdata.annotator.objectscene import ObjectScene
from mgdata.annotator.placements import recipe_placements
from mgdata.annotator.store import GraspStore
from mgdata.annotator.view import GHOST, View
from mgdata.annotator.worker import Done, LatestWorker
from mgdata.grasps.check import GraspCheckConfig, check_grasp
from mgdata.grasps.config import load_grasp_config
from mgdata.grasps.db import Grasp, approach_hint
from mgdata.motion import Pose
from mgdata.viser_gate import guard, unguard

AS_POSED = "as posed"
"""Guided-mode base orientation kept from free mode (so switching modes keeps the pose)."""
SAME_POSE = (1e-6, 1e-6)  # m, quaternion component: a sim result belongs to the draft it was run on


class Annotator:
    """A running annotation session (see the module docstring)."""

    def __init__(self, catalog: Catalog, store: GraspStore, *, host: str = "127.0.0.1", port: int = 8080,
                 start: str | None = None, settings: AnnotateSettings | None = None,
                 check: GraspCheckConfig | None = None) -> None:
        self.catalog, self.store = catalog, store
        self.settings = settings or load_annotate_config()
        self.check_cfg = check or load_grasp_config().check
        self.events: list[tuple[str, float, int, str]] = []
        self.timings: list[Done[Verdict]] = []  # every verdict shown, with its job's wall and CPU time
        self._lock = threading.RLock()
        self._closed = False
        self._seq = 0
        self.server = viser.ViserServer(host=host, port=port, label="mgdata annotate", verbose=False)
        guard(self.server)  # what a browser sends is checked before viser's handlers see it
        self.view = View(self.server, self._clicked, self._gizmo_moved)
        self._build_gui()
        self.worker: LatestWorker[Verdict] = LatestWorker(self._run_check, self._show_verdict)
        self.verdict: Verdict | None = None
        self.pose: Pose | None = None
        self.sim: tuple[Pose, str, str] | None = None
        self._sim_busy = False
        self._objects: dict[str, tuple[ObjectScene, LiveChecker]] = {}
        self.index = catalog.index(start) if start else store.resume_index(catalog.keys)
        self._open(self.index)

    # ------------------------------------------------------------------------------------------ GUI
    def _build_gui(self) -> None:
        gui, d = self.server.gui, self.settings.draft
        self.progress = gui.add_markdown("")
        self.nav = gui.add_button_group("object", ("◀ prev", "next ▶"))
        self.nav.on_click(lambda e: self._step(-1 if e.target.value.startswith("◀") else 1))
        self.search = gui.add_text("search", "")
        self.search.on_update(lambda _: self._filter())
        self.jump = gui.add_dropdown("jump to", self.catalog.keys, initial_value=self.catalog.keys[0])
        self.jump.on_update(lambda _: self._jumped())
        self.mode = gui.add_dropdown("mode", ("guided", "free"), initial_value="guided")
        self.mode.on_update(lambda _: self._mode_changed())
        with gui.add_folder("guided") as self.guided_folder:
            self.preset = gui.add_dropdown("approach", (AS_POSED, *PRESETS), initial_value="top-down")
            self.yaw = gui.add_slider("yaw (deg)", -180.0, 180.0, d.yaw_step_deg, 0.0)
            self.depth = gui.add_slider("depth (m)", d.depth_min, d.depth_max, d.depth_step, d.depth)
            gui.add_markdown("Click the object to set the contact point.")
        for control in (self.preset, self.yaw, self.depth):
            control.on_update(lambda _: self._guided_changed())
        self.badges = gui.add_html("")
        self.sim_line = gui.add_markdown("")
        self.save_button = gui.add_button("save grasp (Enter)")
        self.delete_button = gui.add_button("delete last (Backspace)")
        self.sim_button = gui.add_button("check in sim (C)")
        self.export_button = gui.add_button("export .npz")
        self.status = gui.add_markdown("")
        self.save_button.on_click(lambda _: self.save())
        self.delete_button.on_click(lambda _: self.delete_last())
        self.sim_button.on_click(lambda _: self.check_in_sim())
        self.export_button.on_click(lambda _: self.export())
        # not W A S D Q E or the arrows: viser's camera controls move the view with those
        hotkeys = (("save grasp", "enter", self.save), ("delete last grasp", "backspace", self.delete_last),
                   ("check in sim", "C", self.check_in_sim), ("next object", "N", lambda: self._step(1)),
                   ("previous object", "P", lambda: self._step(-1)))
        for label, key, action in hotkeys:
            gui.add_command(label, hotkey=key).on_trigger(lambda _, a=action: a())

    def _say(self, text: str) -> None:
        self.status.content = text

    def _update_progress(self) -> None:
        n = len(self.store.annotated(self.key))
        self.progress.content = (f"**{self.index + 1}/{len(self.catalog.keys)}, {n} saved**  \n"
                                 f"`{self.key}`")

    # ------------------------------------------------------------------------------------ navigation
    def _step(self, delta: int) -> None:
        self._open((self.index + delta) % len(self.catalog.keys))

    def _filter(self) -> None:
        found = self.catalog.search(self.search.value)
        if found:
            self.jump.options = found
            self._say(f"{len(found)} match(es) for {self.search.value!r}; pick one under 'jump to'")
        else:
            self._say(f"no object matches {self.search.value!r}")

    def _jumped(self) -> None:
        key = self.jump.value
        if key in self.catalog.keys and key != self.key:  # never trust the client's value
            self._open(self.catalog.index(key))

    def _open(self, index: int) -> None:
        with self._lock:
            self.index, self.key = index, self.catalog.keys[index]
            live = self.settings.live
            if self.key not in self._objects:
                placements = recipe_placements(self.catalog.family, self.key.split("/", 1)[0], live)
                obj = ObjectScene.build(self.key, placements[0], live)
                self._objects = {self.key: (obj, LiveChecker(obj, placements, live, self.check_cfg))}
            obj, _ = self._objects[self.key]
            self.view.show_object(obj)
            if self.jump.value != self.key:
                if self.key not in self.jump.options:
                    self.jump.options = self.catalog.keys
                self.jump.value = self.key
            self.sim = None
            self.sim_line.content = ""
            top = float(max(m.bounds[1][2] for m, _ in obj.visual))
            self.contact = np.array([0.0, 0.0, top])
            self.view.set_contact(self.contact)
            if self.preset.value == AS_POSED:
                self.preset.value = "top-down"
            self.base = preset_frame(self.preset.value)
            self._update_progress()
            yaw, depth = float(self.yaw.value), float(self.depth.value)
            self.set_pose(guided_pose(self.contact, self.base, yaw, depth), "open")

    # ---------------------------------------------------------------------------------------- draft
    def _mode_changed(self) -> None:
        free = self.mode.value == "free"
        self.view.set_free_mode(free)
        self.guided_folder.visible = not free
        if not free:  # keep the pose: guided controls now describe it (base = this orientation, yaw 0)
            with self._lock:
                self.base = self.pose.rotation()
                self.contact = self.pose.pos - self.base[:, 2] * float(self.depth.value)
                self.preset.value, self.yaw.value = AS_POSED, 0.0
                self.view.set_contact(self.contact)

    def _guided_changed(self) -> None:
        if self.mode.value != "guided":
            return
        with self._lock:
            if self.preset.value != AS_POSED:
                self.base = preset_frame(self.preset.value)
            pose = guided_pose(self.contact, self.base, float(self.yaw.value), float(self.depth.value))
            if getattr(self, "pose", None) is None or not _same(pose, self.pose):
                self.set_pose(pose, "guided")

    def _clicked(self, origin: np.ndarray, direction: np.ndarray) -> None:
        if self.mode.value != "guided":
            self._say("free mode: drag the gizmo (switch to guided mode to place by clicking)")
            return
        mesh = self.view.pick_mesh
        hit = ray_hit(origin, direction, np.asarray(mesh.vertices), np.asarray(mesh.faces))
        if hit is None:
            return
        self.contact = hit
        self.view.set_contact(hit)
        self._guided_changed()

    def _gizmo_moved(self, pose: Pose, phase: str) -> None:
        if self.mode.value != "free":
            return
        if phase == "end":  # same pose as the last update: its checks are already running
            self._event("drag_end", self._seq, "")
        if not _same(pose, self.pose):
            self.set_pose(pose, "gizmo", move_gizmo=False)

    def set_pose(self, pose: Pose, source: str, move_gizmo: bool = True) -> None:
        """Make ``pose`` (object frame) the draft: show it, grey the ghost, queue its live checks."""
        with self._lock:
            self.pose = pose
            self.view.set_pose(pose, move_gizmo)
            self.view.set_level("pending")
            _, checker = self._objects[self.key]
            self._seq = self.worker.submit((self.key, checker, pose))
            self._event("pose", self._seq, source)

    # ---------------------------------------------------------------------------------------- checks
    def _run_check(self, request: tuple[str, LiveChecker, Pose], stale) -> Verdict | None:
        _, checker, pose = request
        return checker.check(pose, stale)

    def _show_verdict(self, done: Done[Verdict]) -> None:
        with self._lock:
            if done.seq != self._seq or self._closed:
                return
            v = self.verdict = done.result
            with self.server.atomic():
                self.view.set_level(v.level)
                self.badges.content = _badges_html(v)
            self._event("verdict", done.seq, v.level)
            self.timings.append(done)

    def check_in_sim(self) -> None:
        """Run ``mgdata grasps validate``'s close-and-lift check on the draft in the background."""
        with self._lock:
            if self._sim_busy:
                self._say("a sim check is already running")
                return
            self._sim_busy = True
            key, pose = self.key, self.pose
        self.sim_line.content = "sim check: running …"
        threading.Thread(target=self._sim_thread, args=(key, pose), daemon=True).start()

    def _sim_thread(self, key: str, pose: Pose) -> None:
        try:
            grasp = Grasp("draft", tuple(pose.pos), tuple(pose.quat), approach_hint(pose.quat), "annotated")
            status, detail = check_grasp(key, grasp, self.check_cfg)
            with self._lock:
                if key == self.key:
                    self.sim = (pose, status, detail)
                    self.sim_line.content = f"sim check: **{status}** ({detail})"
                    self._event("sim", self._seq, status)
        finally:
            self._sim_busy = False

    # -------------------------------------------------------------------------------------- saving
    def save(self) -> Grasp:
        """Save the draft as an annotated grasp (with the sim result if it was run on this very pose)."""
        with self._lock:
            pose, status, detail = self.pose, "unvalidated", ""
            if self.sim is not None and _same(self.sim[0], pose):
                status, detail = self.sim[1], self.sim[2]
            grasp = self.store.add(self.key, tuple(pose.pos), tuple(pose.quat), self.mode.value, status,
                                   detail)
            self._update_progress()
            self._say(f"saved {grasp.id} ({grasp.approach}, {status})")
            self._event("saved", len(self.store.annotated(self.key)), grasp.id)
            return grasp

    def delete_last(self) -> Grasp | None:
        with self._lock:
            gone = self.store.delete_last(self.key)
            self._update_progress()
            self._say(f"deleted {gone.id}" if gone else "no annotated grasp to delete")
            self._event("deleted", len(self.store.annotated(self.key)), gone.id if gone else "")
            return gone

    def export(self) -> Path:
        category = self.key.split("/", 1)[0]
        keys = [k for k in self.store.db.keys if k.split("/", 1)[0] == category]
        path = export_grasps(self.store.db, keys, self.store.directory / "export" / f"{category}.npz")
        self._say(f"exported {sum(len(self.store.grasps(k)) for k in keys)} grasps to {path}")
        return path

    # ----------------------------------------------------------------------------------------- misc
    def _event(self, kind: str, seq: int, text: str) -> None:
        self.events.append((kind, time.monotonic(), seq, text))

    def serve_forever(self) -> None:
        try:
            while True:
                time.sleep(3600)
        finally:
            self.close()

    def close(self) -> None:
        with self._lock:
            self._closed = True
        self.worker.close()
        unguard(self.server)
        self.server.stop()


def _same(a: Pose, b: Pose) -> bool:
    return bool(np.allclose(a.pos, b.pos, atol=SAME_POSE[0])
                and np.allclose(a.quat, b.quat, atol=SAME_POSE[1]))


def _badges_html(v: Verdict) -> str:
    rows = []
    for b in v.badges:
        r, g, bl = GHOST[b.level]
        rows.append(f'<div style="margin:2px 0"><span data-check="{b.name}" data-level="{b.level}" '
                    f'style="display:inline-block;min-width:64px;padding:1px 6px;border-radius:8px;'
                    f'background:rgb({r},{g},{bl});color:white;font-weight:600;text-align:center">'
                    f'{b.name}</span> '
                    f'<span style="font-size:0.78em;line-height:1.2">{html.escape(b.reason)}</span></div>')
    r, g, bl = GHOST[v.level]
    head = (f'<div data-verdict="{v.level}" style="font-weight:700;color:rgb({r},{g},{bl})">live check: '
            f'{v.level} ({sum(v.clear)}/{len(v.clear)} placements clear, {v.seconds * 1000:.0f} ms)</div>')
    return head + "".join(rows)
