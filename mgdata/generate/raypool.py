"""Attempts on a Ray cluster (``mgdata generate … --ray [ADDRESS]``, the optional extra ``mgdata[ray]``).

:class:`RayAttemptPool` has :class:`~mgdata.generate.workers.AttemptPool`'s interface: attempts are submitted
in the draw cursor's canonical order and handed back in that order, so the main process commits exactly
what a ``--workers 1`` run commits and the dataset is byte-identical. Each Ray actor holds one
:class:`~mgdata.generate.workers.Worker` (one CPU); it stages an episode in a folder of its own machine and
returns the folder's files, which the main process writes into its staging area.

Before any attempt, every actor reports its :class:`~mgdata.generate.fingerprint.Fingerprint` (versions, CPU
features, GL renderer, the digest of the recipe and grasp files it reads); one that differs from the main
process's is refused with a :class:`~mgdata.errors.WorkerError` naming the difference, so results that
could break determinism are never mixed. Nodes must see the recipe and grasp files at the same paths (a
shared file system or the same checkout).

``--ray`` without an address starts a private local Ray instance (one CPU per worker, a bounded object
store, no dashboard) and stops it at the end; ``--ray ADDRESS`` joins a running cluster (``ray start``).

Example::

    with RayAttemptPool(config, workers=8, address="ray://head:10001") as pool:
        pool.submit(task_id=0, draw=0)
        done = pool.next_done()
"""

from __future__ import annotations

import collections
import contextlib
import dataclasses
import os
import shutil
import tempfile
from pathlib import Path
from types import TracebackType
from typing import Any

from mgdata.engine.executor import AttemptResult
from mgdata.errors import RecipeError, WorkerError
from mgdata.generate.fingerprint import Fingerprint, local_fingerprint
from mgdata.generate.workers import AttemptDone, Worker, WorkerConfig

LOCAL = "local"
"""``--ray`` without an address: a private Ray instance on this machine."""
OBJECT_STORE_BYTES = 256 * 2**20
"""Object store of a local instance: staged episodes pass through it one at a time per worker (a five-camera
256² jar episode is a few MB)."""
PASSED_ENV = ("LP_NUM_THREADS", "MUJOCO_GL", "SVT_LOG")
START_TIMEOUT_S = 600.0
"""How long the actors may take to start and report their fingerprints (each needs one free CPU somewhere in
the cluster: a cluster with fewer free CPUs than ``--workers`` is an error, not a wait forever)."""
RERUN = "everything committed so far is kept: run the same command again to resume"


STAGE_PREFIX = "mgdata-ray-"


def _remove_orphans() -> None:
    """Delete the staging folders of actors on this machine that were killed (their process is gone)."""
    for path in Path(tempfile.gettempdir()).glob(f"{STAGE_PREFIX}*-*"):
        pid = path.name[len(STAGE_PREFIX):].split("-", 1)[0]
        if pid.isdigit() and not Path(f"/proc/{pid}").exists():
            shutil.rmtree(path, ignore_errors=True)


def _inputs_digest(config: WorkerConfig) -> str:
    from mgdata.engine.inputs import inputs_digest
    from mgdata.skeleton.skeleton import load_family_recipe

    return inputs_digest(load_family_recipe(config.recipe_path), config.grasps_dir)


class NodeWorker:
    """A Ray actor's state: a :class:`Worker` staging into a private folder on its own machine."""

    def __init__(self, config: WorkerConfig) -> None:
        import mgdata  # noqa: F401  (chooses the headless GL backend before MuJoCo is imported)

        _remove_orphans()
        self.stage = Path(tempfile.mkdtemp(prefix=f"{STAGE_PREFIX}{os.getpid()}-"))
        self.config = dataclasses.replace(config, stage_dir=self.stage)
        self.worker: Worker | None = None
        self.error: Exception | None = None
        try:
            self.worker = Worker(self.config)
        except Exception as err:  # reported with the fingerprint, raised in the main process
            self.error = err

    def fingerprint(self) -> Fingerprint:
        if self.error is not None:
            raise self.error
        return local_fingerprint(_inputs_digest(self.config))

    def run(self, task_id: int, draw: int) -> tuple[AttemptResult, dict[str, bytes] | None]:
        assert self.worker is not None
        done = self.worker.run(task_id, draw)
        if done.staged is None:
            return done.result, None
        files = {p.name: p.read_bytes() for p in sorted(done.staged.iterdir())}
        shutil.rmtree(done.staged)
        return done.result, files

    def close(self) -> None:
        if self.worker is not None:
            self.worker.close()
        shutil.rmtree(self.stage, ignore_errors=True)


class RayAttemptPool:
    """Submit attempts to Ray actors; get them back finished, in submission order (module docstring)."""

    def __init__(self, config: WorkerConfig, workers: int, address: str = LOCAL) -> None:
        try:
            import ray
        except ImportError:
            raise RecipeError("--ray needs Ray: pip install 'mgdata[ray]'") from None
        if workers < 1:
            raise ValueError(f"workers must be >= 1, got {workers}")
        self._ray = ray
        self.config = config
        self.workers = workers
        self.capacity = 2 * workers
        self._queue: collections.deque[tuple[int, int, Any, int]] = collections.deque()
        self._busy = [0] * workers
        self._started = False
        env = {k: os.environ[k] for k in PASSED_ENV if k in os.environ}
        env.setdefault("LP_NUM_THREADS", "1")  # one worker = one core, renderer included
        options: dict[str, Any] = {"runtime_env": {"env_vars": env}, "include_dashboard": False,
                                   "log_to_driver": False, "configure_logging": False}
        if not ray.is_initialized():
            try:
                if address == LOCAL:
                    ray.init(num_cpus=workers, object_store_memory=OBJECT_STORE_BYTES, **options)
                else:
                    ray.init(address=address, **options)
            except Exception as err:  # Ray raises ConnectionError, ValueError, RuntimeError …
                raise WorkerError(f"--ray {address}: cannot start or reach Ray ({err})") from None
            self._started = True
        actor = ray.remote(num_cpus=1, max_restarts=0)(NodeWorker)
        self._actors = [actor.remote(config) for _ in range(workers)]
        try:
            self._check_fingerprints()
        except BaseException:
            self.close()
            raise

    def _check_fingerprints(self) -> None:
        mine = local_fingerprint(_inputs_digest(self.config))
        theirs = self._get([a.fingerprint.remote() for a in self._actors], timeout=START_TIMEOUT_S)
        for fp in theirs:
            problems = mine.differences(fp)
            if problems:
                raise WorkerError(f"Ray node {fp.host or '?'} would not reproduce this machine's results "
                                  f"({'; '.join(problems)}); refusing to mix them: run its attempts on "
                                  "matching machines only")

    def _get(self, refs: Any, timeout: float | None = None) -> Any:
        ray = self._ray
        try:
            return ray.get(refs, timeout=timeout)
        except ray.exceptions.RayTaskError as err:  # the attempt raised: raise its own error here
            cause = getattr(err, "cause", None)
            if isinstance(cause, BaseException):
                raise cause from None
            raise
        except ray.exceptions.GetTimeoutError:
            cpus = ray.cluster_resources().get("CPU", 0)
            raise WorkerError(f"Ray did not start {self.workers} workers within {START_TIMEOUT_S:.0f} s "
                              f"(each needs one free CPU; the cluster has {cpus:g}): add nodes or ask for "
                              "fewer --workers") from None
        except ray.exceptions.RayActorError:  # its process died, or the node it ran on
            raise WorkerError(f"a Ray worker died; {RERUN}") from None
        except ray.exceptions.RayError as err:  # a node lost with an attempt's result, Ray's own processes
            raise WorkerError(f"a Ray node or object was lost ({type(err).__name__}); {RERUN}") from None

    @property
    def in_flight(self) -> int:
        return len(self._queue)

    def submit(self, task_id: int, draw: int) -> None:
        k = min(range(self.workers), key=self._busy.__getitem__)  # the least busy actor
        self._busy[k] += 1
        self._queue.append((task_id, draw, self._actors[k].run.remote(task_id, draw), k))

    def next_done(self) -> AttemptDone:
        """The oldest submitted attempt, waiting for it if needed; its staged files are written here."""
        task_id, draw, ref, k = self._queue.popleft()
        result, files = self._get(ref)
        self._busy[k] -= 1
        if files is None:
            return AttemptDone(result, None)
        path = self.config.stage_dir / f"task{task_id:04d}-draw{draw:06d}"
        partial = path.with_name(path.name + ".partial")
        shutil.rmtree(partial, ignore_errors=True)
        partial.mkdir(parents=True)
        for name, data in files.items():
            (partial / name).write_bytes(data)
        os.replace(partial, path)
        return AttemptDone(result, path)

    def close(self) -> None:
        """Stop the actors (attempts in flight are dropped) and a Ray instance this pool started."""
        ray = self._ray
        actors, self._actors = getattr(self, "_actors", []), []
        if actors and not self._queue:  # idle: let them free their GL contexts and staging folders
            with contextlib.suppress(Exception):
                ray.get([a.close.remote() for a in actors], timeout=60)
        for a in actors:
            with contextlib.suppress(Exception):  # an actor whose node is gone
                ray.kill(a, no_restart=True)
        self._queue.clear()
        if self._started:
            ray.shutdown()  # stops this machine's Ray processes, killed actors included
            self._started = False
            _remove_orphans()

    def __enter__(self) -> RayAttemptPool:
        return self

    def __exit__(self, exc_type: type[BaseException] | None, exc: BaseException | None,
                 tb: TracebackType | None) -> None:
        self.close()
