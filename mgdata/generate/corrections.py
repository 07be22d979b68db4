"""Corrections (``mgdata corrections``): demonstrations restarted where a policy's recorded rollout failed.

A recorded rollout (``mgdata eval --record``) *failed* if it violated a constraint (``unsafe``) or did not
end in success (its ``end``: ``timeout``, ``sim_diverged``, …). Its *failure step* is its first violation,
else its last frame (where the policy stalled). The restart frames are ``f − back``, ``f − 2·back``, …
(down to frame 1): a little before things went wrong, in the state the policy itself brought the scene to.
Each is restarted from its recorded physics state (:meth:`Executor.run
<mgdata.engine.executor.Executor.run>` with ``start=``) with up to ``tries`` draws until one is kept; a frame
the restart rules refuse (``restart_refused``: objects still moving, the spec already violated, an object in
the hand, the skeleton's own feasibility; :mod:`mgdata.engine.restart`) is passed over at once, those rules
not depending on the draw, and does not count. A rollout stops once ``candidates`` frames were tried or
``per_failure`` of them gave a kept correction. Every correction passes the same physics gate as a generated
demo.

A correction's metadata: ``mgdata/source = correction`` and ``variation.restart`` = ``parent`` (the rollout:
scenario, seed, episode index in the rollouts dataset, policy), ``step`` (its restart frame),
``failure_step``, ``failure`` and ``phases`` (the skeleton's phases it ran). Its draw index is
``(episode · L + frame) · tries + t`` (try ``t``, ``L`` the longest rollout's frame count), so its seed is
recorded and distinct.

A rollout is the unit of work: a worker runs all of its tries; the main process commits each rollout's kept
corrections in rollouts-dataset order (same bytes for any worker count) and records what every try gave in
``meta/mgdata_corrections.json`` (:mod:`mgdata.generate.correction_report`), so a run that is stopped
resumes with the rollouts not yet in that file. Rollouts of held-out tasks must not become training data:
select the training tasks with ``tasks``.

``shard=(i, N)`` (``--shard i/N``) corrects only the selected failed rollouts at positions ``i, i + N, …``
(in rollouts-dataset order), with the very draws of the unsharded run; its report records the shard, the
rollouts dataset, ``tasks`` and the settings (a resume must match them), and a shard with no rollout of
its own is still written, empty. ``mgdata merge`` joins shards ``0 … N−1`` into the dataset the unsharded
run writes, byte for byte (:func:`mgdata.generate.merge.merge_shards`).

Example::

    summary = correct(CorrectionJob(rollouts=Path("eval/rollouts/jar"), out=Path("datasets/jar_corr"),
                                    tasks=(0, 1, 2, 3)))
    correct(CorrectionJob(rollouts=Path("eval/rollouts/jar"), out=Path("ds/corr_1"), shard=(1, 4)))
"""

from __future__ import annotations

import hashlib
import os
import shutil
import time
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from mgdata.atomic import remove_stale_temps
from mgdata.engine.executor import dataset_schema
from mgdata.engine.inputs import inputs_digest
from mgdata.episode.timing import Timings
from mgdata.errors import DatasetError, GraspDBError, RecipeError
from mgdata.generate.correction_report import REPORT_FILE, CorrectionReport, ShardRecord, rollouts_digest
from mgdata.generate.resume import RunState
from mgdata.generate.run import check_shard, open_dataset, output_error, run_digest, writable_dir
from mgdata.generate.summary import RunSummary
from mgdata.generate.workers import AttemptDone, AttemptPool, Worker, WorkerConfig
from mgdata.grasps.db import GraspDB
from mgdata.interrupts import sigint_deferred
from mgdata.paths import grasps_dir
from mgdata.record.commit import work_dir
from mgdata.record.episode import EpisodeMeta
from mgdata.record.physics import model_bytes
from mgdata.record.reader import DatasetReader
from mgdata.record.writer import DatasetWriter
from mgdata.skeleton.skeleton import load_family_recipe
from mgdata.tasks.recipe import Recipe

SOURCE = "correction"
NOTHING_TO_CORRECT = "no failed rollout to correct"


@dataclass(frozen=True)
class CorrectionJob:
    """The settings of one ``mgdata corrections`` run (the CLI's options).

    Attributes:
        rollouts: a recorded-rollouts dataset (``<eval out>/rollouts/<family>``).
        out: the corrections dataset (created, or resumed with the same settings).
        tasks: the base tasks whose rollouts are corrected (``None``: all; leave held-out tasks out).
        back: frames between restart candidates (20 = 1 s at 20 Hz).
        candidates: restart frames tried per failed rollout (refused ones do not count).
        tries: draws per candidate.
        per_failure: kept corrections wanted per failed rollout.
        workers, seed, codec, grasps, recipe: as ``mgdata generate``'s.
        shard: ``(i, N)``: correct only the selected failed rollouts at positions ``i, i + N, …``
            (``--shard i/N``; the module docstring).
    """

    rollouts: Path
    out: Path
    tasks: tuple[int, ...] | None = None
    back: int = 20
    candidates: int = 4
    tries: int = 2
    per_failure: int = 1
    workers: int = 1
    seed: int = 0
    codec: str = "h264"
    grasps: Path | None = None
    recipe: Path | None = None
    shard: tuple[int, int] | None = None

    def settings(self) -> dict[str, int]:
        """What shapes the corrections of a rollout (recorded in ``info.json``; a resume must match)."""
        return {"back": self.back, "candidates": self.candidates, "tries": self.tries,
                "per_failure": self.per_failure}


@dataclass(frozen=True)
class Failure:
    """A failed rollout and its restart candidates.

    Attributes:
        episode: its index in the rollouts dataset. parent: scenario, seed, episode, policy.
        task_id, condition: the scenario's base task and condition.
        kind: ``unsafe`` or the rollout's end. step: the failure step (a frame index).
        scene_sha: SHA-256 of the rollout's compiled scene (a correction must run in the very same scene).
        restarts: (frame, physics state) of each candidate, latest first.
        stride: frames per rollout in the draw index (the longest rollout's frame count).
    """

    episode: int
    parent: Mapping[str, Any]
    task_id: int
    condition: str
    kind: str
    step: int
    scene_sha: str
    restarts: tuple[tuple[int, np.ndarray], ...]
    stride: int

    @property
    def key(self) -> str:
        """The rollout's name in the report (scenario, seed, policy)."""
        return f"{self.parent['scenario']}/seed{self.parent['seed']}/{self.parent['policy']}"


@dataclass(frozen=True)
class Corrected:
    """What a worker did with one failed rollout: every try's attempt (kept ones staged) and its log."""

    failure: Failure
    attempts: tuple[AttemptDone, ...]
    tries: tuple[dict[str, Any], ...]


def failures(reader: DatasetReader, tasks: tuple[int, ...] | None, back: int) -> list[Failure]:
    """The failed rollouts of ``reader`` (of ``tasks``), in dataset order, with their restart candidates."""
    found: list[Failure] = []
    stride = max((rec.length for rec in reader.records()), default=1)
    for rec in reader.records():
        meta = rec.meta
        origin = dict(meta.variation).get("rollout")
        if meta.source != "rollout" or not isinstance(origin, Mapping):
            raise DatasetError(f"{reader.root}: episode {rec.index} is no recorded rollout (source "
                               f"{meta.source!r}); give the folder mgdata eval --record wrote "
                               "(<eval out>/rollouts/<family>)")
        if tasks is not None and meta.task_id not in tasks:
            continue
        violations = [t for t in meta.t_violation.values() if t is not None]
        if origin["end"] == "success" and not violations:
            continue
        step = min(violations) if violations else rec.length - 1
        frames = range(step - back, 0, -back)
        ep = reader.episode(rec.index)
        if ep.physics_state is None:
            raise DatasetError(f"{reader.root}: stores no physics states; record the rollouts with "
                               "mgdata eval --record")
        parent = {"scenario": origin["scenario"], "seed": int(origin["seed"]), "episode": rec.index,
                  "policy": origin["policy"]}
        found.append(Failure(rec.index, parent, meta.task_id, meta.condition,
                             "unsafe" if violations else str(origin["end"]), step,
                             hashlib.sha256(reader.scene_mjb(rec.index)).hexdigest(),
                             tuple((k, ep.physics_state[k].copy()) for k in frames), stride))
    return found


def correct_rollout(worker: Worker, failure: Failure, job: CorrectionJob) -> Corrected:
    """Run one failed rollout's tries in ``worker`` (the module docstring's rules)."""
    ex, _ = worker.executor(failure.task_id, failure.condition, Timings())
    if hashlib.sha256(model_bytes(ex.scene.model)).hexdigest() != failure.scene_sha:
        raise DatasetError(f"rollout {failure.key} (episode {failure.episode}) ran in another scene than "
                           f"the recipe builds for task {failure.task_id} ({failure.condition}); correct it "
                           "with the recipe and grasps its scenarios were built from (--recipe, --grasps)")
    attempts: list[AttemptDone] = []
    tries: list[dict[str, Any]] = []
    kept = tried = 0
    for step, state in failure.restarts:
        for t in range(job.tries):
            draw = (failure.episode * failure.stride + step) * job.tries + t
            origin = {"parent": dict(failure.parent), "step": step, "failure_step": failure.step,
                      "failure": failure.kind}
            done = worker.run(failure.task_id, draw, condition=failure.condition, start=state, origin=origin,
                              source=SOURCE, name=f"rollout{failure.episode:06d}-draw{draw:012d}")
            r = done.result
            attempts.append(done)
            tries.append({"step": step, "draw": draw, "kept": r.kept, "stage": r.stage, "reason": r.reason})
            if r.kept or r.stage == "restart_refused":
                break
        kept += tries[-1]["kept"]
        tried += tries[-1]["stage"] != "restart_refused"
        if kept >= job.per_failure or tried >= job.candidates:
            break
    return Corrected(failure, tuple(attempts), tuple(tries))


def _check(job: CorrectionJob) -> tuple[DatasetReader, Recipe, Path]:
    for name in ("back", "candidates", "tries", "per_failure", "workers"):
        if getattr(job, name) < 1:
            raise RecipeError(f"--{name.replace('_', '-')} must be at least 1, got {getattr(job, name)}")
    if job.seed < 0:
        raise RecipeError(f"--seed must be >= 0, got {job.seed}")
    if job.shard is not None:
        check_shard(job.shard)
    reader = DatasetReader(job.rollouts)
    families = sorted({r.meta.family for r in reader.records()})
    if len(families) != 1:
        raise DatasetError(f"{job.rollouts}: expected the recorded rollouts of one family, found "
                           f"{families or 'no episodes'}")
    recipe = load_family_recipe(job.recipe or families[0])
    if recipe.family != families[0]:
        raise RecipeError(f"{recipe.path} is a {recipe.family!r} recipe; the rollouts are {families[0]!r}")
    bad = [t for t in job.tasks or () if not 0 <= t < recipe.tasks.count]
    if bad:
        raise RecipeError(f"--tasks: {recipe.family} has tasks 0 … {recipe.tasks.count - 1}, not {bad[0]}")
    grasps = Path(job.grasps or grasps_dir())
    if not grasps.is_dir():
        raise GraspDBError(f"grasp database folder {grasps} does not exist")
    GraspDB.load_dir(grasps)
    if Path(job.out).resolve() == Path(job.rollouts).resolve():
        raise DatasetError("--out: the corrections go to a dataset of their own, not into the rollouts")
    return reader, recipe, grasps


def _shard(job: CorrectionJob, found: list[Failure]) -> ShardRecord | None:
    """This run's shard (``None`` unsharded): its failed rollouts are ``found[i::N]``."""
    if job.shard is None:
        return None
    i, n = job.shard
    tasks = None if job.tasks is None else tuple(sorted(set(job.tasks)))
    return ShardRecord(i, n, rollouts_digest(job.rollouts), tasks, job.settings(),
                       tuple(f.episode for f in found[i::n]))


def _check_shard(report: CorrectionReport, shard: ShardRecord | None, metas: list[EpisodeMeta],
                 path: Path) -> None:
    """A dataset is resumed as the same shard of the same run (or unsharded, as unsharded)."""
    saved = report.shard
    if shard is None:
        if saved is not None:
            raise DatasetError(f"{path}: this dataset is shard {saved.name} of a corrections run; resume it "
                               f"with --shard {saved.name}, or join the shards with mgdata merge")
        return
    if saved is None:
        if report.rollouts or metas:
            raise DatasetError(f"{path}: this dataset holds the corrections of a run without --shard; "
                               "resume it without --shard, or use a new --out")
        return
    diffs = ([f"shard {saved.name} vs {shard.name}"] if saved.index != shard.index else []) + \
        saved.differences(shard)
    if diffs:
        raise DatasetError(f"{path}: this dataset is another shard or run than this one "
                           f"({'; '.join(diffs)}, the dataset's first); resume with the same --shard, "
                           "--tasks, settings and rollouts, or use a new --out")


def _restart_key(meta_variation: Mapping[str, Any]) -> tuple[str, int, str, int, int]:
    restart = meta_variation["restart"]
    parent = restart["parent"]
    return (parent["scenario"], int(parent["seed"]), parent["policy"], int(parent["episode"]),
            int(restart["step"]))


def correct(job: CorrectionJob, on_attempt: Callable[[RunSummary], None] | None = None) -> RunSummary:
    """Correct every failed rollout of ``job.rollouts`` not corrected into ``job.out`` yet.

    ``on_attempt(summary)`` is called when the tries start and after every committed rollout.
    """
    reader, recipe, grasps = _check(job)
    found = failures(reader, job.tasks, job.back)
    out = Path(job.out)
    summary = RunSummary(out=out, target=0)
    if not found:
        summary.stopped = NOTHING_TO_CORRECT  # nothing is written
        return summary
    shard = _shard(job, found)
    mine = found if shard is None else found[shard.index::shard.count]
    identity = RunState(recipe.family, job.seed, run_digest(inputs_digest(recipe, grasps), "base")
                        + "/corrections " + " ".join(f"{k}={v}" for k, v in job.settings().items()))
    try:
        writable_dir(out, "--out")
        writer = open_dataset(out, dataset_schema(recipe), job.codec, recipe, identity, kept_only=True,
                              extra={"corrections": job.settings()})
    except OSError as err:
        raise output_error(err, out) from None
    start = time.perf_counter()
    try:
        report_path = out / REPORT_FILE
        remove_stale_temps(report_path)
        report = CorrectionReport.load(report_path)
        metas = writer.episodes_meta()
        _check_shard(report, shard, metas, report_path)
        if shard is not None and report.shard is None:  # before any rollout: an empty shard is complete
            report.shard = shard
            report.save(report_path)
        done = {entry["rollout"] for entry in report.rollouts}
        todo = [f for f in mine if f.key not in done]
        summary.kept_before = writer.num_episodes
        summary.target = writer.num_episodes + job.per_failure * len(todo)
        if not mine:  # found[i::N] is empty only for a shard
            summary.stopped = f"no failed rollout falls in this shard ({len(found)} in all): an empty shard"
            return summary
        if not todo:
            summary.stopped = "every failed rollout was corrected before"
            return summary
        present = {_restart_key(m.variation) for m in metas}
        stage_dir = work_dir(out) / "staging" / f"corrections-{os.getpid()}"
        config = WorkerConfig(recipe.path, grasps, stage_dir, job.seed, False, writer.video)
        if on_attempt is not None:
            on_attempt(summary)
        shutil.rmtree(stage_dir, ignore_errors=True)
        try:
            _loop(job, todo, config, writer, report, report_path, present, summary, start, on_attempt)
        finally:
            shutil.rmtree(stage_dir, ignore_errors=True)
        summary.stopped = "every failed rollout tried"
    except KeyboardInterrupt:
        summary.stopped = "interrupted"
    except OSError as err:
        raise output_error(err, out) from None
    finally:
        summary.wall = time.perf_counter() - start
        with sigint_deferred(reraise=False):
            writer.close()
    return summary


def _loop(job: CorrectionJob, todo: list[Failure], config: WorkerConfig, writer: DatasetWriter,
          report: CorrectionReport, report_path: Path, present: set[tuple[str, int, str, int, int]],
          summary: RunSummary, start: float, on_attempt: Callable[[RunSummary], None] | None) -> None:
    pending = list(reversed(todo))
    with AttemptPool(config, job.workers) as pool:
        while pending or pool.in_flight:
            while pending and pool.in_flight < pool.capacity:
                pool.call(correct_rollout, pending.pop(), job)
            corrected: Corrected = pool.next_done()
            t0 = time.process_time()
            with sigint_deferred():  # a rollout's corrections and its report entry go in together
                for attempt in corrected.attempts:
                    meta = attempt.result.meta
                    if attempt.staged is None:
                        continue
                    if meta is not None and _restart_key(meta.variation) in present:  # committed before a
                        shutil.rmtree(attempt.staged, ignore_errors=True)         # kill: not twice
                        continue
                    writer.append_staged(attempt.staged)
                writer.record_attempts(writer.recorded_attempts + len(corrected.attempts))  # the yield
                failure = corrected.failure
                report.rollouts.append({"rollout": failure.key, "parent": dict(failure.parent),
                                        "failure": failure.kind, "failure_step": failure.step,
                                        "corrections": sum(t["kept"] for t in corrected.tries),
                                        "tries": list(corrected.tries)})
                report.save(report_path)
            for attempt in corrected.attempts:
                summary.add(attempt.result)
            summary.timings.writing += time.process_time() - t0
            summary.wall = time.perf_counter() - start
            if on_attempt is not None:
                on_attempt(summary)
