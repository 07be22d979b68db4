"""The whole suite as a number (issue 42): kept demos per CPU-hour per family, camera-free and with the
shipped cameras, and the CPU-hours of the paper's release (40 kept demos per base task, every family).

For each family it runs ``mgdata generate`` twice through :mod:`bench_generate`'s ``run`` (the CLI's code
path): once with a copy of the recipes whose ``cameras = []`` (camera-free: planning, physics, labelling and
writing, the cost no GPU renderer removes) and once with the shipped recipe (five 256² cameras rendered
after the gate, H.264). CPU is user + system time of every process of the run (``getrusage``), so the
figures hold under load. Per family it prints kept/attempts, CPU-seconds per kept demo, kept per CPU-hour
and the time split by phase; then the suite table: base tasks (``recipes/<family>.toml`` ``[tasks] count``)
× 40 ÷ kept per CPU-hour, camera-free and with cameras, and each family's share.

Run: ``.venv/bin/python benchmarks/bench_suite.py [--family jar …] [--n 6] [--workers 2] [--cameras both]``
(``--cameras free`` or ``shipped`` runs one of the two; ``--json OUT`` also writes the figures).
"""

from __future__ import annotations

import os

os.environ["LP_NUM_THREADS"] = "1"  # before mujoco: one llvmpipe thread per worker (as bench_generate)

import argparse
import json
import re
import shutil
import sys
import tempfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

from bench_generate import Measured, run

from mgdata.episode.timing import PHASES
from mgdata.paths import recipes_dir
from mgdata.skeleton.skeleton import load_family_recipe
from mgdata.tasks.recipe import family_recipes

PER_TASK = 40
"""Kept demonstrations per base task in the paper's release (8,000 over 200 base tasks)."""


def camera_free_recipes(folder: Path) -> Path:
    """A copy of the recipes with every family's ``cameras = []``."""
    out = folder / "recipes_camera_free"
    shutil.rmtree(out, ignore_errors=True)
    shutil.copytree(recipes_dir(), out)
    for path in out.glob("*.toml"):
        text = path.read_text()
        path.write_text(re.sub(r"(?m)^cameras = \[.*\]", "cameras = []", text))
    return out


def figures(m: Measured) -> dict[str, float | int | dict[str, float]]:
    s = m.summary
    total = s.timings.total or 1.0
    return {"kept": s.kept, "attempts": s.attempts, "cpu_s": m.cpu, "wall_s": s.wall,
            "cpu_s_per_kept": m.cpu / max(s.kept, 1), "kept_per_cpu_h": s.kept / (m.cpu / 3600.0),
            "split": {p: getattr(s.timings, p) / total for p in PHASES}}


def line(family: str, mode: str, f: dict) -> str:
    split = " ".join(f"{p} {share:.0%}" for p, share in f["split"].items() if share >= 0.005)
    return (f"{family:15s} {mode:11s} kept {f['kept']:3d}/{f['attempts']:3d}  "
            f"{f['cpu_s_per_kept']:6.1f} CPU-s/kept  {f['kept_per_cpu_h']:7.0f} kept/CPU-h  [{split}]")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--family", nargs="+", default=list(family_recipes()))
    parser.add_argument("--n", type=int, default=6, help="kept demonstrations per family and mode")
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--cameras", choices=("both", "free", "shipped"), default="both")
    parser.add_argument("--json", type=Path, default=None)
    args = parser.parse_args()
    root = Path(tempfile.mkdtemp(prefix="bench_suite_"))
    free = camera_free_recipes(root)
    modes = {"both": ("free", "shipped"), "free": ("free",), "shipped": ("shipped",)}[args.cameras]
    print(f"{os.cpu_count()} cores visible · --n {args.n} · --workers {args.workers} · {', '.join(modes)}")
    results: dict[str, dict[str, dict]] = {}
    try:
        for family in args.family:
            results[family] = {}
            for mode in modes:
                recipe = free / f"{family}.toml" if mode == "free" else None
                measured = run(family, args.n, args.workers, "all", root, "after", recipe)
                results[family][mode] = figures(measured)
                print(line(family, mode, results[family][mode]), flush=True)
                shutil.rmtree(root / f"{family}_w{args.workers}_after", ignore_errors=True)
    finally:
        shutil.rmtree(root, ignore_errors=True)
    print(f"\nThe suite at {PER_TASK} kept per base task "
          f"(CPU-hours = tasks × {PER_TASK} ÷ kept per CPU-hour):")
    print(f"{'family':15s} {'tasks':>5s} " + " ".join(f"{m + ' CPU-h':>14s} {'share':>6s}" for m in modes))
    totals = {m: sum(load_family_recipe(f).tasks.count * PER_TASK / results[f][m]["kept_per_cpu_h"]
                     for f in results) for m in modes}
    for family in results:
        tasks = load_family_recipe(family).tasks.count
        cells = []
        for m in modes:
            hours = tasks * PER_TASK / results[family][m]["kept_per_cpu_h"]
            cells.append(f"{hours:14.1f} {hours / totals[m]:6.0%}")
        print(f"{family:15s} {tasks:5d} " + " ".join(cells))
    print(f"{'all':15s} {'':5s} " + " ".join(f"{totals[m]:14.1f} {'':6s}" for m in modes))
    if args.json:
        args.json.write_text(json.dumps({"n": args.n, "workers": args.workers, "families": results,
                                         "suite_cpu_hours": totals}, indent=1) + "\n")


if __name__ == "__main__":
    main()
