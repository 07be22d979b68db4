"""Executor: plan → execute → monitor → gate → record, one attempt at a time, for one task.

Per attempt: reset the scene to the task's initial state; draw the variation from (family, task, draw, seed);
for each segment of the skeleton resolve its target, plan it (IK + OMPL + toppra, a straight line, a reversal
or a pause) from the last commanded configuration, and execute it at 20 Hz, labelling, monitoring and
recording every control step; after the last segment hold still for up to ``settle_steps``. The steps after
the last motion segment (the final ``hold`` segments and the settling steps: the arm commanded still) are
the *holding* steps. The attempt ends

* as **kept** once success (the goal predicate ∧ the goal's objects at rest, the recorded success column)
  has held on ``hold_steps`` consecutive holding steps, with no violation at any step
  (:mod:`mgdata.episode.gate`); the episode then ends with that hold;
* as ``unsafe`` at the first step the monitor reports a violation (before engagement too);
* as ``timeout`` at the family's step horizon, or with the failure stage of a planning step, a runtime target
  or ``goal_not_reached``.

Example::

    ex = Executor(task, recipe, grasps=GraspDB.load_dir(grasps_dir()))
    result = ex.run(draw=0, sink=MemorySink())
    result.kept, result.stage, result.meta.t_engage
    ex.close()
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from dataclasses import dataclass
from types import MappingProxyType
from typing import Any

import numpy as np

from mgdata.engine.guarded import GuardedMove
from mgdata.engine.perturbation import Perturbation
from mgdata.engine.restart import check_restart
from mgdata.episode.gate import AttemptFailed, SuccessGate
from mgdata.episode.runner import EpisodeRunner
from mgdata.episode.success import SuccessCheck
from mgdata.episode.timing import Timings
from mgdata.errors import RecipeError, SimulationError
from mgdata.grasps.db import GraspDB
from mgdata.motion import (
    AllowedContacts,
    Attachment,
    JointTrajectory,
    MotionConfig,
    MotionFailure,
    MotionPlanner,
    Pose,
    load_motion_config,
)
from mgdata.record.episode import DatasetSchema, EpisodeMeta, EpisodeSink, Frame
from mgdata.record.physics import set_physics_state, state_size
from mgdata.record.recorder import Recorder
from mgdata.sim.config import load_sim_config
from mgdata.sim.controller import JointController
from mgdata.sim.labelling import Labeller
from mgdata.sim.physics_config import Physics
from mgdata.sim.renderer import CameraRig
from mgdata.sim.robot import ROOT_BODY
from mgdata.sim.scene import Scene, build_scene
from mgdata.sim.taskspec import TaskSpec
from mgdata.skeleton.context import Context
from mgdata.skeleton.phase import Phase, flatten, remaining
from mgdata.skeleton.segment import MotionSegment
from mgdata.skeleton.skeleton import FamilySkeleton, Infeasible, skeleton_for
from mgdata.skeleton.variation import draw_variation
from mgdata.spec import SafetySpec
from mgdata.tasks.base import draw_task
from mgdata.tasks.placer import LayoutRejected
from mgdata.tasks.recipe import Recipe

_MOTION_STAGES = {"start_invalid": "plan_fail"}


@dataclass(frozen=True)
class AttemptResult:
    """The outcome of one attempt.

    Attributes:
        task_id, draw, seed: which attempt this was.
        kept: the gate accepted it (success held at rest after the motion, no violation).
        stage, reason, segment: why it failed (``None`` when kept).
        steps: control steps (actions) executed; the episode has ``steps + 1`` frames.
        verdict: the safety verdict ν; ``t_engage``/``t_violation``: first engagement / violation step
            (per constraint), ``None`` for never.
        grasp_id: the grasp the skeleton chose, if any.
        meta: the episode metadata if the episode was recorded to the sink, else ``None``.
        timings: seconds per phase.
    """

    task_id: int
    draw: int
    seed: int
    kept: bool
    stage: str | None
    reason: str | None
    segment: str | None
    steps: int
    verdict: bool
    t_engage: int | None
    t_violation: dict[str, int | None]
    grasp_id: str | None
    meta: EpisodeMeta | None
    timings: Timings


class _GatePassed(Exception):
    """Internal: success held at rest for the gate's window after the motion; stop executing."""


class _TimedSink:
    """Forwards to a sink, timing ``add_frame`` as encoding and ``end_episode`` as writing."""

    def __init__(self, sink: EpisodeSink, timings: Timings) -> None:
        self.sink, self.timings = sink, timings

    def set_scene(self, mjb: bytes) -> None:
        self.sink.set_scene(mjb)

    def add_frame(self, frame: Frame) -> None:
        with self.timings.measure("encoding"):
            self.sink.add_frame(frame)

    def end_episode(self, meta: EpisodeMeta) -> None:
        with self.timings.measure("writing"):
            self.sink.end_episode(meta)

    def discard_episode(self) -> None:
        self.sink.discard_episode()


def slowed(traj: JointTrajectory, speed: float) -> JointTrajectory:
    """``traj`` played at ``speed`` (≤ 1) of its pace, resampled at its rate by linear interpolation.

    Linear interpolation between consecutive samples stays on the segments the planner re-checked.
    """
    if speed >= 1.0 or len(traj) < 2:
        return traj
    duration = traj.duration / speed
    n = int(np.ceil(duration * traj.rate - 1e-9)) + 1
    t = np.minimum(np.arange(n) / traj.rate, duration) * speed
    q = np.stack([np.interp(t, traj.times, traj.q[:, j]) for j in range(7)], axis=1)
    q[-1] = traj.q[-1]
    return JointTrajectory(q, traj.rate, duration)


def control_rate(physics: Physics, motion: MotionConfig) -> int:
    """The control and recording rate (Hz), ``recipes/sim.toml`` ``[physics] control_dt``; the planner's
    trajectory samples (``recipes/motion.toml`` ``[retime] rate``) must come at the same rate."""
    fps = round(1.0 / physics.control_dt)
    if abs(fps * physics.control_dt - 1.0) > 1e-9:
        raise RecipeError(f"recipes/sim.toml [physics] control_dt = {physics.control_dt!r}: expected the "
                          "period of a whole number of Hz (the dataset's fps)")
    if abs(motion.retime.rate - fps) > 1e-9:
        raise RecipeError(f"recipes/motion.toml [retime] rate = {motion.retime.rate!r} Hz does not match "
                          f"the control rate of recipes/sim.toml ([physics] control_dt = "
                          f"{physics.control_dt!r} s, {fps} Hz)")
    return fps


def dataset_schema(recipe: Recipe) -> DatasetSchema:
    """The dataset schema every episode of a family's generation run shares (the physics-state width is
    task 0's: every task of a family has the same MuJoCo state size)."""
    size = recipe.tasks.image_size if recipe.tasks.cameras else 0  # no cameras: a state-only dataset
    fps = control_rate(load_sim_config().physics, load_motion_config())
    return DatasetSchema(fps=fps, cameras=recipe.tasks.cameras, image_height=size, image_width=size,
                         propositions=recipe.spec.proposition_names,
                         constraints=tuple(c.id for c in recipe.spec.constraints),
                         physics_state_size=state_size(build_scene(_first_layout(recipe)).model),
                         executed_action=recipe.recovery.perturbs)


def _first_layout(recipe: Recipe) -> TaskSpec:
    """Task 0's first draw that meets the layout rules (its scene gives the family's state width)."""
    for draw in range(recipe.tasks.max_draws):
        try:
            return draw_task(recipe, 0, draw)
        except LayoutRejected as why:
            last = why
    raise RecipeError(f"{recipe.path}: no draw of task 0 meets the layout rules in {recipe.tasks.max_draws} "
                      f"draws (the last: {last})")


class Executor:
    """Runs attempts of one task; the scene, planner and renderer are built once and reset per attempt.

    Args:
        task: the task to demonstrate.
        recipe: its family recipe (gate, horizon, variation knobs, success predicate).
        grasps: the grasp database (the valid grasps of the task's object models go to the skeleton).
        motion: motion tunables (default: ``recipes/motion.toml``).
        base_seed: the user seed mixed into every attempt seed.
        render: record camera images (off for quick planning-only runs and grasp checks).
    """

    def __init__(self, task: TaskSpec, recipe: Recipe, *, grasps: GraspDB,
                 motion: MotionConfig | None = None, base_seed: int = 0, render: bool = True) -> None:
        self.task, self.recipe, self.base_seed = task, recipe, base_seed
        self.skeleton: FamilySkeleton = skeleton_for(recipe.skeleton)
        self.scene: Scene = build_scene(task)
        self.controller = JointController(self.scene)
        motion = motion or load_motion_config()
        control_rate(self.scene.physics, motion)
        self.planner = MotionPlanner(self.scene.model, motion)
        self.cameras = CameraRig(self.scene, recipe.tasks.cameras, task.image_size) \
            if render and recipe.tasks.cameras else None
        self._success = SuccessCheck(self.controller, recipe)
        self.perturbation = Perturbation(recipe.recovery) if recipe.recovery.perturbs else None
        self.grasps = {o.name: grasps.grasps(o.model, status="valid") for o in task.objects
                       if o.model in grasps.objects}

    def use_controller(self, controller: JointController) -> None:
        """Step later attempts through ``controller`` (a probe subclassing :class:`JointController`, as the
        tests use), watched by the success check's rest test as the executor's own was."""
        self.controller = controller
        controller.watch(self._success.rest)

    def close(self) -> None:
        """Free the renderer (idempotent)."""
        if self.cameras is not None:
            self.cameras.close()
            self.cameras = None

    # -- one attempt ---------------------------------------------------------------------------------------
    def run(self, draw: int, sink: EpisodeSink, *, keep_failed: bool = False, start: np.ndarray | None = None,
            origin: Mapping[str, Any] | None = None, source: str = "planner") -> AttemptResult:
        """Run attempt ``draw``; the episode goes to ``sink`` if kept (or always, with ``keep_failed``).

        ``start``: a physics state (``sim.physics_state`` layout) to start from instead of the task's
        initial state: a restart (:mod:`mgdata.engine.restart`), refused (stage ``restart_refused``) where
        its rules fail, else running the phases not done there. ``origin`` is recorded as the episode's
        ``variation.restart`` (e.g. the parent rollout and step), ``source`` as its ``mgdata/source``."""
        task, settings = self.task, self.recipe.tasks
        var = draw_variation(task.family, task.task_id, draw, self.base_seed, self.recipe.variation)
        timings = Timings()
        self.scene.reset()
        refusal: Infeasible | None = None
        if start is not None:
            with timings.measure("planning"):
                refusal, task = self._restart(start)
        self.planner.sync(self.scene.data)
        ctx = Context(task, self.scene, self.planner, var, self.grasps, self.scene.arm_q())
        gate = SuccessGate(settings.hold_steps)
        recorder = Recorder(self.scene, task.safety, _TimedSink(sink, timings), self.cameras,
                            lambda scene: self._success(lambda: self.skeleton.success_extra(ctx)))
        runner = EpisodeRunner(self.controller, recorder, gate, settings.horizon, timings,
                               max_penetration=settings.max_penetration)
        state = _Run(ctx, runner)
        stage = reason = segment = None
        if self.perturbation is not None:
            self.perturbation.reset()
        runner.start()
        phases: list[Phase] = []
        try:
            if refusal is not None:
                raise AttemptFailed("restart_refused", str(refusal))
            if start is None:
                segments = list(self.skeleton.segments(ctx))
            else:
                phases = remaining(self.skeleton.phases(ctx), self._holds)
                segments = flatten(phases)
            last_motion = max((i for i, seg in enumerate(segments) if seg.kind != "hold"), default=-1)
            for i, seg in enumerate(segments):
                segment = seg.name
                state.holding, state.index = i > last_motion, i
                self._segment(seg, ctx, state)
            segment, state.holding = "settle", True
            for _ in range(settings.settle_steps):
                self._step(ctx.q_cmd, runner.grip, state)
            raise AttemptFailed("goal_not_reached", f"success held at rest for at most {gate.best} "
                                f"consecutive steps after the motion ended, {settings.settle_steps} settling "
                                f"steps included (needs {gate.hold_steps})")
        except _GatePassed:
            segment = None
        except AttemptFailed as fail:
            stage, reason = fail.stage, fail.reason
            segment = fail.segment or segment
        except MotionFailure as fail:
            stage, reason = _MOTION_STAGES.get(fail.stage, fail.stage), fail.reason
        except SimulationError as fail:
            stage, reason = "sim_diverged", str(fail)
        ok, kept = runner.verdict, stage is None and runner.kept
        meta, grasp_id = None, ctx.memo.get("grasp_id")
        t_engage, t_violation = recorder.t_engage, recorder.first_violation
        if kept or keep_failed:
            variation = var.as_meta()
            if start is not None:
                variation["restart"] = {**(origin or {}), "phases": [p.name for p in phases]}
            if self.perturbation is not None:
                variation["perturbation"] = self.perturbation.as_meta()
            meta = recorder.finish(seed=var.seed, draw_index=draw, kept=kept, success=gate.passed,
                                   failure_stage=stage, failure_reason=reason, grasp_id=grasp_id,
                                   variation=variation, source=source)
        else:
            recorder.discard()
        return AttemptResult(task.task_id, draw, var.seed, kept, stage, reason, segment, runner.steps, ok,
                             t_engage, t_violation, grasp_id, meta, timings)

    def _restart(self, start: np.ndarray) -> tuple[Infeasible | None, TaskSpec]:
        """Set the scene to ``start`` and check the restart rules there; the refusal (or ``None``) and the
        task with the restart state's feasibility facts."""
        model, data = self.scene.model, self.scene.data
        if np.shape(start) != (state_size(model),):
            raise SimulationError(f"a restart state has {np.size(start)} numbers, this scene's physics state "
                                  f"{state_size(model)}")
        set_physics_state(model, data, start)
        try:
            facts = check_restart(self.scene, self.recipe, self.skeleton, self.planner, self.grasps)
        except Infeasible as why:
            return why, self.task
        finally:
            set_physics_state(model, data, start)  # start exactly there, whatever the checks computed
        return None, dataclasses.replace(self.task, gate=MappingProxyType({**self.task.gate, **facts}))

    def _holds(self, name: str) -> bool:
        """Whether the recipe's proposition ``name`` (a phase's postcondition) holds in the current state."""
        props = {p.name: p for p in (*self.recipe.spec.propositions, *self.recipe.success)}
        if name not in props:
            raise RecipeError(f"skeleton {self.skeleton.name!r}: a phase is done when {name!r} holds, which "
                              f"is not a proposition of {self.recipe.path} (nor of its spec)")
        return bool(Labeller(self.scene, SafetySpec(f"phase_{name}", (), (props[name],))).labels()[0])

    # -- segments ------------------------------------------------------------------------------------------
    def _segment(self, seg: MotionSegment, ctx: Context, state: _Run) -> None:
        grip = 1.0 if seg.gripper == "close" else 0.0
        if seg.kind in ("gripper", "hold"):
            for _ in range(seg.steps):
                self._step(ctx.q_cmd, grip, state)
            ctx.executed[seg.name] = JointTrajectory(ctx.q_cmd[None], 20.0, 0.0)
            return
        if seg.kind == "guarded":
            move = self._guarded(seg, ctx, state.runner.timings)
            ctx.executed[seg.name] = move.run(lambda q: self._step(q, grip, state))
            return
        with state.runner.timings.measure("planning"):
            traj = slowed(self._plan(seg, ctx), seg.speed)
        pert, targets = self.perturbation, traj.q[1:]
        mode = pert.settings.mode if pert is not None else "off"
        if pert is not None and mode == "dart":  # the plan plus a smooth offset; the actions stay the plan's
            rng = ctx.variation.rng(f"perturb/{state.index}/{seg.name}")
            offsets = pert.segment(state.index, seg.name, rng, len(targets), state.runner.steps)
            for q, dq in zip(targets, offsets, strict=True):
                self._step(q, grip, state, q + dq)
        elif pert is not None and mode == "replan" and seg.kind != "reverse" \
                and len(targets) >= 3 * pert.settings.push_steps:  # a reversal retraces its segment unpushed
            traj = self._push_and_replan(seg, ctx, state, traj, grip)
        else:
            for q in targets:
                self._step(q, grip, state)
        ctx.executed[seg.name] = traj

    def _push_and_replan(self, seg: MotionSegment, ctx: Context, state: _Run, traj: JointTrajectory,
                         grip: float) -> JointTrajectory:
        """Execute ``traj`` up to a drawn step, push the arm's targets off it (the actions stay the plan's),
        then plan the rest of the segment again from the pushed configuration and execute that; returns
        the replanned trajectory (what a later reversal of the segment retraces)."""
        assert self.perturbation is not None
        rng = ctx.variation.rng(f"perturb/{state.index}/{seg.name}")
        targets = traj.q[1:]
        k0, offsets = self.perturbation.push(state.index, seg.name, rng, len(targets), state.runner.steps)
        for q in targets[:k0]:
            self._step(q, grip, state)
        for q, dq in zip(targets[k0:k0 + len(offsets)], offsets, strict=True):
            self._step(q, grip, state, q + dq)
        pushed = targets[k0 + len(offsets) - 1] + offsets[-1]
        with state.runner.timings.measure("planning"):
            rest = slowed(self._plan(seg, ctx, start=pushed, goal=traj.q[-1]), seg.speed)
        self.perturbation.replanned(len(rest.q) - 1)
        for q in rest.q[1:]:
            self._step(q, grip, state)
        return rest

    def _plan(self, seg: MotionSegment, ctx: Context, start: np.ndarray | None = None,
              goal: np.ndarray | None = None) -> JointTrajectory:
        """Plan ``seg`` from the last command (or ``start``); a free segment to its target's IK solution
        (or the configuration ``goal``)."""
        planner = self.planner
        planner.sync(self.scene.data)
        q_start = ctx.q_cmd if start is None else start
        if seg.kind == "reverse":
            if seg.of not in ctx.executed:
                raise AttemptFailed("target_fail", f"reverse of {seg.of!r}, which has not run yet", seg.name)
            traj = planner.reverse(ctx.executed[seg.of])
            if np.max(np.abs(traj.start - ctx.q_cmd)) > 1e-6:
                raise AttemptFailed("path_discontinuity", f"segment {seg.of!r} ended elsewhere than the arm "
                                    "is now; only the last motion can be reversed", seg.name)
            return traj
        target = self._target(seg, ctx)
        riders = tuple(b for r in seg.riders for b in self.scene.loose_bodies(r))
        allowed = seg.allow + AllowedContacts(tuple((ROOT_BODY, b) for b in riders))
        attached = self._attachment(seg.attached, riders) if seg.attached else None
        rng = ctx.variation.rng(f"plan/{seg.name}" if start is None else f"replan/{seg.name}")
        if seg.kind == "linear":
            return planner.linear(q_start, target, rng, orientation=seg.orientation, allowed=allowed,
                                  attached=attached)
        if goal is None:
            seed = ctx.q_hints.get(seg.target, ctx.q_cmd) if isinstance(seg.target, str) else ctx.q_cmd
            goal = planner.ik(target, seed, rng, collision_free=True, allowed=allowed, attached=attached)
        return planner.free(q_start, goal, rng, allowed=allowed, attached=attached)

    def _guarded(self, seg: MotionSegment, ctx: Context, timings: Timings) -> GuardedMove:
        """Plan a guarded segment (its line from the live state); :mod:`mgdata.engine.guarded` runs it."""
        target = self._target(seg, ctx) if seg.target is not None else None
        attached = self._attachment(seg.attached, ()) if seg.attached else None
        with timings.measure("planning"):
            return GuardedMove(seg, ctx, target, attached)

    def _target(self, seg: MotionSegment, ctx: Context) -> Pose:
        if isinstance(seg.target, Pose):
            return seg.target
        try:
            return self.skeleton.resolve(str(seg.target), ctx)
        except AttemptFailed:
            raise
        except KeyError as err:
            raise AttemptFailed("target_fail", str(err), seg.name) from None

    def _attachment(self, body: str, riders: tuple[str, ...]) -> Attachment:
        """The held object's pose in the TCP frame, measured from the live state, with its riders."""
        tcp = Pose.from_pos_mat(*self.scene.tcp_pose())
        obj = Pose.from_pos_mat(*self.scene.object_pose(body))
        return Attachment(body, (tcp.inverse() @ obj).matrix(), riders=riders)

    # -- one control step ----------------------------------------------------------------------------------
    def _step(self, q: np.ndarray, grip: float, state: _Run, command: np.ndarray | None = None) -> None:
        """One control step towards the plan's ``q`` (the recorded action); ``command``: the arm targets
        executed instead (a perturbed demonstration)."""
        out = state.runner.step(q, grip, state.holding, command)
        state.ctx.q_cmd = state.runner.q_cmd
        if out.end in ("unsafe", "penetration"):
            raise AttemptFailed(out.end, str(out.reason))
        if out.end == "passed":
            raise _GatePassed
        if out.end == "timeout":
            raise AttemptFailed("timeout", str(out.reason))


@dataclass
class _Run:
    """Mutable per-attempt state of the executor loop: the context, the runner and whether the motion has
    ended (only holding steps count towards the gate) and the index of the segment being executed."""

    ctx: Context
    runner: EpisodeRunner
    holding: bool = False
    index: int = 0
