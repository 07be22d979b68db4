"""The live checks: is a draft grasp pose reachable and clear, at the placements that matter?

For each placement (the sim check's, then the recipe's; :mod:`mgdata.annotator.placements`) the object is
stood there and five checks run with the generator's motion facade:

* ``reach``: IK solutions for the pre-grasp pose (``standoff`` back along the approach, as the sim check)
  and the grasp pose, every joint at least ``joint_margin`` inside its limits: a quick pass, and at the
  sim check's placement also a thorough one with the planner's restarts, as ``mgdata grasps validate``;
* ``arm``: at the grasp pose nothing touches anything except the hand and the object;
* ``approach``: the pre-grasp pose is collision-free and so is the straight line from it to the grasp (the
  hand may touch the object); joints are interpolated and the TCP must stay within ``LINE_TOL`` of the
  line, else the line is solved waypoint by waypoint;
* ``lift``: the pose ``lift`` above the grasp is reachable with the object in the hand (object–table contact
  allowed), joints inside the margin;
* ``width`` (the same everywhere): the object material between the open finger pads is narrower than the
  opening minus ``width_clearance`` (else red) and reaches along the approach at least ``min_grip_depth``
  (green), ``pinch_depth`` (amber) or less (red: the fingers pinch an edge or close on air); the surfaces
  each finger meets first face it within ``grip_cone_deg`` (else amber: the object may squirt out);
* ``contact`` (the same everywhere): how deep the open hand cuts into the object at the grasp pose and on
  the approach: green up to ``touch_depth``, amber up to ``push_depth`` (the hand will push the object
  before closing), red beyond (it lands on the object instead of around it).

A check is green when it passes at every placement, amber at some, red at none; the verdict is the worst
badge, and red too when no single placement passes everything. A cold check (``warm=False``) is
deterministic: every solve starts from ``HOME_Q`` (wrist turned as the pose needs) with a fixed seed. While
dragging, the previous pose's solutions are tried first (see :meth:`LiveChecker.check`).

Example::

    checker = LiveChecker(obj, recipe_placements("jar", "jar", cfg), cfg, GraspCheckConfig())
    verdict = checker.check(Pose(pos, quat))      # pose of the TCP in the object frame
    verdict.level, [b.reason for b in verdict.badges]
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from mgdata.annotator.config import LiveConfig
from mgdata.annotator.meshes import body_subtree_geoms
from mgdata.annotator.objectscene import INSTANCE, ObjectScene
from mgdata.annotator.placements import Placement, sim_check_placement
from mgdata.grasps.check import GraspCheckConfig
from mgdata.grasps.db import Grasp, approach_hint
from mgdata.motion import AllowedContacts, Attachment, MotionFailure, MotionPlanner, Pose
from mgdata.sim import robot

CHECKS: tuple[str, ...] = ("reach", "arm", "approach", "lift", "width", "contact")
PER_PLACEMENT: tuple[str, ...] = CHECKS[:4]
LEVELS: tuple[str, ...] = ("green", "amber", "red")
WARM_DIST, WARM_ANGLE = 0.05, 0.5
"""m, rad: a pose this near the previous one starts its IK from the previous solutions (a drag)."""
LINE_TOL = 0.003
"""m a joint-interpolated approach may leave the straight line before it is solved waypoint by waypoint."""


@dataclass(frozen=True)
class Badge:
    """One check's result over all placements: ``level`` green / amber / red and a one-line reason."""

    name: str
    level: str
    reason: str


@dataclass(frozen=True)
class Verdict:
    """The live checks of one pose.

    Attributes:
        level: green (reachable and clear everywhere), amber (somewhere), red (nowhere, or too wide / empty).
        badges: one per check, in :data:`CHECKS` order.
        clear: per placement, whether every check passed there.
        placements: the placements checked (the sim check's first).
        seconds: compute time.
    """

    level: str
    badges: tuple[Badge, ...]
    clear: tuple[bool, ...]
    placements: tuple[Placement, ...]
    seconds: float

    def badge(self, name: str) -> Badge:
        return next(b for b in self.badges if b.name == name)


class _Stale(Exception):
    """A newer pose is waiting: the check in progress is abandoned."""


def _worst(levels: list[str]) -> str:
    return max(levels, key=LEVELS.index)


class LiveChecker:
    """Runs the live checks of TCP poses (object frame) on one object model."""

    def __init__(self, obj: ObjectScene, placements: tuple[Placement, ...], cfg: LiveConfig,
                 check: GraspCheckConfig) -> None:
        self.obj, self.placements, self.cfg, self.check_cfg = obj, placements, cfg, check
        planner = obj.planner
        self._lower, self._upper = planner.lower, planner.upper
        self._fingers = AllowedContacts(((robot.HAND_BODY, INSTANCE),))  # judged by depth instead
        m = obj.scene.model
        self._finger_geoms = np.zeros(m.ngeom, dtype=bool)
        self._finger_geoms[body_subtree_geoms(m, m.body(robot.HAND_BODY).id)] = True
        self._depth: float | None = None
        self._object_geoms = np.zeros(m.ngeom, dtype=bool)
        self._object_geoms[obj.scene.object_geom_ids(INSTANCE)] = True
        turned = robot.HOME_Q.copy()
        turned[6] -= np.pi
        self._homes = (robot.HOME_Q, turned)
        self._last: tuple[Pose, list[np.ndarray | None]] | None = None
        self._stale: Callable[[], bool] = lambda: False
        self._lifting = AllowedContacts(((robot.HAND_BODY, INSTANCE), (INSTANCE, "table")))

    # --------------------------------------------------------------------------------------- public
    def check(self, pose: Pose, stale: Callable[[], bool] = lambda: False, warm: bool = True
              ) -> Verdict | None:
        """The verdict for TCP pose ``pose`` in the object frame; None if ``stale()`` turned true meanwhile
        (a newer pose is waiting, so this one's verdict would never be shown).

        ``warm``: when the previous pose checked was near this one (a drag), its pre-grasp solutions are
        tried first as IK seeds; a solution found that way is a real witness of reachability, and where
        none is found the seeded search from ``HOME_Q`` decides as in a cold check.
        """
        t0 = time.perf_counter()
        last = self._last
        near = (warm and last is not None and float(np.linalg.norm(last[0].pos - pose.pos)) < WARM_DIST
                and last[0].angle_to(pose) < WARM_ANGLE)
        witnesses: list[np.ndarray | None] = []
        grasp = Grasp("draft", tuple(pose.pos), tuple(pose.quat), approach_hint(pose.quat), "annotated")
        placements = (sim_check_placement(grasp, self.check_cfg, self.obj.key), *self.placements)
        width = self._width(pose)
        self._depth = None
        results: list[dict[str, str | None]] = []
        self._stale = stale
        for i, placement in enumerate(placements):
            hint = last[1][i] if near and last is not None and i < len(last[1]) else None
            try:
                out, q_pre = self._at(placement, pose, thorough=i == 0, hint=hint)
            except _Stale:
                return None
            results.append(out)
            witnesses.append(q_pre)
        self._last = (pose, witnesses)
        badges = []
        for name in PER_PLACEMENT:
            fails = [(p, r[name]) for p, r in zip(placements, results, strict=True) if r[name] is not None]
            if not fails:
                badges.append(Badge(name, "green", f"clear at all {len(placements)} placements"))
            elif len(fails) < len(placements):
                p, why = fails[0]
                badges.append(Badge(name, "amber", f"fails at {len(fails)} of {len(placements)}: "
                                    f"{p.describe()}: {why}"))
            else:
                badges.append(Badge(name, "red", f"fails at every placement; {placements[0].label}: "
                                    f"{fails[0][1]}"))
        badges.append(Badge("width", *width))
        contact = self._contact_badge()
        badges.append(contact)
        clear = tuple(all(v is None for v in r.values()) and width[0] != "red" and contact.level != "red"
                      for r in results)
        level = _worst([b.level for b in badges])
        if not any(clear):
            level = "red"
        return Verdict(level, tuple(badges), clear, placements, time.perf_counter() - t0)

    # ---------------------------------------------------------------------------------------- checks
    def _room(self, *qs: np.ndarray) -> str | None:
        """None if every joint of every ``q`` keeps the margin, else which one does not."""
        for q in qs:
            room = np.minimum(q - self._lower, self._upper - q)
            j = int(np.argmin(room))
            if room[j] < self.cfg.joint_margin - 1e-3:  # IK keeps the margin up to its own tolerance
                return (f"joint{j + 1} {max(room[j], 0.0):.2f} rad from its limit "
                        f"(margin {self.cfg.joint_margin:g})")
        return None

    def _at(self, placement: Placement, pose: Pose, thorough: bool, hint: np.ndarray | None
            ) -> tuple[dict[str, str | None], np.ndarray | None]:
        """Failure reason per check at one placement (None: passed); ``thorough``: IK falls back to the
        deep pass (the sim check's placement, whose verdict predicts ``mgdata grasps validate``)."""
        out: dict[str, str | None] = dict.fromkeys(PER_PLACEMENT)
        obj = self.obj
        obj.place(placement)
        world = placement.matrix()
        world[2, 3] = obj.world_T_object[2, 3]
        target = Pose.from_matrix(world @ pose.matrix())
        approach = target.rotation()[:, 2]
        pre = Pose(target.pos - approach * self.check_cfg.standoff, target.quat)
        rng = np.random.default_rng(0)
        seeds = [self._seed(pre)] if hint is None else [hint, self._seed(pre)]
        self._poll()
        q_pre = self._solve(pre, seeds, rng, "pre-grasp", out, "approach", thorough)
        self._poll()
        q = None if q_pre is None else self._solve(target, [q_pre], rng, "grasp", out, "arm", thorough)
        self._poll()
        if q_pre is None or q is None:
            for name in ("arm", "approach", "lift"):
                out[name] = out[name] or "not checked: " + (out["reach"] or "the pre-grasp pose collides")
            return out, q_pre
        out["reach"] = self._room(q_pre, q)
        out["arm"] = self._clear(q)
        out["approach"] = self._approach(q_pre, q, pre, target)
        self._poll()
        out["lift"] = self._lift(obj.deep if thorough else obj.planner, q, target, world, rng)
        return out, q_pre

    def _seed(self, pose: Pose) -> np.ndarray:
        """``HOME_Q`` or ``HOME_Q`` with the wrist turned half a turn, whichever points the hand nearer
        ``pose``: the local IK cannot cross the wrist's joint limit to undo a half-turn roll by itself."""
        return min(self._homes, key=lambda q: self.obj.planner.fk(q).angle_to(pose))

    def _poll(self) -> None:
        """Give up (raise :class:`_Stale`) when a newer pose is waiting."""
        if self._stale():
            raise _Stale

    def _solve(self, pose: Pose, seeds: list[np.ndarray], rng: np.random.Generator, what: str,
               out: dict[str, str | None], collision_check: str, thorough: bool) -> np.ndarray | None:
        """IK with the fingers allowed to touch the object: the quick pass from each seed, then
        (``thorough``) the deep pass from the last one. On failure, say whether the pose is out of reach
        (``reach``) or only reachable in collision (``collision_check``)."""
        quick, chk = self.obj.planner, self.obj.planner.checker
        deep = self.obj.deep if thorough else quick
        seed = seeds[-1]
        tries = [(quick, s) for s in seeds] + ([(deep, seed)] if thorough else [])
        q = None
        for planner, start in tries:
            try:
                q = planner.ik(pose, start, rng)
                break
            except MotionFailure:
                continue
        if q is None:
            out["reach"] = out["reach"] or f"no IK solution for the {what} pose within the joint margin"
            return None
        chk.configure(self._fingers, None, 0.0)
        if chk.valid(q):
            return q
        try:  # reachable, but this solution collides: search thoroughly for one that does not
            return deep.ik(pose, seed, rng, collision_free=True, allowed=self._fingers)
        except MotionFailure:
            chk.configure(self._fingers, None, 0.0)
            out[collision_check] = f"every {what} solution found collides, e.g. {chk.explain(q)}"
            return None

    def _approach(self, q_pre: np.ndarray, q: np.ndarray, pre: Pose, target: Pose) -> str | None:
        planner, chk = self.obj.planner, self.obj.planner.checker
        chk.configure(self._fingers, None, 0.0)
        n = max(2, int(np.ceil(self.check_cfg.standoff / self.cfg.approach_step)))
        path = [q_pre + (q - q_pre) * (k / n) for k in range(1, n)]
        off = max((_line_distance(planner.fk(p).pos, pre.pos, target.pos) for p in path), default=0.0)
        if off > LINE_TOL:  # the joint interpolation bows away: solve the line waypoint by waypoint
            path, prev = [], q_pre
            rng = np.random.default_rng(1)
            for k in range(1, n):
                try:
                    waypoint = Pose(pre.pos + (target.pos - pre.pos) * (k / n), target.quat)
                    prev = planner.ik(waypoint, prev, rng)
                except MotionFailure:
                    return (f"the straight approach leaves the arm's reach "
                            f"{k / n * self.check_cfg.standoff:.2f} m in")
                path.append(prev)
        for p in path:
            why = self._clear(p)
            if why is not None:
                return f"the straight approach collides: {why}"
        return None

    def _clear(self, q: np.ndarray) -> str | None:
        """None if ``q`` is collision-free apart from the hand touching the object; how deep the open hand
        cuts into the object is recorded for the ``contact`` badge (it is the same at every placement)."""
        chk = self.obj.planner.checker
        chk.configure(self._fingers, None, 0.0)
        if not chk.valid(q):
            return chk.explain(q)
        con = chk.data.contact[: chk.data.ncon]
        depth = 0.0
        if len(con):
            g1, g2 = con.geom[:, 0], con.geom[:, 1]
            fo = self._finger_geoms, self._object_geoms
            pair = (fo[0][g1] & fo[1][g2]) | (fo[0][g2] & fo[1][g1])
            if pair.any():
                depth = max(0.0, -float(con.dist[pair].min()))
        self._depth = max(self._depth or 0.0, depth)
        return None

    def _contact_badge(self) -> Badge:
        d, touch, push = self._depth, self.cfg.touch_depth, self.cfg.push_depth
        if d is None:
            return Badge("contact", "amber", "not checked: the grasp is reachable nowhere")
        mm = f"{d * 1000:.0f} mm"
        if d <= touch:
            return Badge("contact", "green", f"the open hand at most touches the object ({mm})")
        if d <= push:
            return Badge("contact", "amber", f"the open hand cuts {mm} into the object on the way in: it "
                         f"will push the object before the fingers close (green up to {touch * 1000:.0f} mm)")
        return Badge("contact", "red", f"the open hand cuts {mm} into the object: it lands on it instead of "
                     f"around it (limit {push * 1000:.0f} mm)")

    def _lift(self, planner: MotionPlanner, q: np.ndarray, target: Pose, world_T_obj: np.ndarray,
              rng: np.random.Generator) -> str | None:
        held = Attachment(INSTANCE, np.linalg.inv(planner.fk(q).matrix()) @ world_T_obj)
        up = Pose(target.pos + np.array([0.0, 0.0, self.check_cfg.lift]), target.quat)
        try:
            q_up = planner.ik(up, q, rng, collision_free=True, allowed=self._lifting, attached=held)
        except MotionFailure as fail:
            return f"lift pose {self.check_cfg.lift:.2f} m up: {fail.reason}"
        return self._room(q_up)

    # ----------------------------------------------------------------------------------------- width
    def _width(self, pose: Pose) -> tuple[str, str]:
        pads = self.obj.pads
        tcp_T_obj = np.linalg.inv(pose.matrix())
        pts = self.obj.surface @ tcp_T_obj[:3, :3].T + tcp_T_obj[:3, 3]
        normals = self.obj.normals @ tcp_T_obj[:3, :3].T
        inside = ((np.abs(pts[:, 0]) <= pads.half_x) & (pts[:, 2] >= pads.z_lo) & (pts[:, 2] <= pads.z_hi)
                  & (np.abs(pts[:, 1]) <= pads.half_gap))
        opening = 2.0 * pads.half_gap
        if not inside.any():
            return "red", "nothing between the finger pads: the fingers would close on air"
        ys, zs = pts[inside, 1], pts[inside, 2]
        width, depth = float(ys.max() - ys.min()), float(zs.max() - zs.min())
        limit = opening - self.cfg.width_clearance
        if width > limit:
            return "red", (f"{width * 100:.1f} cm of object between the pads; the hand opens "
                           f"{opening * 100:.1f} cm ({self.cfg.width_clearance * 1000:.0f} mm to spare)")
        held = f"{width * 100:.1f} cm across, {depth * 1000:.0f} mm deep between the pads"
        if depth < self.cfg.pinch_depth:
            return "red", f"{held}: the fingers would pinch an edge (< {self.cfg.pinch_depth * 1000:.0f} mm)"
        if depth < self.cfg.min_grip_depth:
            return "amber", f"{held}: a shallow grip (green from {self.cfg.min_grip_depth * 1000:.0f} mm)"
        skew = _closing_skew(ys, normals[inside, 1])
        if skew > self.cfg.grip_cone_deg:
            return "amber", (f"{held}, but the surfaces the fingers meet first face {skew:.0f}° away from "
                             f"the closing direction (green up to {self.cfg.grip_cone_deg:g}°): it may slip")
        return "green", f"{held} (opening {opening * 100:.1f} cm)"


def _closing_skew(ys: np.ndarray, ny: np.ndarray, patch: float = 0.002) -> float:
    """Median angle (deg) between the closing direction and the surface normals of the patches each
    finger meets first (points within ``patch`` m of the extreme y on either side); an antipodal grasp has
    normals along ∓Y there."""
    angles = []
    for side, sign in ((ys >= ys.max() - patch, 1.0), (ys <= ys.min() + patch, -1.0)):
        cos = np.clip(sign * ny[side], -1.0, 1.0)  # outward normal should point at the finger on that side
        angles.append(float(np.median(np.degrees(np.arccos(cos)))))
    return max(angles)


def _line_distance(p: np.ndarray, a: np.ndarray, b: np.ndarray) -> float:
    ab = b - a
    t = float(np.clip((p - a) @ ab / max(float(ab @ ab), 1e-12), 0.0, 1.0))
    return float(np.linalg.norm(p - (a + t * ab)))
