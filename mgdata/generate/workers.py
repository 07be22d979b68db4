"""Attempt workers: run attempts in this process or in a pool of processes, results in canonical order.

Each attempt is recorded into its own staged-episode folder (``EpisodeStager``); the main process appends
staged folders to the dataset in the order the attempts were *submitted* (the cursor's canonical order), so
the dataset is byte-identical whatever the number of workers. A worker keeps a few executors (scene,
planner, renderer) for recently used tasks. With ``render_after`` (the default) attempts run without
cameras and only recorded episodes are rendered, from their physics states, when they end
(:class:`~mgdata.episode.deferred.DeferredRenderSink`): the same bytes, no rendering for dropped attempts.
Worker processes are started with ``spawn`` (a fresh interpreter: no inherited OpenGL or OMPL state) and
ignore Ctrl-C; the main process handles it and terminates them.

The pool fails fast: a worker whose start-up raises (a bad input the main process did not catch) hands that
error to the first attempt it is given, which re-raises it in the main process; a worker that dies (killed,
crashed) breaks the pool and the run ends with :class:`WorkerError`. Workers are never respawned, so a
start-up that always fails cannot loop.

Example::

    with AttemptPool(config, workers=2) as pool:
        pool.submit(task_id=0, draw=0)
        done = pool.next_done()          # results come back in submission order
"""

from __future__ import annotations

import collections
import multiprocessing as mp
import os
import signal
from collections.abc import Callable, Mapping
from concurrent.futures import Future, ProcessPoolExecutor
from concurrent.futures.process import BrokenProcessPool
from dataclasses import dataclass
from pathlib import Path
from types import TracebackType
from typing import Any

import numpy as np

from mgdata.engine.executor import AttemptResult, Executor
from mgdata.engine.init_gate import base_task
from mgdata.episode.deferred import DeferredRenderSink
from mgdata.episode.timing import Timings
from mgdata.errors import RecipeError, WorkerError
from mgdata.grasps.db import GraspDB
from mgdata.pool_worker import die_with_parent
from mgdata.record.episode import EpisodeSink
from mgdata.record.staging import EpisodeStager
from mgdata.record.video import VideoSettings
from mgdata.scenarios.conditions import attempt_condition, variant
from mgdata.sim.renderer import CameraRig
from mgdata.sim.taskspec import TaskSpec
from mgdata.skeleton.skeleton import load_family_recipe
from mgdata.tasks.recipe import with_recovery

EXECUTOR_CACHE = 2
"""Executors (one per task) kept alive per worker; rebuilding one costs a fraction of an attempt."""


@dataclass(frozen=True)
class WorkerConfig:
    """Everything a worker needs, as plain picklable data."""

    recipe_path: Path
    grasps_dir: Path
    stage_dir: Path
    base_seed: int
    keep_failed: bool
    video: VideoSettings
    render_after: bool = True
    condition: str = "base"
    recovery: str | None = None


@dataclass(frozen=True)
class AttemptDone:
    """A finished attempt: its result and, if it was recorded, the staged episode folder."""

    result: AttemptResult
    staged: Path | None


class Worker:
    """Runs attempts for any task of one recipe (one instance per process)."""

    def __init__(self, config: WorkerConfig) -> None:
        from mgdata.engine.executor import dataset_schema

        self.config = config
        self.recipe = with_recovery(load_family_recipe(config.recipe_path), config.recovery)
        if self.recipe.appearance.enabled and not config.render_after and self.recipe.tasks.cameras:
            raise RecipeError(f"{config.recipe_path}: [appearance] draws each episode's look when it is "
                              "rendered after the gate; drop --render-during")
        self.schema = dataset_schema(self.recipe)
        self.grasps = GraspDB.load_dir(config.grasps_dir)
        self._tasks: dict[tuple[int, str], TaskSpec] = {}
        self._executors: collections.OrderedDict[tuple[int, str], tuple[Executor, CameraRig | None]] = \
            collections.OrderedDict()

    def executor(self, task_id: int, condition: str, timings: Timings) -> tuple[Executor, CameraRig | None]:
        """The executor of the task in ``condition`` (the task as ``mgdata scenarios`` builds it) and, when
        rendering after the gate, the rig that renders its episodes (the time a new one takes goes into
        ``timings``)."""
        key = (task_id, condition)
        if key in self._executors:
            self._executors.move_to_end(key)
            return self._executors[key]
        while len(self._executors) >= EXECUTOR_CACHE:
            self._close(*self._executors.popitem(last=False)[1])
        after = self.config.render_after
        if key not in self._tasks:  # a location variant is gated anew: build each once per process
            with timings.measure("planning"):  # the initial-state gate's IK
                task = base_task(self.recipe, task_id, self.config.grasps_dir)
                self._tasks[key] = task if condition == "base" else variant(self.recipe, task, condition,
                                                                            self.grasps)[0]
        task = self._tasks[key]
        with timings.measure("setup"):
            ex = Executor(task, self.recipe, grasps=self.grasps, base_seed=self.config.base_seed,
                          render=not after)
            rig = CameraRig(ex.scene, self.recipe.tasks.cameras, task.image_size) \
                if after and self.recipe.tasks.cameras else None
        self._executors[key] = (ex, rig)
        return ex, rig

    def run(self, task_id: int, draw: int, *, condition: str | None = None, start: np.ndarray | None = None,
            origin: Mapping[str, Any] | None = None, source: str = "planner", name: str | None = None
            ) -> AttemptDone:
        """Attempt ``draw`` of ``task_id`` in ``condition`` (default: the run's condition for that draw),
        staged in ``name`` under the stage folder (default ``task<id>-draw<draw>``); ``start``, ``origin``
        and ``source`` are the executor's (a restart, :meth:`Executor.run`)."""
        path = self.config.stage_dir / (name or f"task{task_id:04d}-draw{draw:06d}")
        stager = EpisodeStager(path, self.schema, self.config.video)
        setup = Timings()
        ex, rig = self.executor(task_id, condition or attempt_condition(self.config.condition, draw), setup)
        deferred = DeferredRenderSink(stager, rig, self.recipe.appearance) if rig is not None else None
        sink: EpisodeSink = deferred if deferred is not None else stager
        try:
            result = ex.run(draw, sink, keep_failed=self.config.keep_failed, start=start, origin=origin,
                            source=source)
        except BaseException:
            sink.discard_episode()
            raise
        if deferred is not None:  # the executor timed the deferred work as writing: split it up
            spent = deferred.timings
            result.timings.writing -= spent.total
            result.timings.add(spent)
        result.timings.add(setup)
        return AttemptDone(result, path if stager.done else None)

    @staticmethod
    def _close(ex: Executor, rig: CameraRig | None) -> None:
        ex.close()
        if rig is not None:
            rig.close()

    def close(self) -> None:
        for ex, rig in self._executors.values():
            self._close(ex, rig)
        self._executors.clear()


_WORKER: Worker | None = None
_START_ERROR: BaseException | None = None


def _init_worker(config: WorkerConfig, parent: int) -> None:
    """Build this process's :class:`Worker`; a failure is kept and raised by every attempt (never a crash
    at start-up, which a pool would answer with a new process failing the same way)."""
    global _WORKER, _START_ERROR
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # Ctrl-C is the main process's: it decides what to keep
    die_with_parent(parent)
    try:
        _WORKER = Worker(config)
    except Exception as err:  # handed to the main process with the first attempt
        _START_ERROR = err


def _run_in_worker(fn: Callable[..., Any], *args: Any) -> Any:
    if _START_ERROR is not None:
        raise _START_ERROR
    assert _WORKER is not None
    return fn(_WORKER, *args)


class AttemptPool:
    """Submit attempts (or any work a :class:`Worker` does, :meth:`call`); get them back finished, in
    submission order.

    ``workers == 1`` runs each attempt in this process when its result is asked for (Ctrl-C interrupts it
    cleanly); more workers run in ``spawn``-ed processes with up to ``2 × workers`` attempts in flight.
    """

    def __init__(self, config: WorkerConfig, workers: int = 1) -> None:
        if workers < 1:
            raise ValueError(f"workers must be >= 1, got {workers}")
        self.workers = workers
        self.capacity = 1 if workers == 1 else 2 * workers
        self._queue: collections.deque[tuple[Callable[..., Any], tuple[Any, ...], Future[Any] | None]] = \
            collections.deque()
        self._local = Worker(config) if workers == 1 else None
        self._pool = None if workers == 1 else ProcessPoolExecutor(
            workers, mp_context=mp.get_context("spawn"), initializer=_init_worker,
            initargs=(config, os.getpid()))

    @property
    def in_flight(self) -> int:
        return len(self._queue)

    def submit(self, task_id: int, draw: int) -> None:
        """Attempt ``draw`` of ``task_id`` (:meth:`Worker.run`); :meth:`next_done` gives its
        :class:`AttemptDone`."""
        self.call(Worker.run, task_id, draw)

    def call(self, fn: Callable[..., Any], *args: Any) -> None:
        """Run ``fn(worker, *args)`` in a worker (``fn``: a module-level function, picklable by name)."""
        handle = None
        if self._pool is not None:
            try:
                handle = self._pool.submit(_run_in_worker, fn, *args)
            except BrokenProcessPool:
                raise self._died() from None
        self._queue.append((fn, args, handle))

    def next_done(self) -> Any:
        """The oldest submitted work's result, waiting for it if needed.

        Raises:
            WorkerError: a worker process died (killed or crashed) before returning it.
        """
        fn, args, handle = self._queue.popleft()
        if handle is None:
            assert self._local is not None
            return fn(self._local, *args)
        try:
            return handle.result()
        except BrokenProcessPool:
            raise self._died() from None

    def _died(self) -> WorkerError:
        codes = sorted({p.exitcode for p in self._processes() if p.exitcode not in (None, 0)})
        how = f" (exit code {', '.join(map(str, codes))})" if codes else ""
        return WorkerError(f"a worker process died{how}; everything committed so far is kept, run the same "
                           "command again to resume (with --workers 1 to see the error in this process)")

    def _processes(self) -> list[mp.process.BaseProcess]:
        # ProcessPoolExecutor has no public way to kill its workers before Python 3.14
        return list((getattr(self._pool, "_processes", None) or {}).values())

    def close(self) -> None:
        """Stop the workers, killing attempts still in flight (their results are no longer wanted)."""
        if self._pool is not None:
            procs = self._processes()
            self._pool.shutdown(wait=False, cancel_futures=True)
            for p in procs:
                p.terminate()
            for p in procs:
                p.join()
            self._pool = None
        if self._local is not None:
            self._local.close()
            self._local = None
        self._queue.clear()

    def __enter__(self) -> AttemptPool:
        return self

    def __exit__(self, exc_type: type[BaseException] | None, exc: BaseException | None,
                 tb: TracebackType | None) -> None:
        self.close()
