"""``mgdata eval``: every (scenario, seed) of a scenario set rolled out against a policy server, resumable
and parallel, into ``<out>/rollouts.jsonl``.

* **Plan.** The manifest's scenarios (optionally one family / condition), each under every seed, in the
  manifest's (family, task, condition) order, seeds inner.
* **Resume.** Each finished rollout is appended to ``rollouts.jsonl`` as one line and flushed to disk before
  the next is counted; a rerun skips the (scenario, seed) pairs already there (a line torn by a kill is
  dropped and re-run). ``<out>/eval.json`` records the settings and the policy server's metadata frame; a
  rerun with others is refused (the server's URL may change).
* **Recording** (``LoopSettings.record_dir``, ``mgdata eval --record``): each rollout's episode is staged
  before its record is appended, and the staged episodes are appended in plan order to
  ``<out>/rollouts/<family>`` when every rollout is in (:mod:`mgdata.evaluate.recorded`).
* **Workers.** ``workers`` spawned processes each run whole rollouts (their own scene, renderer and
  connection). When every rollout is in, the file is rewritten in plan order, so it is byte-identical for
  any worker count (a record does not depend on wall time, order or which process ran it).

Example::

    job = EvalJob(Path("scenarios"), LoopSettings("ws://127.0.0.1:8000"), seeds=(0, 1, 2),
                  out=Path("results"))
    summary = run_eval(job)
"""

from __future__ import annotations

import json
import multiprocessing
import os
from collections.abc import Callable
from concurrent.futures import FIRST_COMPLETED, Future, ProcessPoolExecutor, wait
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from mgdata.atomic import write_text_atomic
from mgdata.errors import DatasetError, OutputError
from mgdata.evaluate.client import PolicyClient
from mgdata.evaluate.rollout import LoopSettings, RolloutJob, run_rollout, video_name
from mgdata.lock import output_lock
from mgdata.pool_worker import die_with_parent
from mgdata.scenarios.store import read_manifest

RESULTS = "rollouts.jsonl"
SETTINGS = "eval.json"


@dataclass(frozen=True)
class EvalJob:
    """What to evaluate: a scenario set, the loop settings, filters, seeds, output folder, workers."""

    scenarios: Path
    settings: LoopSettings
    seeds: tuple[int, ...] = (0, 1, 2)
    out: Path = Path("results")
    families: tuple[str, ...] | None = None
    conditions: tuple[str, ...] | None = None
    workers: int = 1


@dataclass(frozen=True)
class EvalSummary:
    """What a run did: rollouts planned, already done before it, run by it; the results file."""

    planned: int
    resumed: int
    ran: int
    results: Path


def plan(job: EvalJob) -> list[RolloutJob]:
    """Every rollout of ``job`` in canonical order.

    Raises:
        DatasetError: no manifest, or no scenario left after the filters.
    """
    entries = read_manifest(job.scenarios)
    chosen = [e for e in entries if (job.families is None or e["family"] in job.families)
              and (job.conditions is None or e["condition"] in job.conditions)]
    if not chosen:
        filters = (("family", job.families), ("condition", job.conditions))
        what = ", ".join(f"{k} {', '.join(v)}" for k, v in filters if v)
        raise DatasetError(f"{job.scenarios}: no scenarios{' with ' + what if what else ''} "
                           f"(the manifest lists {len(entries)})")
    return [RolloutJob(job.scenarios, e["path"], s) for e in chosen for s in job.seeds]


def _settings_record(job: EvalJob, metadata: dict[str, Any]) -> dict[str, Any]:
    """What makes two runs the same evaluation: the scenarios, the loop settings that change a record, and
    the policy's own metadata frame (not its URL: a restarted server on another port is the same policy)."""
    s = job.settings
    loop = {"convention": s.convention, "cameras": None if s.cameras is None else list(s.cameras),
            "chunk_steps": s.chunk_steps, "timeout_s": s.timeout_s, "horizon": s.horizon}
    if s.ensemble is not None:  # absent when off: results written before ensembling existed still resume
        loop["ensemble"] = s.ensemble
    if s.record_dir is not None:  # likewise: a recorded run's every rollout must be recorded
        loop["record"] = True
    return {"scenarios": str(job.scenarios), "loop": loop,
            "policy_metadata": json.loads(json.dumps(metadata, sort_keys=True, default=repr))}


def read_results(path: Path) -> list[dict[str, Any]]:
    """The complete records of a results file (a torn last line is left out)."""
    if not path.exists():
        return []
    records = []
    for line in path.read_text(encoding="utf-8").splitlines():
        try:
            records.append(json.loads(line))
        except json.JSONDecodeError:
            continue  # the line a kill tore
    return records


def _append(path: Path, record: dict[str, Any]) -> None:
    with path.open("a", encoding="utf-8") as f:
        f.write(json.dumps(record, sort_keys=True) + "\n")
        f.flush()
        os.fsync(f.fileno())


def _prepare(job: EvalJob, metadata: dict[str, Any]) -> Path:
    out = Path(job.out)
    if out.exists() and not out.is_dir():
        raise OutputError(f"--out {out}: exists and is not a folder")
    out.mkdir(parents=True, exist_ok=True)
    wanted = _settings_record(job, metadata)
    settings = out / SETTINGS
    if settings.exists():
        try:
            before = json.loads(settings.read_text(encoding="utf-8"))
        except json.JSONDecodeError:
            before = None
        if before is not None and before != wanted:
            raise OutputError(f"--out {out}: holds results of another evaluation ({SETTINGS} differs: the "
                              "policy's metadata, convention, cameras, chunk steps, timeout, horizon or "
                              "scenarios); choose a new --out")
    write_text_atomic(settings, json.dumps(wanted, indent=1, sort_keys=True) + "\n")
    results = out / RESULTS
    good = read_results(results)
    text = "".join(json.dumps(r, sort_keys=True) + "\n" for r in good)
    if results.exists() and results.read_text(encoding="utf-8") != text:
        write_text_atomic(results, text)  # drop a torn last line before appending
    return results


def run_eval(job: EvalJob, on_record: Callable[[dict[str, Any]], None] | None = None,
             on_plan: Callable[[int, int], None] | None = None) -> EvalSummary:
    """:func:`_run_eval` holding ``job.out``'s one-writer lock (:func:`mgdata.lock.output_lock`)."""
    with output_lock(job.out):
        return _run_eval(job, on_record, on_plan)


def _run_eval(job: EvalJob, on_record: Callable[[dict[str, Any]], None] | None = None,
              on_plan: Callable[[int, int], None] | None = None) -> EvalSummary:
    """Run every rollout of ``job`` not in the results yet (see the module docstring).

    ``on_plan(total, done)`` is called once before the first rollout, ``on_record`` after each one.
    """
    rollouts = plan(job)
    with PolicyClient(job.settings.policy, timeout=job.settings.timeout_s,
                      connect_timeout=job.settings.connect_timeout_s) as client:
        metadata = client.metadata
    results = _prepare(job, metadata)
    done = {(r["scenario"], r["seed"]) for r in read_results(results)}
    todo = [r for r in rollouts if r.key not in done]
    if on_plan is not None:
        on_plan(len(rollouts), len(rollouts) - len(todo))

    def finished(record: dict[str, Any]) -> None:
        _append(results, record)
        if on_record is not None:
            on_record(record)

    if job.workers <= 1 or len(todo) <= 1:
        for r in todo:
            finished(run_rollout(r, job.settings))
    else:
        _parallel(todo, job, finished)
    order = {r.key: i for i, r in enumerate(rollouts)}
    records = [r for r in read_results(results) if (r["scenario"], r["seed"]) in order]
    records.sort(key=lambda r: order[(r["scenario"], r["seed"])])
    write_text_atomic(results, "".join(json.dumps(r, sort_keys=True) + "\n" for r in records))
    if job.settings.record_dir is not None:
        from mgdata.evaluate.recorded import append_staged

        append_staged(job.settings.record_dir, [video_name(r) for r in rollouts], job.scenarios)
    return EvalSummary(len(rollouts), len(rollouts) - len(todo), len(todo), results)


def _parallel(todo: list[RolloutJob], job: EvalJob, finished: Callable[[dict[str, Any]], None]) -> None:
    """Run ``todo`` in ``job.workers`` spawned processes, at most ``workers`` in flight (so a failure stops
    the run after little wasted work); records are handed to ``finished`` as they arrive."""
    pending = list(reversed(todo))
    with ProcessPoolExecutor(job.workers, mp_context=multiprocessing.get_context("spawn"),
                             initializer=die_with_parent, initargs=(os.getpid(),)) as pool:
        running: set[Future[dict[str, Any]]] = set()
        try:
            while pending or running:
                while pending and len(running) < job.workers:
                    running.add(pool.submit(run_rollout, pending.pop(), job.settings))
                done, running = wait(running, return_when=FIRST_COMPLETED)
                for f in done:
                    finished(f.result())
        except BaseException:
            for f in running:
                f.cancel()
            raise
