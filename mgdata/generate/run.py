"""One generation run: attempts in canonical order until the dataset holds the target number of kept demos.

Every input is checked in this process before any dataset is created or any worker starts: the recipe
against its skeleton's declared keys, the spec's formulas (compiled), the grasp database, the selected base
tasks, and the output folder. The dataset at ``out`` is then created or resumed (its writer recovers from a
killed run). Its identity (family, user seed, inputs digest) is written into ``meta/info.json`` when the
dataset is created, so it cannot be lost separately from the data; a run with other inputs is refused. The
generator state (``meta/mgdata_generate.json``: per-task draw cursor, attempts) is caught up from the
dataset on every start (a ``kill -9`` between a commit and the state's save leaves it one attempt behind),
and every episode already in the dataset must carry the seed that (task, draw, --seed) gives, so a resumed
run can neither reuse a draw nor mix seeds. Kept attempts are appended to ``out``; with ``keep_failed`` the
others go to ``<out>_failed`` with their labels and failure stage; otherwise they are dropped. Ctrl-C stops
at once: everything committed stays, and re-running the command continues. An output that cannot be
written (not a folder, read-only, disk full) is an :class:`OutputError`; the attempt whose commit failed is
not counted and is attempted again on resume.

Example::

    summary = generate(GenerateJob(family="jar", n=40, out=Path("datasets/jar"), workers=2))
"""

from __future__ import annotations

import collections
import contextlib
import copy
import dataclasses
import os
import shutil
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

from mgdata.atomic import remove_stale_temps
from mgdata.engine.executor import dataset_schema
from mgdata.engine.inputs import inputs_digest
from mgdata.episode.success import physics_gate
from mgdata.errors import DatasetError, GraspDBError, OutputError, RecipeError
from mgdata.generate.resume import DrawCursor, RunState
from mgdata.generate.summary import RunSummary
from mgdata.generate.workers import AttemptPool, WorkerConfig
from mgdata.grasps.db import GraspDB
from mgdata.interrupts import sigint_deferred
from mgdata.ltl import Monitor
from mgdata.paths import grasps_dir
from mgdata.record import layout
from mgdata.record.commit import work_dir
from mgdata.record.episode import DatasetSchema, EpisodeMeta
from mgdata.record.metafiles import read_info
from mgdata.record.writer import DatasetWriter
from mgdata.scenarios.conditions import attempt_condition
from mgdata.skeleton.skeleton import load_family_recipe
from mgdata.skeleton.variation import attempt_seed
from mgdata.tasks.base import draw_task
from mgdata.tasks.placer import LayoutRejected
from mgdata.tasks.recipe import Recipe, with_recovery

if TYPE_CHECKING:
    from mgdata.generate.raypool import RayAttemptPool

STATE_FILE = "meta/mgdata_generate.json"


@dataclass(frozen=True)
class GenerateJob:
    """The settings of one run (the CLI's options).

    Attributes:
        family: task family (recipe and skeleton name).
        n: kept episodes wanted in the dataset (existing ones count).
        out: dataset folder.
        tasks: base-task ids to draw from, round-robin (``None``: all of the recipe's tasks).
        workers: attempt processes.
        seed: user seed mixed into every attempt seed.
        keep_failed: also record failed and unsafe attempts, into ``<out>_failed``.
        max_attempts: attempts this run may make (``None``: 4 × the episodes still missing, at least 8).
        codec: video codec of a new dataset (``h264`` or ``av1``).
        grasps: grasp database folder.
        recipe: a recipe file to use instead of ``recipes/<family>.toml``.
        per_task: kept episodes wanted per selected base task (``--per-task``; replaces ``n``): the draw
            cursor passes over a task once its quota is met, and an attempt of a full task that was already
            running is dropped uncounted, so the dataset does not depend on the number of workers.
        shard: ``(i, N)``: this run generates shard ``i`` of ``N`` (``--shard i/N``, with ``--per-task``): the
            selected tasks at positions ``i, i + N, …``; ``mgdata merge`` joins the shards' datasets into
            the one a single run would have written.
        render_after: render only the episodes that are recorded, after their attempt, from their physics
            states (two passes; the default), instead of every step of every attempt while it runs; the
            dataset's bytes are the same either way.
        ray: run the attempts on Ray actors instead of local processes (``--ray [ADDRESS]``): ``"local"``
            for a private local instance, else a cluster address; ``workers`` actors, the same bytes.
        condition: the scenario condition the demos are generated in (``--condition``): ``base``, an OOD
            variant of each task as ``mgdata scenarios`` builds it (``target``, ``language``, ``location``,
            ``environment``), or ``all`` (draw ``d`` of a task in ``CONDITIONS[d mod 5]``). Each episode
            records its condition; a dataset is resumed and merged only with the same condition.
        recovery: ``--recovery``: the recipe's ``[recovery] mode`` for this run (``None``: the recipe's;
            :mod:`mgdata.tasks.recovery`); a dataset is resumed only with the same mode.
    """

    family: str
    n: int
    out: Path
    tasks: tuple[int, ...] | None = None
    workers: int = 1
    seed: int = 0
    keep_failed: bool = False
    max_attempts: int | None = None
    codec: str = "h264"
    grasps: Path | None = None
    recipe: Path | None = None
    render_after: bool = True
    per_task: int | None = None
    shard: tuple[int, int] | None = None
    ray: str | None = None
    condition: str = "base"
    recovery: str | None = None


def failed_path(out: Path) -> Path:
    """Where the labelled negatives of ``out`` go."""
    return out.with_name(out.name + "_failed")


def _check_episodes(metas: list[EpisodeMeta], job: GenerateJob, root: Path) -> None:
    """Every episode already in the dataset must come from this family and this ``--seed``."""
    for m in metas:
        if m.family != job.family:
            raise DatasetError(f"{root}: holds {m.family!r} episodes; this run generates {job.family!r} "
                               "(use another --out)")
        if m.source == "planner" and m.seed != attempt_seed(job.family, m.task_id, m.draw_index, job.seed):
            raise DatasetError(f"{root}: its episodes were generated with another --seed than {job.seed}; "
                               "resume with the same seed, or use another --out")


def _tasks(job: GenerateJob, recipe: Recipe) -> tuple[int, ...]:
    tasks = job.tasks if job.tasks is not None else tuple(range(recipe.tasks.count))
    bad = [t for t in tasks if not 0 <= t < recipe.tasks.count]
    if bad or not tasks:
        raise RecipeError(f"{recipe.path}: task id(s) {bad or '(none)'} do not exist; the recipe has tasks "
                          f"0 … {recipe.tasks.count - 1}")
    return tuple(dict.fromkeys(tasks))


def check_shard(shard: tuple[int, int]) -> tuple[int, int]:
    """``shard`` if it is an ``i/N`` with ``0 <= i < N``, else :class:`RecipeError` (``--shard``)."""
    i, n = shard
    if not 0 <= i < n:
        raise RecipeError(f"--shard {i}/{n}: expected i/N with 0 <= i < N")
    return i, n


def shard_tasks(job: GenerateJob, tasks: tuple[int, ...]) -> tuple[int, ...]:
    """The tasks of ``job.shard`` (all of ``tasks`` without one). A shard needs ``--per-task`` (a total
    ``--n`` cannot be split without knowing each task's yield) and tasks in ascending order (the canonical
    order ``mgdata merge`` restores: by draw, then task)."""
    if job.shard is None:
        return tasks
    i, n = check_shard(job.shard)
    if job.per_task is None:
        raise RecipeError("--shard needs --per-task (each shard fills the quota of its own tasks)")
    if list(tasks) != sorted(tasks):
        raise RecipeError(f"--shard: give the tasks in ascending order (got {list(tasks)})")
    mine = tasks[i::n]
    if not mine:
        raise RecipeError(f"--shard {i}/{n}: no task falls in this shard ({len(tasks)} tasks selected)")
    return mine


def run_digest(inputs: str, condition: str, recovery: str = "off") -> str:
    """The identity digest of a run: the inputs' digest, with ``/<condition>`` unless it is ``base`` and
    ``/recovery=<mode>`` unless recovery is off, so a dataset is never resumed or merged with demos of
    another condition or another recovery mode."""
    digest = inputs if condition == "base" else f"{inputs}/{condition}"
    return digest if recovery == "off" else f"{digest}/recovery={recovery}"


def check_inputs(job: GenerateJob) -> tuple[Recipe, tuple[int, ...], Path]:
    """Load and check every input an attempt worker will read, in this process, so bad input is one error
    before any dataset or worker exists: the recipe (against its skeleton's keys), the spec (each constraint
    compiled), the grasp database, the options, and the selected base tasks (their layout)."""
    if job.n < 1:
        raise RecipeError(f"--n must be at least 1, got {job.n}")
    if job.per_task is not None and job.per_task < 1:
        raise RecipeError(f"--per-task must be at least 1, got {job.per_task}")
    if job.workers < 1:
        raise RecipeError(f"--workers must be at least 1, got {job.workers}")
    if job.seed < 0:
        raise RecipeError(f"--seed must be >= 0, got {job.seed}")
    if job.max_attempts is not None and job.max_attempts < 1:
        raise RecipeError(f"--max-attempts must be at least 1, got {job.max_attempts}")
    attempt_condition(job.condition, 0)  # a known condition
    recipe = with_recovery(load_family_recipe(job.recipe or job.family), job.recovery)
    if recipe.family != job.family:
        raise RecipeError(f"{recipe.path} is a {recipe.family!r} recipe, not {job.family!r}")
    tasks = _tasks(job, recipe)
    Monitor(recipe.spec)  # compiles every constraint (cached for this process)
    grasps = Path(job.grasps or grasps_dir())
    if not grasps.is_dir():
        raise GraspDBError(f"grasp database folder {grasps} does not exist")
    GraspDB.load_dir(grasps)
    for task_id in tasks:  # the layout's rules; workers run the initial-state gate per task
        with contextlib.suppress(LayoutRejected):  # a rejected draw is redrawn by the gate
            draw_task(recipe, task_id)
    return recipe, tasks, grasps


def writable_dir(path: Path, option: str) -> Path:
    """``path`` as an existing folder this process can write into, or :class:`OutputError` saying why not."""
    if path.exists() and not path.is_dir():
        raise OutputError(f"{option} {path}: is a file, not a folder")
    try:
        path.mkdir(parents=True, exist_ok=True)
    except OSError as err:
        raise OutputError(f"{option} {path}: cannot create the folder ({err.strerror or err})") from None
    if not os.access(path, os.W_OK | os.X_OK):
        raise OutputError(f"{option} {path}: no permission to write into the folder")
    return path


def output_error(err: OSError, out: Path) -> OutputError:
    where = err.filename or out
    return OutputError(f"cannot write the dataset {out}: {where}: {err.strerror or err}; everything "
                       "committed before is kept: fix the cause and run the same command again to resume")


def open_dataset(root: Path, schema: DatasetSchema, codec: str, recipe: Recipe, identity: RunState, *,
                 kept_only: bool, extra: dict[str, object] | None = None) -> DatasetWriter:
    """Create the dataset (its ``info.json`` records ``identity``, the gate's promises: ``hold_steps``,
    ``kept_only``, and ``extra`` under ``mgdata``) or resume it (``identity`` must match)."""
    record = {"generator": {"family": identity.family, "seed": identity.seed,
                            "inputs_digest": identity.inputs_digest},
              "physics_gate": physics_gate(recipe).to_info(),
              **({"recovery": recipe.recovery.to_info()} if recipe.recovery.perturbs else {}),
              **(extra or {})}
    writer = DatasetWriter.open_or_create(root, schema, codec=codec, spec=recipe.spec, mgdata=record,
                                          hold_steps=recipe.tasks.hold_steps, kept_only=kept_only)
    try:
        _check_identity(root, identity, writer.num_episodes)
    except BaseException:
        writer.close()
        raise
    return writer


def _check_identity(root: Path, identity: RunState, episodes: int) -> None:
    """The dataset's recorded generator identity (``info.json``) must be this run's."""
    path = root / layout.INFO_PATH
    raw = read_info(path)["mgdata"].get("generator")
    if raw is None:  # written before the identity lived in info.json: the state file is all there is
        if episodes and not (root / STATE_FILE).exists():
            raise DatasetError(f"{path}: records no generator inputs, and {STATE_FILE} is gone; this run "
                               "cannot tell whether it would mix inputs: use a new --out")
        return
    try:
        recorded = RunState(str(raw["family"]), int(raw["seed"]), str(raw["inputs_digest"]))
    except (KeyError, TypeError, ValueError) as err:
        raise DatasetError(f"{path}: mgdata.generator is malformed ({err!r}); use a new --out") from None
    recorded.check_compatible(identity, path)


def generate(job: GenerateJob, on_attempt: Callable[[RunSummary], None] | None = None) -> RunSummary:
    """Run until the dataset holds ``job.n`` kept episodes, ``max_attempts`` are spent, or Ctrl-C.

    ``on_attempt(summary)`` is called once when the attempts start (inputs checked, dataset open) and after
    every committed attempt.
    """
    recipe, tasks, grasps = check_inputs(job)
    tasks = shard_tasks(job, tasks)
    if job.per_task is not None:
        job = dataclasses.replace(job, n=job.per_task * len(tasks))
    schema = dataset_schema(recipe)
    out = Path(job.out)
    identity = RunState(job.family, job.seed, run_digest(inputs_digest(recipe, grasps), job.condition,
                                                         recipe.recovery.mode))
    try:
        writable_dir(out, "--out")
        writer = open_dataset(out, schema, job.codec, recipe, identity, kept_only=True)
    except OSError as err:
        raise output_error(err, out) from None
    failed: DatasetWriter | None = None
    summary = RunSummary(out=out, target=job.n, kept_before=writer.num_episodes)
    start = time.perf_counter()
    try:
        neg_root = failed_path(out)
        if job.keep_failed or (neg_root / layout.INFO_PATH).exists():
            failed = open_dataset(writable_dir(neg_root, "--keep-failed"), schema, job.codec, recipe,
                                  identity, kept_only=False)
            summary.failed_out = neg_root if job.keep_failed else None
        state_path = out / STATE_FILE
        remove_stale_temps(state_path)  # a save cut short by kill -9 (the writer's lock is ours now)
        saved = RunState.load(state_path)
        state = copy.deepcopy(identity)
        if saved is not None:
            saved.check_compatible(identity, state_path)
            state = copy.deepcopy(saved)
        metas = writer.episodes_meta() + (failed.episodes_meta() if failed else [])
        _check_episodes(metas, job, out)
        # A kill -9 between an episode's commit and the state file's update leaves the state behind the
        # dataset: catch it up from what the dataset records, and save the repaired state right away.
        state.attempts = max(state.attempts, writer.recorded_attempts)
        for m in metas:
            state.next_draw[m.task_id] = max(state.next_draw.get(m.task_id, 0), m.draw_index + 1)
        if state != saved:
            state.save(state_path)
        cursor = DrawCursor.resume(tasks, state.next_draw, [(m.task_id, m.draw_index) for m in metas])
        kept = collections.Counter(m.task_id for m in writer.episodes_meta())
        quota = Quota(job.per_task, tasks, kept)
        missing = quota.missing if job.per_task is not None else max(0, job.n - writer.num_episodes)
        budget = job.max_attempts if job.max_attempts is not None else max(8, 4 * missing)
        # per-run folder under staging/ (which the writer's open() clears after a crash)
        stage_dir = work_dir(out) / "staging" / f"generate-{os.getpid()}"
        config = WorkerConfig(recipe.path, grasps, stage_dir, job.seed, job.keep_failed, writer.video,
                              job.render_after, job.condition, job.recovery)
        if missing == 0:
            summary.stopped = "target already reached"
            return summary
        if on_attempt is not None:
            on_attempt(summary)  # inputs checked, dataset open: the run starts
        _loop(job, cursor, quota, config, budget, writer, failed, state, state_path, summary, start,
              on_attempt)
    except KeyboardInterrupt:
        summary.stopped = "interrupted"
    except OSError as err:
        raise output_error(err, out) from None
    finally:
        summary.wall = time.perf_counter() - start
        with sigint_deferred(reraise=False):
            _close(writer, failed, out)
    return summary


def _close(writer: DatasetWriter, failed: DatasetWriter | None, out: Path) -> None:
    for w in (writer, failed):
        if w is None:
            continue
        try:
            w.close()
        except OSError as err:
            raise output_error(err, out) from None


class Quota:
    """``--per-task``: how many kept episodes each selected task still needs (no limit without a quota).

    Attributes:
        per_task: the quota (``None``: none; the run's target is ``--n`` in all).
        kept: kept episodes per task so far.
    """

    def __init__(self, per_task: int | None, tasks: tuple[int, ...], kept: collections.Counter[int]) -> None:
        self.per_task, self.tasks, self.kept = per_task, tasks, kept

    @property
    def full(self) -> frozenset[int]:
        """The tasks whose quota is met (the cursor passes over them)."""
        if self.per_task is None:
            return frozenset()
        return frozenset(t for t in self.tasks if self.kept[t] >= self.per_task)

    @property
    def missing(self) -> int:
        """Kept episodes still needed to fill every task's quota."""
        return sum(max(0, (self.per_task or 0) - self.kept[t]) for t in self.tasks)

    @property
    def met(self) -> bool:
        return self.per_task is not None and self.missing == 0


def _pool(job: GenerateJob, config: WorkerConfig) -> AttemptPool | RayAttemptPool:
    if job.ray is None:
        return AttemptPool(config, job.workers)
    from mgdata.generate.raypool import RayAttemptPool

    return RayAttemptPool(config, job.workers, job.ray)


def _loop(job: GenerateJob, cursor: DrawCursor, quota: Quota, config: WorkerConfig, budget: int,
          writer: DatasetWriter, failed: DatasetWriter | None, state: RunState, state_path: Path,
          summary: RunSummary, start: float, on_attempt: Callable[[RunSummary], None] | None) -> None:
    submitted = 0
    shutil.rmtree(config.stage_dir, ignore_errors=True)
    try:
        with _pool(job, config) as pool:
            while True:
                while pool.in_flight < pool.capacity and submitted < budget:
                    nxt = cursor.take(skip=quota.full)
                    if nxt is None:
                        break
                    pool.submit(*nxt)
                    submitted += 1
                if pool.in_flight == 0:
                    summary.stopped = "target reached" if quota.met else "max attempts reached"
                    return
                done = pool.next_done()
                result = done.result
                if result.task_id in quota.full:  # ran ahead of its task's quota: a one-worker run never
                    if done.staged is not None:   # makes this attempt, so it leaves no trace
                        shutil.rmtree(done.staged, ignore_errors=True)
                    submitted -= 1
                    continue
                t0 = time.process_time()
                with sigint_deferred():  # a commit and the cursor recording it happen together or not at all
                    # the count goes into the commit itself, so a kill -9 before the state file is saved
                    # loses no kept attempt from it (resume takes the larger count)
                    writer.record_attempts(state.attempts + 1)
                    try:
                        if result.kept and done.staged is not None:
                            writer.append_staged(done.staged)
                        elif done.staged is not None and failed is not None and job.keep_failed:
                            failed.append_staged(done.staged)
                        elif done.staged is not None:
                            shutil.rmtree(done.staged, ignore_errors=True)
                    except BaseException:  # not committed (disk full …): not counted, drawn again on resume
                        writer.record_attempts(state.attempts)
                        raise
                    state.next_draw[result.task_id] = max(state.next_draw.get(result.task_id, 0),
                                                          result.draw + 1)
                    state.attempts += 1
                    state.save(state_path)
                if result.kept:
                    quota.kept[result.task_id] += 1
                summary.add(result, time.process_time() - t0)
                summary.wall = time.perf_counter() - start
                if on_attempt is not None:
                    on_attempt(summary)
                if quota.met or (quota.per_task is None and summary.total_kept >= job.n):
                    summary.stopped = "target reached"
                    return
    finally:
        shutil.rmtree(config.stage_dir, ignore_errors=True)
