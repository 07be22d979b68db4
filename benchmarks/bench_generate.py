"""Generation benchmark per family (prints figures; targets from issues 4, 8 and 9).

For each family and worker count it runs ``mgdata generate`` (the same code path as the CLI, the shipped
recipe: five cameras at 256², H.264) into a fresh dataset and prints:

- wall time, kept demonstrations, attempts and the gate yield (kept / attempts; target >= 80 %);
- kept demonstrations per core-hour two ways: per **CPU-hour** (user + system CPU time of this process and
  of every worker process, from ``getrusage(RUSAGE_SELF)`` + ``getrusage(RUSAGE_CHILDREN)``: what the run
  really consumed, rendering and encoding threads included) and per **wall-core-hour** (wall time × workers:
  what the run occupied). The target (>= 150) applies to the lower of the two;
- the time split (IK/planning, physics, rendering + labelling, encoding, writing), summed over workers;
- the failure stages;
- the speed-up of the largest worker count over one worker (target >= 1.7× for 2 workers).

Rendering runs on Mesa's llvmpipe, which starts one thread per core unless told otherwise; the benchmark pins
it to one thread per worker (``LP_NUM_THREADS=1``, set before MuJoCo or any worker starts) so that a worker
is one core and the per-core figures mean what they say.

Run: ``.venv/bin/python benchmarks/bench_generate.py [--family jar clutter_dry] [--n 40] [--workers 1 2]
[--tasks all]``
"""

from __future__ import annotations

import os

os.environ["LP_NUM_THREADS"] = "1"  # before mujoco / any worker: one llvmpipe thread per worker process

import argparse
import resource
import shutil
import tempfile
from dataclasses import dataclass
from pathlib import Path

from mgdata.engine.commands import parse_ids
from mgdata.engine.generate import GenerateJob, generate
from mgdata.engine.summary import RunSummary
from mgdata.engine.timing import PHASES


def cpu_seconds() -> float:
    """User + system CPU seconds of this process and of its reaped children (the pool's workers)."""
    own, kids = resource.getrusage(resource.RUSAGE_SELF), resource.getrusage(resource.RUSAGE_CHILDREN)
    return own.ru_utime + own.ru_stime + kids.ru_utime + kids.ru_stime


@dataclass(frozen=True)
class Measured:
    summary: RunSummary
    cpu: float  # CPU seconds the run consumed (all processes)


def run(family: str, n: int, workers: int, tasks: str, root: Path) -> Measured:
    out = root / f"{family}_w{workers}"
    shutil.rmtree(out, ignore_errors=True)
    cpu0 = cpu_seconds()
    summary = generate(GenerateJob(family=family, n=n, out=out, tasks=parse_ids(tasks), workers=workers))
    return Measured(summary, cpu_seconds() - cpu0)  # the pool is joined by now: its CPU time is counted


def report(m: Measured, family: str, workers: int) -> None:
    summary = m.summary
    wall_core_h = summary.wall * workers / 3600.0
    print(f"\n== {family}, workers {workers}: {summary.stopped}")
    print(f"wall {summary.wall:.1f} s ({summary.wall / 60:.1f} min) · CPU {m.cpu:.1f} s "
          f"({m.cpu / max(summary.wall * workers, 1e-9):.0%} of wall × workers) · kept {summary.kept} · "
          f"attempts {summary.attempts} · yield {summary.yield_:.0%}")
    per_cpu_h = summary.kept / (m.cpu / 3600.0) if m.cpu > 0 else 0.0
    per_wall_core_h = summary.kept / wall_core_h if wall_core_h > 0 else 0.0
    print(f"kept per CPU-hour {per_cpu_h:.0f} · kept per wall-core-hour {per_wall_core_h:.0f} · "
          f"kept per wall-hour {summary.kept / summary.wall * 3600:.0f} · "
          f"{summary.wall / max(summary.kept, 1):.1f} s wall per kept demo")
    total = summary.timings.total or 1.0
    split = ", ".join(f"{p} {getattr(summary.timings, p):.1f} s ({getattr(summary.timings, p) / total:.0%})"
                      for p in PHASES)
    print(f"time split (summed over workers): {split}")
    print(f"failures: {dict(summary.stages) or 'none'}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--family", nargs="+", default=["jar"], help="families (recipes) to measure")
    parser.add_argument("--n", type=int, default=40, help="kept demonstrations per run")
    parser.add_argument("--workers", type=int, nargs="+", default=[1, 2])
    parser.add_argument("--tasks", default="all")
    parser.add_argument("--keep", type=Path, default=None, help="write the datasets here (default: tmp dir)")
    args = parser.parse_args()
    root = args.keep or Path(tempfile.mkdtemp(prefix="bench_generate_"))
    print(f"LP_NUM_THREADS={os.environ['LP_NUM_THREADS']} · {os.cpu_count()} cores visible")
    try:
        for family in args.family:
            results: dict[int, Measured] = {}
            for w in args.workers:
                results[w] = run(family, args.n, w, args.tasks, root)
                report(results[w], family, w)
            if 1 in results and len(results) > 1:
                most = max(results)
                one, many = results[1].summary, results[most].summary
                ratio = (many.kept / many.wall) / (one.kept / one.wall)
                print(f"\n{family}: speed-up {most} workers vs 1: {one.wall / many.wall:.2f}× "
                      f"(kept-per-wall-hour ratio {ratio:.2f}×)")
    finally:
        if args.keep is None:
            shutil.rmtree(root, ignore_errors=True)


if __name__ == "__main__":
    main()
