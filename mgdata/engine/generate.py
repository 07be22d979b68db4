"""One generation run: attempts in canonical order until the dataset holds the target number of kept demos.

The dataset at ``out`` is created or resumed (its writer recovers from a killed run). Its generator state
(``meta/mgdata_generate.json``: family, user seed, recipe digest, per-task draw cursor, attempts) must agree
with the run, and every episode already in it must carry the seed that (task, draw, --seed) gives, so a
resumed run can neither reuse a draw nor mix seeds. Kept attempts are appended to ``out``; with
``keep_failed`` the others go to ``<out>_failed`` with their labels and failure stage; otherwise they are
dropped. Ctrl-C stops at once: everything committed stays, and re-running the command continues.

Example::

    summary = generate(GenerateJob(family="jar", n=40, out=Path("datasets/jar"), workers=2))
"""

from __future__ import annotations

import hashlib
import os
import shutil
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from mgdata.atomic import remove_stale_temps
from mgdata.engine.executor import dataset_schema
from mgdata.engine.resume import DrawCursor, RunState
from mgdata.engine.summary import RunSummary
from mgdata.engine.variation import attempt_seed
from mgdata.engine.workers import AttemptPool, WorkerConfig
from mgdata.errors import DatasetError, RecipeError
from mgdata.interrupts import sigint_deferred
from mgdata.paths import grasps_dir, recipes_dir
from mgdata.record import layout
from mgdata.record.commit import work_dir
from mgdata.record.episode import EpisodeMeta
from mgdata.record.writer import DatasetWriter
from mgdata.sim.config import SIM_TOML
from mgdata.tasks.recipe import Recipe, load_recipe

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


def inputs_digest(recipe: Recipe, grasps: Path) -> str:
    """Hash of everything besides the code that shapes the data: the family recipe and its spec
    (``recipe.digest``), ``recipes/sim.toml``, ``recipes/motion.toml`` and the grasp database files."""
    h = hashlib.sha256(recipe.digest.encode())
    for path in [recipes_dir() / SIM_TOML, recipes_dir() / "motion.toml", *sorted(grasps.glob("*.json"))]:
        h.update(b"\0" + path.name.encode() + b"\0" + path.read_bytes())
    return h.hexdigest()[:16]


def generate(job: GenerateJob, on_attempt: Callable[[RunSummary], None] | None = None) -> RunSummary:
    """Run until the dataset holds ``job.n`` kept episodes, ``max_attempts`` are spent, or Ctrl-C."""
    if job.n < 1:
        raise RecipeError(f"--n must be at least 1, got {job.n}")
    if job.workers < 1:
        raise RecipeError(f"--workers must be at least 1, got {job.workers}")
    recipe = load_recipe(job.recipe or job.family)
    if recipe.family != job.family:
        raise RecipeError(f"{recipe.path} is a {recipe.family!r} recipe, not {job.family!r}")
    tasks = _tasks(job, recipe)
    schema = dataset_schema(recipe)
    out = Path(job.out)
    writer = DatasetWriter.open_or_create(out, schema, codec=job.codec, spec=recipe.spec,
                                          hold_steps=recipe.tasks.hold_steps, kept_only=True)
    failed: DatasetWriter | None = None
    summary = RunSummary(out=out, target=job.n, kept_before=writer.num_episodes)
    start = time.perf_counter()
    try:
        neg_root = failed_path(out)
        if job.keep_failed or (neg_root / layout.INFO_PATH).exists():
            failed = DatasetWriter.open_or_create(neg_root, schema, codec=job.codec, spec=recipe.spec,
                                                  hold_steps=recipe.tasks.hold_steps)
            summary.failed_out = neg_root if job.keep_failed else None
        state_path = out / STATE_FILE
        state = RunState(job.family, job.seed, inputs_digest(recipe, Path(job.grasps or grasps_dir())))
        remove_stale_temps(state_path)  # a save cut short by kill -9 (the writer's lock is ours now)
        saved = RunState.load(state_path)
        if saved is not None:
            saved.check_compatible(state, state_path)
            state = saved
        metas = writer.episodes_meta() + (failed.episodes_meta() if failed else [])
        _check_episodes(metas, job, out)
        # A kill -9 between an episode's commit and the state file's update leaves the state one attempt
        # behind the dataset: catch it up from what the dataset records.
        state.attempts = max(state.attempts, writer.recorded_attempts)
        for m in metas:
            state.next_draw[m.task_id] = max(state.next_draw.get(m.task_id, 0), m.draw_index + 1)
        cursor = DrawCursor.resume(tasks, state.next_draw, [(m.task_id, m.draw_index) for m in metas])
        missing = max(0, job.n - writer.num_episodes)
        budget = job.max_attempts if job.max_attempts is not None else max(8, 4 * missing)
        # per-run folder under staging/ (which the writer's open() clears after a crash)
        stage_dir = work_dir(out) / "staging" / f"generate-{os.getpid()}"
        config = WorkerConfig(recipe.path, Path(job.grasps or grasps_dir()), stage_dir, job.seed,
                              job.keep_failed, writer.video)
        if missing == 0:
            summary.stopped = "target already reached"
            return summary
        _loop(job, cursor, config, budget, writer, failed, state, state_path, summary, start, on_attempt)
    except KeyboardInterrupt:
        summary.stopped = "interrupted"
    finally:
        summary.wall = time.perf_counter() - start
        with sigint_deferred(reraise=False):
            writer.close()
            if failed is not None:
                failed.close()
    return summary


def _loop(job: GenerateJob, cursor: DrawCursor, config: WorkerConfig, budget: int, writer: DatasetWriter,
          failed: DatasetWriter | None, state: RunState, state_path: Path, summary: RunSummary, start: float,
          on_attempt: Callable[[RunSummary], None] | None) -> None:
    submitted = 0
    shutil.rmtree(config.stage_dir, ignore_errors=True)
    try:
        with AttemptPool(config, job.workers) as pool:
            while True:
                while pool.in_flight < pool.capacity and submitted < budget:
                    pool.submit(*cursor.take())
                    submitted += 1
                if pool.in_flight == 0:
                    summary.stopped = "max attempts reached"
                    return
                done = pool.next_done()
                result = done.result
                t0 = time.perf_counter()
                with sigint_deferred():  # a commit and the cursor recording it happen together or not at all
                    # the count goes into the commit itself, so a kill -9 before the state file is saved
                    # loses no kept attempt from it (resume takes the larger count)
                    writer.record_attempts(state.attempts + 1)
                    if result.kept and done.staged is not None:
                        writer.append_staged(done.staged)
                    elif done.staged is not None and failed is not None and job.keep_failed:
                        failed.append_staged(done.staged)
                    elif done.staged is not None:
                        shutil.rmtree(done.staged, ignore_errors=True)
                    state.next_draw[result.task_id] = max(state.next_draw.get(result.task_id, 0),
                                                          result.draw + 1)
                    state.attempts += 1
                    state.save(state_path)
                summary.add(result, time.perf_counter() - t0)
                summary.wall = time.perf_counter() - start
                if on_attempt is not None:
                    on_attempt(summary)
                if summary.total_kept >= job.n:
                    summary.stopped = "target reached"
                    return
    finally:
        shutil.rmtree(config.stage_dir, ignore_errors=True)
