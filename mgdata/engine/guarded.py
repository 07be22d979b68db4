"""Guarded moves: a straight TCP line that stops on contact, with a bound on how hard it pushes.

A ``guarded`` segment (:func:`mgdata.skeleton.segment.guarded`) moves the TCP along a world direction (or
towards a target) at its start orientation. Every control step the live MuJoCo contacts between the *moving
set* (the hand and fingers, plus the held object if ``attached``) and the ``until`` body are read
(:func:`mgdata.sim.contact_force.pair_contact`), and the move stops as soon as

* ``touch(body)``: the two touch, or
* ``force(body, newtons)``: the sum of their contacts' normal forces is at least ``newtons``.

How the command relates to the arm: the position servos do not compensate gravity, so the command is the
*rest command* of a point on the line (:class:`mgdata.sim.servo.ArmServo`: the command under which the arm
rests exactly there, pushing on nothing), and the point is advanced along the line. The line starts where
the previous command brings the arm to rest, so the command continues without a jump even if the arm is
still catching up with it. The force on anything
the arm meets along the line is then at most ``k · lead``, the servos' pinned stiffness ``k`` along the
line times how far the commanded point leads the measured TCP, so

* while free, the commanded point leads by at most ``max_force / k``: the approach speed adapts to the
  bound (≈ 5 mm/s for 20 N over the table), and first contact cannot push harder;
* in contact for ``force(...)``, the lead is corrected each step by ``(goal - F) / k`` towards a goal
  between the threshold and ``max_force``; since the real contact is softer than ``k``, the force rises
  monotonically towards the goal without overshooting it (quasi-statically);
* a measured force above ``max_force`` backs the commanded point off to the measured TCP.

On stop the arm is commanded to rest where it actually is (one step of the rest command of the measured
configuration), so it does not keep pushing. Without the condition the move ends when the commanded point
has reached ``max_distance`` and the arm has caught up (``guarded_no_contact``), or when the measured TCP
has not advanced for :data:`STALL_STEPS` steps (``guarded_stalled``, e.g. blocked by something else); both
end the attempt with that stage unless the segment says ``on_miss="continue"``. Either way the outcome is
left in ``ctx.memo["guarded/<segment name>"]`` (:class:`GuardedOutcome`) for the skeleton. Everything is
computed from the simulation state: no wall time, no randomness besides the line's IK restarts (drawn from
the attempt's ``plan/<segment name>`` stream).

**Sliding** (``press=`` a world direction, e.g. down; wiping): the TCP travels ``max_distance`` along the
line (towards a target: its part across ``press``) while, along ``press``, the commanded point is offset so
that the pair's normal force tracks the goal between the ``force`` threshold and ``max_force`` (the offset
is corrected by ``(goal - F) / k`` each step, with the stiffness along ``press``, easing off as well as
pressing; above ``max_force`` it falls back to at most the measured TCP). The move starts in contact (after
a guarded press) and must stay in it: :data:`LOST_STEPS` consecutive steps without contact end it as
``guarded_no_contact``; reaching the distance limit is the success. Peaks above ``max_force`` can still
occur while the contact is dynamic (a sponge dragged at the start of a stroke): the bound is what the
regulation aims under, not a clamp.

Example::

    seg = guarded("press", (0, 0, -1), until=force("lid", 5.0), max_distance=0.03, max_force=15.0,
                  gripper="close")
    stroke = guarded("wipe", (1, 0, 0), until=force("tray", 1.0), max_force=4.0, max_distance=0.08,
                     press=(0, 0, -1), gripper="close", attached="sponge")
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING

import mujoco
import numpy as np

from mgdata.episode.gate import AttemptFailed
from mgdata.motion.types import AllowedContacts, Attachment, JointTrajectory, Pose
from mgdata.sim.contact_force import HAND, geom_set, pair_contact
from mgdata.sim.servo import ArmServo

if TYPE_CHECKING:
    from mgdata.skeleton.context import Context
    from mgdata.skeleton.segment import MotionSegment

STALL_STEPS = 40
"""Control steps (2 s at 20 Hz) without :data:`STALL_PROGRESS` of TCP travel that end a move as stalled."""
STALL_PROGRESS = 0.0005
"""TCP travel along the line (m) that counts as progress."""
ARRIVED = 0.001
"""How close (m) the measured TCP must come to the distance limit for the move to have reached it."""
ARRIVE_STEPS = 20
"""Control steps the arm gets to catch up with a commanded point at the distance limit."""
LOST_STEPS = 10
"""Consecutive control steps without contact that end a sliding move (``press``) as lost."""


@dataclass(frozen=True)
class GuardedOutcome:
    """How a guarded move ended.

    Attributes:
        met: the stop condition held.
        stage: ``None`` if met, else ``"guarded_no_contact"`` or ``"guarded_stalled"``.
        distance: measured TCP travel along the line at the stop (m).
        force: the pair's normal force at the stop (N); ``peak_force``: its largest value during the move.
        steps: control steps executed (the final resting step included).
    """

    met: bool
    stage: str | None
    distance: float
    force: float
    peak_force: float
    steps: int


class GuardedMove:
    """One guarded segment, planned from the live state at construction and executed by :meth:`run`.

    Args:
        seg: the guarded segment.
        ctx: the attempt's context (scene, planner, variation, last command).
        target: the resolved target pose (``None`` for a direction).
        attached: the held object's attachment (``None`` if nothing is held).
    """

    def __init__(self, seg: MotionSegment, ctx: Context, target: Pose | None,
                 attached: Attachment | None) -> None:
        assert seg.guard is not None
        self.seg, self.ctx, self.guard = seg, ctx, seg.guard
        scene, planner = ctx.scene, ctx.planner
        self.servo = ArmServo(scene.model)
        q = self.servo.rest_pose(ctx.q_cmd)  # the line starts where the last command brings the arm to rest,
        start = planner.fk(q)                # so the first rest command along it is that command: no jump
        self.origin = start.pos
        if self.guard.direction is not None and self.guard.max_distance is not None:
            direction = np.array(self.guard.direction)
            limit = self.guard.max_distance
        else:
            assert target is not None
            offset = target.pos - start.pos
            if self.guard.press is not None:  # a slide travels across the press direction only
                offset = offset - (offset @ np.array(self.guard.press)) * np.array(self.guard.press)
            if np.linalg.norm(offset) < 1e-6:
                raise AttemptFailed("target_fail", "the guarded move's target is where the TCP already is",
                                    seg.name)
            direction = offset / np.linalg.norm(offset)
            limit = self.guard.max_distance or float(np.linalg.norm(offset))
        self.direction, self.limit = direction, limit
        moving = [HAND, *([seg.attached] if seg.attached else [])]
        allowed = seg.allow + AllowedContacts(tuple((m, self.guard.until.body) for m in moving
                                                    if _is_body(scene.model, self.guard.until.body)))
        planner.sync(scene.data)
        end = Pose(start.pos + direction * limit, start.quat)
        self.line = planner.line(q, end, ctx.variation.rng(f"plan/{seg.name}"), "hold", allowed, attached)
        self.moving = np.logical_or.reduce([geom_set(scene, m) for m in moving])
        self.other = geom_set(scene, self.guard.until.body)

    def _line_q(self, s: float) -> np.ndarray:
        """The line's joint configuration at ``s`` metres along it (linear in between IK waypoints)."""
        return np.array([np.interp(s, self.line.dist, self.line.q[:, j]) for j in range(7)])

    def run(self, step: Callable[[np.ndarray], None]) -> JointTrajectory:
        """Execute the move, calling ``step(q)`` once per control step; returns the commands issued (row 0:
        the command before the move). Raises ``AttemptFailed`` for a miss unless ``on_miss="continue"``."""
        if self.guard.press is not None:
            return self._slide(step)
        ctx, guard, scene = self.ctx, self.guard, self.ctx.scene
        model, data = scene.model, scene.data
        until, fmax = guard.until, guard.max_force
        lc = ctx.planner.config.linear
        dt = scene.physics.control_dt
        vmax = self.seg.speed * lc.speed
        goal = 0.5 * (until.newtons + fmax)
        commands = [ctx.q_cmd.copy()]
        s_cmd = vel = peak = 0.0
        best = -np.inf  # the farthest measured progress so far (the arm may start behind the line's start)
        idle = at_limit = 0
        stage: str | None = None
        while True:
            s_act = float((scene.tcp_pose()[0] - self.origin) @ self.direction)
            touching, newtons = pair_contact(model, data, self.moving, self.other)
            peak = max(peak, newtons)
            if until.met(touching, newtons):
                break
            if s_cmd >= self.limit and (s_act >= self.limit - ARRIVED or at_limit >= ARRIVE_STEPS):
                stage = "guarded_no_contact"
                break
            if idle >= STALL_STEPS:
                stage = "guarded_stalled"
                break
            k = self.servo.stiffness(self._line_q(s_cmd), self.direction)
            if touching:  # pressing towards the force threshold (a touch condition has stopped already)
                s_next = s_act + max(0.0, s_cmd - s_act + (goal - newtons) / k)
            else:
                vel = min(vmax, vel + lc.accel * dt)
                s_next = min(s_cmd + vel * dt, s_act + fmax / k)
            if newtons > fmax:
                s_next = min(s_next, s_act)
            s_cmd = float(np.clip(s_next, 0.0, self.limit))
            q = self.servo.rest_command(self._line_q(s_cmd))
            step(q)
            commands.append(q)
            if s_act > best + STALL_PROGRESS:
                best, idle = s_act, 0
            else:
                idle += 1
            at_limit = at_limit + 1 if s_cmd >= self.limit else 0
        return self._finish(step, commands, stage, s_act, newtons, peak)

    def _finish(self, step: Callable[[np.ndarray], None], commands: list[np.ndarray], stage: str | None,
                s_act: float, newtons: float, peak: float) -> JointTrajectory:
        """Rest where the arm is, record the outcome, fail on a miss unless ``on_miss="continue"``."""
        ctx, guard, scene, until = self.ctx, self.guard, self.ctx.scene, self.guard.until
        dt = scene.physics.control_dt
        rest = self.servo.rest_command(scene.arm_q())
        step(rest)
        commands.append(rest)
        outcome = GuardedOutcome(stage is None, stage, s_act, newtons, peak, len(commands) - 1)
        ctx.memo[f"guarded/{self.seg.name}"] = outcome
        if stage is not None and guard.on_miss == "fail":
            if guard.press is not None:
                raise AttemptFailed(stage, f"moved {s_act * 1000:.1f} mm of {self.limit * 1000:.1f} mm and "
                                    f"lost contact with {until.body!r} for {LOST_STEPS} steps", self.seg.name)
            what = f"touching {until.body!r}" if until.kind == "touch" else \
                f"pressing on {until.body!r} with {until.newtons:g} N (reached {peak:.1f} N)"
            where = ("reached its distance limit" if stage == "guarded_no_contact"
                     else f"stopped advancing for {STALL_STEPS} steps")
            raise AttemptFailed(stage, f"moved {s_act * 1000:.1f} mm of {self.limit * 1000:.1f} mm and "
                                f"{where} without {what}", self.seg.name)
        rate = 1.0 / dt
        return JointTrajectory(np.array(commands), rate, (len(commands) - 1) / rate)

    def _slide(self, step: Callable[[np.ndarray], None]) -> JointTrajectory:
        """A sliding move: along the line to the distance limit, the force along ``press`` regulated."""
        ctx, guard, scene = self.ctx, self.guard, self.ctx.scene
        model, data = scene.model, scene.data
        assert guard.press is not None
        press, fmax = np.array(guard.press), guard.max_force
        lc = ctx.planner.config.linear
        dt = scene.physics.control_dt
        vmax = self.seg.speed * lc.speed
        goal = 0.5 * (guard.until.newtons + fmax)
        commands = [ctx.q_cmd.copy()]
        s_cmd = vel = peak = d_cmd = 0.0
        lost = at_limit = 0
        stage: str | None = None
        while True:
            offset = scene.tcp_pose()[0] - self.origin
            s_act, d_act = float(offset @ self.direction), float(offset @ press)
            touching, newtons = pair_contact(model, data, self.moving, self.other)
            peak = max(peak, newtons)
            lost = 0 if touching else lost + 1
            if lost >= LOST_STEPS:
                stage = "guarded_no_contact"
                break
            if s_cmd >= self.limit and (s_act >= self.limit - ARRIVED or at_limit >= ARRIVE_STEPS):
                break
            q_line = self._line_q(s_cmd)
            k = self.servo.stiffness(q_line, press)
            d_cmd = d_cmd + (goal - newtons) / k  # both ways: a slide eases off as well as presses
            if newtons > fmax:
                d_cmd = min(d_cmd, d_act)
            vel = min(vmax, vel + lc.accel * dt)
            s_cmd = min(s_cmd + vel * dt, self.limit)
            q = self.servo.rest_command(self.servo.displace(self._line_q(s_cmd), press * d_cmd))
            step(q)
            commands.append(q)
            at_limit = at_limit + 1 if s_cmd >= self.limit else 0
        return self._finish(step, commands, stage, s_act, newtons, peak)


def _is_body(model: mujoco.MjModel, name: str) -> bool:
    return mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, name) >= 0
