"""Generation benchmark for the jar family (prints figures; targets from issue 4).

For each worker count it runs ``mgdata generate`` (the same code path as the CLI, the shipped recipe: five
cameras at 256², H.264) into a fresh dataset and prints:

- wall time, kept demonstrations, attempts and the gate yield (target >= 80 %);
- kept demonstrations per core-hour, with core-hours = wall time × workers (target >= 150);
- the time split (IK/planning, physics, rendering + labelling, encoding, writing), summed over workers;
- the failure stages;
- the speed-up of the largest worker count over one worker (target >= 1.7× for 2 workers).

The issue's headline target is ``--n 40 --workers 2`` in <= 15 min on this 2-core machine.

Run: ``.venv/bin/python benchmarks/bench_generate.py [--n 40] [--workers 1 2] [--tasks all]``
"""

from __future__ import annotations

import argparse
import shutil
import tempfile
from pathlib import Path

from mgdata.engine.commands import parse_ids
from mgdata.engine.generate import GenerateJob, generate
from mgdata.engine.summary import RunSummary
from mgdata.engine.timing import PHASES


def run(n: int, workers: int, tasks: str, root: Path) -> RunSummary:
    out = root / f"jar_w{workers}"
    shutil.rmtree(out, ignore_errors=True)
    summary = generate(GenerateJob(family="jar", n=n, out=out, tasks=parse_ids(tasks), workers=workers))
    return summary


def report(summary: RunSummary, workers: int) -> None:
    core_h = summary.wall * workers / 3600.0
    print(f"\n== workers {workers}: {summary.stopped}")
    print(f"wall {summary.wall:.1f} s ({summary.wall / 60:.1f} min) · kept {summary.kept} · attempts "
          f"{summary.attempts} · yield {summary.yield_:.0%}")
    per_wall_h = summary.kept / summary.wall * 3600
    print(f"kept per core-hour {summary.kept / core_h:.0f} · kept per wall-hour {per_wall_h:.0f} · "
          f"{summary.wall / max(summary.kept, 1):.1f} s wall per kept demo")
    total = summary.timings.total or 1.0
    split = ", ".join(f"{p} {getattr(summary.timings, p):.1f} s ({getattr(summary.timings, p) / total:.0%})"
                      for p in PHASES)
    print(f"time split (summed over workers): {split}")
    print(f"failures: {dict(summary.stages) or 'none'}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--n", type=int, default=40, help="kept demonstrations per run")
    parser.add_argument("--workers", type=int, nargs="+", default=[1, 2])
    parser.add_argument("--tasks", default="all")
    parser.add_argument("--keep", type=Path, default=None, help="write the datasets here (default: tmp dir)")
    args = parser.parse_args()
    root = args.keep or Path(tempfile.mkdtemp(prefix="bench_generate_"))
    try:
        results = {}
        for w in args.workers:
            results[w] = run(args.n, w, args.tasks, root)
            report(results[w], w)
        if 1 in results and len(results) > 1:
            most = max(results)
            speedup = results[1].wall / results[most].wall
            print(f"\nspeed-up {most} workers vs 1: {speedup:.2f}× (kept-per-wall-hour ratio "
                  f"{(results[most].kept / results[most].wall) / (results[1].kept / results[1].wall):.2f}×)")
    finally:
        if args.keep is None:
            shutil.rmtree(root, ignore_errors=True)


if __name__ == "__main__":
    main()
