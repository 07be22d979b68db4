"""Generation benchmark per family (prints figures; targets from issues 4, 8, 9 and 16).

For each family (``--family``, default jar) and worker count it runs ``mgdata generate`` (the same code path
as the CLI, the shipped recipe: five cameras at 256², H.264) into a fresh dataset and prints:

- wall time, kept demonstrations, attempts and the gate yield (kept / attempts; target >= 80 %);
- kept demonstrations per core-hour two ways: per **CPU-hour** (user + system CPU time of this process and
  of every worker process, from ``getrusage(RUSAGE_SELF)`` + ``getrusage(RUSAGE_CHILDREN)``: what the run
  really consumed, rendering and encoding threads included) and per **wall-core-hour** (wall time × workers:
  what the run occupied). The target (>= 150) applies to the lower of the two;
- the time split (IK/planning, physics, rendering + labelling, encoding, writing, setup), summed over workers,
  and the wall time × workers over rendering + encoding + physics (issue 16: ≤ 1.15× at one worker);
- the failure stages;
- the speed-up of the largest worker count over one worker (target >= 1.7× for 2 workers);
- with ``--render after during``: both ways of rendering (``--render-after``, the default: attempts run
  without cameras and only kept episodes are rendered from their physics states; ``--render-during``: every
  step of every attempt is rendered while it runs) and the gain of rendering after the gate.

``--low-yield`` runs a variant of the jar recipe in which about half of the attempts fail honestly: the goal
sphere's radius is 4 cm instead of 5 and the carried jar is aimed up to 5 cm off the goal centre along x and
y (instead of 1.2 cm), so on about π·4²/10² ≈ 50 % of the draws the jar ends up held outside the goal and the
gate reports ``goal_not_reached`` after the whole motion. Use it with a few ``--tasks`` (e.g. ``0-3``):
draw 0 of every task aims at the goal centre, so the failures come from the later draws.

Rendering runs on Mesa's llvmpipe, which starts one thread per core unless told otherwise; the benchmark pins
it to one thread per worker (``LP_NUM_THREADS=1``, set before MuJoCo or any worker starts) so that a worker
is one core and the per-core figures mean what they say.

Run: ``.venv/bin/python benchmarks/bench_generate.py [--family jar clutter_dry clutter_liquid] [--n 40]
[--workers 1 2] [--tasks all] [--render after during] [--low-yield]``
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

from mgdata.engine.init_gate import forget_base_tasks
from mgdata.episode.timing import PHASES
from mgdata.generate.run import GenerateJob, generate
from mgdata.generate.summary import RunSummary
from mgdata.options import parse_ids
from mgdata.paths import recipes_dir


def cpu_seconds() -> float:
    """User + system CPU seconds of this process and of its reaped children (the pool's workers)."""
    own, kids = resource.getrusage(resource.RUSAGE_SELF), resource.getrusage(resource.RUSAGE_CHILDREN)
    return own.ru_utime + own.ru_stime + kids.ru_utime + kids.ru_stime


@dataclass(frozen=True)
class Measured:
    summary: RunSummary
    cpu: float  # CPU seconds the run consumed (all processes)


def low_yield_recipe(folder: Path) -> Path:
    """The shipped jar recipe with about half of the attempts failing at the goal (module docstring)."""
    text = (recipes_dir() / "jar.toml").read_text()
    text = text.replace('spec = "specs/jar.toml"', f'spec = "{recipes_dir() / "specs" / "jar.toml"}"')
    for old, new in (("radius = 0.05", "radius = 0.04"),
                     ("goal_dx = [-0.012, 0.012]", "goal_dx = [-0.05, 0.05]"),
                     ("goal_dy = [-0.012, 0.012]", "goal_dy = [-0.05, 0.05]")):
        if old not in text:
            raise SystemExit(f"recipes/jar.toml no longer has {old!r}: update the --low-yield variant")
        text = text.replace(old, new)
    (folder / "low_yield").mkdir(exist_ok=True)
    path = folder / "low_yield" / "jar.toml"  # a recipe's file name is its family
    path.write_text(text)
    return path


def run(family: str, n: int, workers: int, tasks: str, root: Path, render: str,
        recipe: Path | None) -> Measured:
    out = root / f"{family}_w{workers}_{render}"
    shutil.rmtree(out, ignore_errors=True)
    forget_base_tasks()  # with one worker the attempts run in this process: each run gates its own tasks
    cpu0 = cpu_seconds()
    summary = generate(GenerateJob(family=family, n=n, out=out, tasks=parse_ids(tasks), workers=workers,
                                   recipe=recipe, render_after=render == "after"))
    return Measured(summary, cpu_seconds() - cpu0)  # the pool is joined by now: its CPU time is counted


def report(m: Measured, family: str, workers: int, render: str) -> None:
    summary = m.summary
    wall_core_h = summary.wall * workers / 3600.0
    print(f"\n== {family}, workers {workers}, rendering {render} the gate: {summary.stopped}")
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
    core = sum(getattr(summary.timings, p) for p in ("rendering", "encoding", "physics"))
    print(f"wall × workers / (rendering + encoding + physics) = {summary.wall * workers:.1f} / {core:.1f} s"
          f" = {summary.wall * workers / max(core, 1e-9):.2f}×  [target ≤ 1.15× at 1 worker]")
    print(f"failures: {dict(summary.stages) or 'none'}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--family", nargs="+", default=["jar"], help="families (recipes) to measure")
    parser.add_argument("--n", type=int, default=40, help="kept demonstrations per run")
    parser.add_argument("--workers", type=int, nargs="+", default=[1, 2])
    parser.add_argument("--tasks", default="all")
    parser.add_argument("--keep", type=Path, default=None, help="write the datasets here (default: tmp dir)")
    parser.add_argument("--render", nargs="+", choices=("after", "during"), default=["after"],
                        help="render after the gate (default) and/or during execution")
    parser.add_argument("--low-yield", action="store_true", help="the ~50 %% yield jar recipe variant")
    args = parser.parse_args()
    root = args.keep or Path(tempfile.mkdtemp(prefix="bench_generate_"))
    root.mkdir(parents=True, exist_ok=True)
    if args.low_yield and args.family != ["jar"]:
        raise SystemExit("--low-yield is a variant of the jar recipe: use it with --family jar")
    recipe = low_yield_recipe(root) if args.low_yield else None
    print(f"LP_NUM_THREADS={os.environ['LP_NUM_THREADS']} · {os.cpu_count()} cores visible · families "
          f"{', '.join(args.family)}{' (jar: low-yield variant)' if args.low_yield else ''}")
    try:
        for family in args.family:
            per_cpu: dict[str, dict[int, float]] = {}
            for render in args.render:
                results: dict[int, Measured] = {}
                for w in args.workers:
                    results[w] = run(family, args.n, w, args.tasks, root, render, recipe)
                    report(results[w], family, w, render)
                if 1 in results and len(results) > 1:
                    most = max(results)
                    one, many = results[1].summary, results[most].summary
                    ratio = (many.kept / many.wall) / (one.kept / one.wall)
                    print(f"\n{family}: speed-up {most} workers vs 1: {one.wall / many.wall:.2f}× "
                          f"(kept-per-wall-hour ratio {ratio:.2f}×)")
                per_cpu[render] = {w: m.summary.kept / m.cpu for w, m in results.items()}
            if len(per_cpu) == 2:
                for w in args.workers:
                    gain = per_cpu["after"][w] / per_cpu["during"][w]
                    print(f"\n{family}: rendering after the gate vs during, {w} worker(s): {gain:.2f}× kept "
                          "per CPU-hour")
    finally:
        if args.keep is None:
            shutil.rmtree(root, ignore_errors=True)


if __name__ == "__main__":
    main()
