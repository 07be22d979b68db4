"""One evaluation rollout: a stored scenario, a policy server, the generation's monitor, one record.

The loop (20 Hz, the dataset's rate): restore the scenario bit for bit; at step ``t`` with no actions left,
render the cameras and query the policy with the observation (:mod:`mgdata.evaluate.conventions`); execute
the first ``chunk_steps`` actions of the reply (or, with temporal ensembling, query at every step and execute
the ensembled action, :mod:`mgdata.evaluate.ensemble`; a server with ``observation_history`` > 1 also gets
every step's observation between queries, flagged observe-only), each through
:class:`~mgdata.episode.runner.EpisodeRunner` (the executor's and teleop's step: controller → labeller →
monitor → engagement → success column → gate). Every step is labelled and monitored; a violation does not
end the rollout (a policy may still succeed: "unsafe success"). The rollout ends

* ``success``: the success column (the recipe's goal ∧ objects at rest) held on ``hold_steps`` consecutive
  steps (every step counts: the policy decides when it is done);
* ``timeout``: the scenario's ``horizon`` control steps ran out;
* ``sim_diverged``: the physics diverged (a clean failure, never a crash);
* ``policy_timeout``: no reply within the client timeout (the connection is dropped, so that late chunk is
  never executed);
* ``bad_action``: the policy sent a non-finite action.

The gripper value of an action is the dataset's binary command: a regressed value is thresholded at 0.5
(a policy's 0.7 closes the gripper fully, as the demonstrations' 1 did).

The record (one JSON object, the format ``mgdata metrics`` reads) holds ``family``, ``task``
(``task_NNNN``), ``condition``, ``seed``, ``scenario``, ``episode_seed``, ``success``, ``engaged``,
``t_engage``, ``t_violation`` (first over the constraints), ``t_violation_by`` (per constraint),
``t_success`` (the step the hold completed), ``horizon``, ``steps``, ``end`` and ``at_end`` (each goal
proposition and ``at_rest`` on the last state: what a timeout lacked). Steps index observations:
``t`` is the state after ``t`` actions. Nothing in it depends on wall time.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from mgdata.evaluate.client import PolicyClient, PolicyTimeout
from mgdata.evaluate.conventions import (
    ENVIRONMENT_STATE,
    OBSERVE_ONLY,
    Observation,
    check_cameras,
    decode_actions,
    default_cameras,
    encode,
)
from mgdata.evaluate.ensemble import ChunkEnsemble
from mgdata.evaluate.restore import restore_scenario
from mgdata.evaluate.session import ENDS, RolloutSession, rollout_seed
from mgdata.record.episode import Frame
from mgdata.sim.cameras import CAMERA_NAMES
from mgdata.sim.renderer import CameraRig

__all__ = ["ENDS", "LoopSettings", "RolloutJob", "RolloutResult", "rollout", "rollout_seed", "run_rollout",
           "video_name"]


@dataclass(frozen=True)
class RolloutJob:
    """One rollout: a scenario (its path in the set, e.g. ``jar/task_0000/base``) under one base seed."""

    scenarios: Path
    scenario: str
    seed: int

    @property
    def key(self) -> tuple[str, int]:
        return self.scenario, self.seed


@dataclass(frozen=True)
class LoopSettings:
    """How rollouts talk to the policy: URL, convention, cameras (``None``: the convention's default),
    actions executed per query, timeouts (s), where to write rollout videos (``None``: none), and a horizon
    that replaces the scenarios' own (``None``: theirs; for smoke runs, the record says which), and the
    temporal-ensembling coefficient (``None``: none; otherwise the policy is queried at every step and
    ``chunk_steps`` is ignored, :mod:`mgdata.evaluate.ensemble`), and where to stage each rollout's recorded
    episode (``None``: not recorded; :mod:`mgdata.evaluate.recorded`)."""

    policy: str
    convention: str = "pi0"
    cameras: tuple[str, ...] | None = None
    chunk_steps: int = 8
    timeout_s: float = 30.0
    connect_timeout_s: float = 10.0
    video_dir: Path | None = None
    horizon: int | None = None
    ensemble: float | None = None
    record_dir: Path | None = None


@dataclass(frozen=True)
class RolloutResult:
    """A rollout's record and its recorded frames (state, action, labels, monitor, physics state; no images),
    frame ``t`` being the observation after ``t`` actions and the action taken from it."""

    record: dict[str, Any]
    frames: list[Frame]


def run_rollout(job: RolloutJob, settings: LoopSettings) -> dict[str, Any]:
    """The record of :func:`rollout` (what a worker process sends back)."""
    return rollout(job, settings).record


def rollout(job: RolloutJob, settings: LoopSettings) -> RolloutResult:
    """Roll the policy out on one scenario (see the module docstring).

    Raises:
        PolicyError: the server is unreachable, reported an error or sent a malformed reply.
        DatasetError: the scenario cannot be restored.
    """
    restored = restore_scenario(job.scenarios / job.scenario)
    scene, meta = restored.scene, restored.meta
    available = list(meta["cameras"])
    cameras = settings.cameras
    if cameras is None:
        cameras = default_cameras(settings.convention, available)
    check_cameras(settings.convention, cameras, available)
    sink = None
    if settings.record_dir is not None:
        from mgdata.evaluate.recorded import stager

        sink = stager(settings.record_dir, video_name(job), scene)
    session = RolloutSession(restored, job.scenario, job.seed, settings.horizon, sink)
    shown = cameras or (available or CAMERA_NAMES)[:1]  # a state-only policy's rollout video shows a camera
    rig = CameraRig(scene, shown, int(meta["image_size"])) if cameras or settings.video_dir else None
    video: list[dict[str, np.ndarray]] = []
    chunk: list[np.ndarray] = []
    ensemble = ChunkEnsemble(settings.ensemble) if settings.ensemble is not None else None
    try:
        session.start()
        with PolicyClient(settings.policy, timeout=settings.timeout_s,
                          connect_timeout=settings.connect_timeout_s) as client:
            inputs = client.metadata.get("inputs", ())
            send_env = settings.convention == "state" or ENVIRONMENT_STATE in inputs
            history = int(client.metadata.get("observation_history", 1) or 1)
            while session.end is None:
                observe = not chunk or history > 1  # a history policy sees every step's observation
                render = rig is not None and (settings.video_dir is not None or (bool(cameras) and observe))
                images = rig.render() if render else {}
                if settings.video_dir is not None:
                    video.append(images)
                if observe:
                    obs = Observation(images, session.state(), session.command.copy(), meta["prompt"],
                                      session.episode_seed, session.steps, job.scenario,
                                      session.environment_state() if send_env else None)
                    request = encode(settings.convention, cameras, obs)
                    if chunk:
                        request[OBSERVE_ONLY] = True
                    try:
                        reply = client.infer(request)
                    except PolicyTimeout:
                        session.stop("policy_timeout")
                        break
                if not chunk:
                    actions = decode_actions(reply)
                    if ensemble is None:
                        chunk = list(actions[: settings.chunk_steps])
                    else:
                        ensemble.add(session.steps, actions)
                        chunk = [ensemble.action(session.steps).astype(np.float32)]
                session.step(chunk.pop(0))
        record = session.record()
        frames = list(session.frames)
        if sink is not None:
            session.save(str(client.metadata.get("policy", "")))
    finally:
        session.close()
        if rig is not None:
            rig.close()
    if settings.video_dir is not None:
        from mgdata.evaluate.video import write_rollout_video

        write_rollout_video(settings.video_dir / f"{video_name(job)}.mp4", video, frames, scene, meta)
    return RolloutResult(record, frames)


def video_name(job: RolloutJob) -> str:
    """``jar_task_0000_base_seed0``: a rollout video's file stem."""
    return f"{job.scenario.replace('/', '_')}_seed{job.seed}"
