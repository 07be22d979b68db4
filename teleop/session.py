"""The teleop session: a leader arm drives the Panda in a task scene, episodes go through the generator's
recorder, monitor and gate into the same LeRobot dataset (``source = gello|so101``).

One control loop at the dataset rate (20 Hz, paced on the monotonic clock) takes the newest leader reading
(the :class:`~teleop.reader.LeaderReader` process reads at ≥ 100 Hz), maps it to an action and steps an
:class:`~mgdata.episode.runner.EpisodeRunner`. Operator commands (browser buttons or terminal keys) are queued
and applied at the top of a step:

* ``record``: reset the task to its initial state and start an episode;
* ``stop``: end the episode now (kept only if the gate has passed);
* ``done``: stop following the leader and hold the arm still for the recipe's ``settle_steps``, giving the
  gate its window, then end;
* ``discard``: drop the episode; ``reset``: drop it and restore the task's initial state; ``quit``;
* ``clutch`` (SO-101: re-anchor) and ``grip`` (gripper toggle on a GELLO without a trigger).

An episode also ends by itself, as a generated attempt does: at the first violation (``unsafe``), when the
gate passes (kept), or at the family's horizon (``timeout``). Kept episodes go to ``out``; others to
``<out>_failed`` with ``keep_failed``, labelled with their failure stage; otherwise they are dropped. The
raw leader stream of each stored episode goes beside it (:mod:`teleop.stream`), in the episode's own
commit, and
:meth:`TeleopSession.replay` re-simulates an episode from it, byte for byte.
"""

from __future__ import annotations

import os
import queue
import shutil
import sys
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from mgdata.engine.executor import dataset_schema
from mgdata.engine.init_gate import base_task
from mgdata.episode.gate import SuccessGate
from mgdata.episode.runner import EpisodeRunner, StepOutcome
from mgdata.episode.success import SuccessCheck, physics_gate
from mgdata.errors import RecipeError, SimulationError
from mgdata.generate.run import failed_path
from mgdata.record.commit import work_dir
from mgdata.record.episode import EpisodeMeta, Frame
from mgdata.record.recorder import Recorder
from mgdata.record.staging import EpisodeStager
from mgdata.record.writer import DatasetWriter
from mgdata.sim.controller import JointController
from mgdata.sim.renderer import CameraRig
from mgdata.sim.scene import build_scene
from mgdata.skeleton.skeleton import load_family_recipe
from mgdata.teleop.config import load_teleop_config
from mgdata.teleop.mapping import Mapper, StepEvents
from mgdata.teleop.priority import realtime
from mgdata.teleop.reader import LeaderReader
from mgdata.teleop.stream import LeaderStream, stream_rel

SWITCH_S = 0.001
"""The interpreter's thread switch interval during a live session (s; Python's default is 5 ms)."""

COMMANDS = ("record", "stop", "done", "discard", "reset", "quit", "clutch", "grip")


@dataclass(frozen=True)
class SessionJob:
    """The session's settings (the CLI's options).

    Attributes:
        arm: ``gello`` or ``so101``; family, task: the task to demonstrate; out: the dataset.
        keep_failed: also store failed/unsafe episodes, in ``<out>_failed``.
        episodes: stop after this many finished episodes, stored or not (``None``: until ``quit``).
        autostart: start recording at once and after each episode (scripted sessions).
        codec: video codec of a new dataset.
    """

    arm: str
    family: str
    task: int
    out: Path
    keep_failed: bool = False
    episodes: int | None = None
    autostart: bool = False
    codec: str = "h264"


@dataclass
class SessionStatus:
    """What the operator view shows after each control step."""

    step: int = 0
    recording: bool = False
    settling: bool = False
    clutch_out: bool = False  # the robot holds while the operator repositions the leader (SO-101)
    constraints: tuple[str, ...] = ()
    formulas: tuple[str, ...] = ()
    violated: tuple[bool, ...] = ()
    dfa_state: tuple[int, ...] = ()
    first_violation: str | None = None
    engaged: bool = False
    success: bool = False
    streak: int = 0
    hold_steps: int = 10
    message: str = "press Record to start an episode"
    kept: int = 0
    failed: int = 0
    images: dict[str, np.ndarray] = field(default_factory=dict)
    sent_at: float = 0.0  # wall clock (time.time) when the step finished


@dataclass
class _Episode:
    stager: EpisodeStager
    draw: int
    samples: list[int] = field(default_factory=list)
    clutch: list[bool] = field(default_factory=list)
    grip: list[bool] = field(default_factory=list)
    settle_left: int | None = None


class TeleopSession:
    """Runs a session (see the module docstring).

    Args:
        job: the settings.
        mapper: the arm's reading → action mapping.
        calibration: the calibration file's text (stored with every leader stream).
        reader: the live leader (``None`` for :meth:`replay` only).
        on_status: called with the :class:`SessionStatus` after every control step (the operator view).
        on_step: called with the step count after every control step (a scripted leader's clock).
    """

    def __init__(self, job: SessionJob, mapper: Mapper, calibration: str, reader: LeaderReader | None = None,
                 on_status: Callable[[SessionStatus], None] | None = None,
                 on_step: Callable[[int], None] | None = None) -> None:
        if job.arm != mapper.arm:
            raise RecipeError(f"--arm {job.arm} does not match the calibration file (a {mapper.arm} device)")
        self.job, self.mapper, self.calibration, self.reader = job, mapper, calibration, reader
        self.on_status, self.on_step = on_status, on_step
        self.recipe = load_family_recipe(job.family)
        if not 0 <= job.task < self.recipe.tasks.count:
            raise RecipeError(f"--task {job.task}: the {job.family} recipe has tasks 0 … "
                              f"{self.recipe.tasks.count - 1}")
        self.task = base_task(self.recipe, job.task)
        self.scene = build_scene(self.task)
        self.controller = JointController(self.scene)
        self.dt = self.scene.physics.control_dt
        self.cameras = CameraRig(self.scene, self.recipe.tasks.cameras, self.task.image_size)
        success = SuccessCheck(self.controller, self.recipe)
        config = load_teleop_config()
        self.still_joint_step = config.leader.still_joint_step
        self.realtime_priority = config.loop.realtime_priority
        schema = dataset_schema(self.recipe)
        hold = self.recipe.tasks.hold_steps
        bounds = {"physics_gate": physics_gate(self.recipe).to_info()}
        self.writer = DatasetWriter.open_or_create(job.out, schema, codec=job.codec, spec=self.recipe.spec,
                                                   hold_steps=hold, kept_only=True, mgdata=bounds)
        self.failed: DatasetWriter | None = None
        if job.keep_failed:
            self.failed = DatasetWriter.open_or_create(failed_path(job.out), schema, codec=job.codec,
                                                       spec=self.recipe.spec, hold_steps=hold, mgdata=bounds)
        self.stage_dir = work_dir(job.out) / "staging" / f"teleop-{os.getpid()}"
        self.recorder = Recorder(self.scene, self.task.safety, _NoSink(), self.cameras,
                                 lambda scene: success())
        self.runner = EpisodeRunner(self.controller, self.recorder, SuccessGate(self.recipe.tasks.hold_steps),
                                    self.recipe.tasks.horizon,
                                    max_penetration=self.recipe.tasks.max_penetration)
        self.commands: queue.Queue[str] = queue.Queue()
        self.status = SessionStatus(constraints=tuple(c.id for c in self.task.safety.constraints),
                                    formulas=tuple(c.formula for c in self.task.safety.constraints),
                                    hold_steps=self.recipe.tasks.hold_steps)
        self.episode: _Episode | None = None
        self.stored: list[tuple[bool, int]] = []  # (kept, episode index) per stored episode
        self.finished = 0  # episodes ended by the gate, the horizon or the operator (stored or not)
        self.step_times: list[float] = []  # monotonic start time of every control step (for jitter)
        self.step_due: list[float] = []  # when each of those steps was due on the absolute schedule
        self.step_busy: list[float] = []  # s each of those steps took (commands, leader, step, publish)
        self.skipped = 0  # schedule slots dropped after an overrun of more than a period
        self._pending = StepEvents()
        self._quit = False
        self._replaying: LeaderStream | None = None
        self.scene.reset()

    # -- live loop -----------------------------------------------------------------------------------------
    def command(self, name: str) -> None:
        """Queue an operator command (thread-safe; see :data:`COMMANDS`)."""
        if name not in COMMANDS:
            raise ValueError(f"unknown command {name!r}")
        self.commands.put(name)

    def run(self) -> None:
        """The live loop at the control rate until ``quit`` or ``job.episodes`` finished episodes.

        Steps start on an absolute schedule ``t0 + k·dt`` (no drift; a late step is followed at once by the
        next one on time). A step more than one period behind skips the missed slots instead of bursting
        through them. While the loop runs the interpreter hands the GIL over every ``SWITCH_S`` so the
        control thread is not held up by the operator view's Python code; with ``[loop] realtime_priority``
        the process's threads and the leader reader's process run ``SCHED_FIFO`` (:mod:`teleop.priority`).
        """
        if self.reader is None:
            raise RecipeError("a live session needs a leader")
        switch = sys.getswitchinterval()
        sys.setswitchinterval(SWITCH_S)
        try:
            with realtime(self.realtime_priority, helpers=(self.reader.pid,)):
                self._loop()
        finally:
            sys.setswitchinterval(switch)
            self.close()

    def _loop(self) -> None:
        """Steps on the absolute schedule until quit (see :meth:`run`)."""
        t0, k = time.monotonic(), 0
        while not self._quit:
            due = t0 + k * self.dt
            now = time.monotonic()
            if now < due:
                time.sleep(due - now)
            elif now - due > self.dt:  # more than a period behind: drop the missed slots
                skip = int((now - due) / self.dt)
                k += skip
                self.skipped += skip
                due = t0 + k * self.dt
            start = time.monotonic()
            self.step_times.append(start)
            self.step_due.append(due)
            self._tick()
            self.step_busy.append(time.monotonic() - start)
            k += 1

    def _tick(self) -> None:
        self._apply_commands()
        if self._quit:
            return
        if self.episode is None and self.job.autostart:
            self._begin()
        if self.episode is not None:
            if self.episode.settle_left is None:
                assert self.reader is not None
                sample, ticks = self.reader.latest()
                self._step(sample, ticks)
            else:
                self._step(-1, None)
        self._publish()

    def _apply_commands(self) -> None:
        while True:
            try:
                name = self.commands.get_nowait()
            except queue.Empty:
                return
            ep = self.episode
            if name == "quit":
                if ep is not None:
                    self._drop("quit")
                self._quit = True
                return
            if name == "record" and ep is None:
                self._begin()
            elif name == "stop" and ep is not None:
                self._end(None, None)
            elif name == "done" and ep is not None and ep.settle_left is None:
                ep.settle_left = self.recipe.tasks.settle_steps
                self.status.message = "holding still for the gate"
            elif name in ("discard", "reset") and ep is not None:
                self._drop(name)
            if name == "reset":
                self.scene.reset()
            elif name == "clutch":
                self._pending = StepEvents(clutch=True, grip_toggle=self._pending.grip_toggle)
            elif name == "grip":
                self._pending = StepEvents(clutch=self._pending.clutch,
                                           grip_toggle=not self._pending.grip_toggle)

    # -- one episode -----------------------------------------------------------------------------------------
    def _draw_index(self) -> int:
        metas = self.writer.episodes_meta() + (self.failed.episodes_meta() if self.failed else [])
        return sum(1 for m in metas if m.task_id == self.job.task and m.source == self.job.arm)

    def _begin(self, draw: int | None = None) -> None:
        self.scene.reset()
        self.mapper.reset(self.scene.arm_q())
        shutil.rmtree(self.stage_dir, ignore_errors=True)
        stager = self.writer.stager(self.stage_dir / "episode")
        self.recorder.sink = _Tap(stager, self.status)
        self.episode = _Episode(stager, self._draw_index() if draw is None else draw)
        self._pending = StepEvents()
        self.runner.start()
        if self.reader is not None:
            self.reader.start_log()
        self.status.first_violation = None
        self.status.message = "recording"

    def _step(self, sample: int, ticks: np.ndarray | None) -> StepOutcome | None:
        ep = self.episode
        assert ep is not None
        events, self._pending = self._pending, StepEvents()
        if ticks is None:
            q, grip = self.runner.q_cmd, self.runner.grip
        else:
            q, grip = self.mapper.command(ticks, events)
        self.status.clutch_out = not self.mapper.engaged
        ep.samples.append(sample)
        ep.clutch.append(events.clutch)
        ep.grip.append(events.grip_toggle)
        try:
            still = (float(np.max(np.abs(np.asarray(q) - self.runner.q_cmd))) <= self.still_joint_step
                     and grip == self.runner.grip)
            out = self.runner.step(q, grip, holding=still)
        except SimulationError as err:
            self._end("sim_diverged", str(err))
            return None
        self.status.violated = tuple(bool(v) for v in out.monitor.violated)
        self.status.dfa_state = tuple(int(v) for v in out.monitor.dfa_state)
        if out.end == "unsafe" and self.status.first_violation is None:
            self.status.first_violation = out.reason
        self.status.engaged, self.status.success = out.engaged, out.success
        self.status.streak = self.runner.gate.streak
        if self.on_step is not None:
            self.on_step(self.runner.steps)
        if out.end == "passed":
            self._end(None, None)
        elif out.end is not None:
            self._end(out.end, out.reason)
        elif ep.settle_left is not None:
            ep.settle_left -= 1
            if ep.settle_left <= 0:
                self._end(None, None)
        return out

    def _end(self, stage: str | None, reason: str | None) -> None:
        """Finish the episode: commit it where it belongs, with its leader stream."""
        ep = self.episode
        assert ep is not None
        self.episode = None
        meta = self.runner.finish(seed=0, draw_index=ep.draw, source=self.job.arm, stage=stage, reason=reason)
        if self._replaying is not None:
            self._store(meta.kept, ep.stager.path, self._replaying)
            self._replaying = None
            return
        assert self.reader is not None
        times, ticks = self.reader.take_log()
        stream = LeaderStream(self.job.arm, self.calibration, self.job.family, self.job.task, ep.draw,
                              times, ticks.astype(np.int64), np.asarray(ep.samples, dtype=np.int64),
                              np.asarray(ep.clutch, dtype=bool), np.asarray(ep.grip, dtype=bool))
        self._store(meta.kept, ep.stager.path, stream)
        what = "kept" if meta.kept else f"{meta.failure_stage}: {meta.failure_reason}"
        self.status.message = f"episode ended ({what})"
        self.finished += 1
        if self.job.episodes is not None and self.finished >= self.job.episodes:
            self._quit = True

    def _store(self, kept: bool, staged: Path, stream: LeaderStream) -> None:
        target = self.writer if kept else self.failed
        if target is None:
            shutil.rmtree(staged, ignore_errors=True)
            return
        data = stream.to_bytes()
        index = target.append_staged(staged, extra=lambda ep: {stream_rel(ep): data})  # one commit
        self.stored.append((kept, index))
        self.status.kept += int(kept)
        self.status.failed += int(not kept)

    def _drop(self, why: str) -> None:
        self.runner.discard()
        if self.reader is not None:
            self.reader.take_log()
        self.episode = None
        self.status.message = f"episode dropped ({why})"

    def _publish(self) -> None:
        s = self.status
        s.step, s.recording = self.runner.steps, self.episode is not None
        s.settling = self.episode is not None and self.episode.settle_left is not None
        s.sent_at = time.time()
        if self.on_status is not None:
            self.on_status(s)

    # -- replay ----------------------------------------------------------------------------------------------
    def replay(self, stream: LeaderStream) -> None:
        """Re-simulate one recorded episode from its leader stream into this session's dataset(s)."""
        if (stream.arm, stream.family, stream.task_id) != (self.job.arm, self.job.family, self.job.task):
            raise RecipeError(f"the stream is a {stream.arm} episode of {stream.family} task "
                              f"{stream.task_id}, "
                              f"not {self.job.arm} {self.job.family} task {self.job.task}")
        self._replaying = stream
        self._begin(draw=stream.draw_index)
        for k, sample in enumerate(stream.step_sample):
            self._pending = StepEvents(bool(stream.clutch[k]), bool(stream.grip_toggle[k]))
            ticks = stream.ticks[sample] if sample >= 0 else None
            out = self._step(int(sample), ticks)
            if self.episode is None:
                if k != len(stream.step_sample) - 1:
                    raise RecipeError(f"replay diverged: the episode ended at step {k + 1} of "
                                      f"{len(stream.step_sample)} ({out.end if out else 'sim_diverged'})")
                break
            ep = self.episode
            if ep.settle_left is None and k + 1 < len(stream.step_sample) and stream.step_sample[k + 1] < 0:
                ep.settle_left = self.recipe.tasks.settle_steps
        if self.episode is not None:  # the operator stopped it here
            self._end(None, None)

    def close(self) -> None:
        """Drop an unfinished episode, close the datasets and the renderer (idempotent)."""
        if self.episode is not None:
            self._drop("session closed")
        self.writer.close()
        if self.failed is not None:
            self.failed.close()
        self.cameras.close()
        shutil.rmtree(self.stage_dir, ignore_errors=True)


class _Tap:
    """Forwards frames to the episode's stager and keeps the latest camera images for the operator view."""

    def __init__(self, sink: EpisodeStager, status: SessionStatus) -> None:
        self.sink, self.status = sink, status

    def set_scene(self, mjb: bytes) -> None:
        self.sink.set_scene(mjb)

    def add_frame(self, frame: Frame) -> None:
        self.sink.add_frame(frame)
        self.status.images = dict(frame.images)

    def end_episode(self, meta: EpisodeMeta) -> None:
        self.sink.end_episode(meta)

    def discard_episode(self) -> None:
        self.sink.discard_episode()


class _NoSink:
    """Placeholder sink between episodes (each episode records into its own stager)."""

    def set_scene(self, mjb: bytes) -> None:
        raise RuntimeError("no episode in progress")

    def add_frame(self, frame: object) -> None:
        raise RuntimeError("no episode in progress")

    def end_episode(self, meta: object) -> None:
        raise RuntimeError("no episode in progress")

    def discard_episode(self) -> None:
        """Nothing is in progress between episodes, so there is nothing to drop."""
