"""How long locked scenarios take to build, per condition, and what the whole set would take.

Builds the chosen tasks of each family into a fresh temporary folder (nothing is reused) in this one process,
timing every scenario, and prints per family and condition the mean seconds, the location proposals the gate
needed, and the time all of the family's tasks would take at that rate (one process; the issue's target is
1,000 scenarios in 30 min on 2 cores). The CPU time is printed too, since a busy machine inflates wall time.
Last, the model store: the MJB bytes of all built scenarios against the bytes their shared chunks take.

Run: ``.venv/bin/python benchmarks/bench_scenarios.py --family jar clutter_dry clutter_liquid --tasks 3``
"""

from __future__ import annotations

import argparse
import json
import tempfile
import time
from collections import defaultdict
from pathlib import Path

from mgdata.engine.init_gate import base_task
from mgdata.scenarios.store import CHUNKS, build_scenario
from mgdata.skeleton.skeleton import load_family_recipe
from mgdata.tasks.variants import CONDITIONS


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--family", nargs="+", default=["jar", "clutter_dry", "clutter_liquid"])
    parser.add_argument("--tasks", type=int, default=2, help="first N tasks of each family")
    args = parser.parse_args()
    total_est = 0.0
    with tempfile.TemporaryDirectory() as tmp:
        for family in args.family:
            recipe = load_family_recipe(family)
            wall: dict[str, list[float]] = defaultdict(list)
            cpu: dict[str, list[float]] = defaultdict(list)
            attempts = []
            for k in range(min(args.tasks, recipe.tasks.count)):
                w0, c0 = time.perf_counter(), time.process_time()
                base_task(recipe, k)
                wall["gate"].append(time.perf_counter() - w0)
                cpu["gate"].append(time.process_time() - c0)
                for condition in CONDITIONS:
                    w0, c0 = time.perf_counter(), time.process_time()
                    build_scenario(recipe, k, condition, Path(tmp))
                    wall[condition].append(time.perf_counter() - w0)
                    cpu[condition].append(time.process_time() - c0)
                meta = json.loads(
                    (Path(tmp) / family / f"task_{k:04d}" / "location" / "scenario.json").read_text()
                )
                attempts.append(meta["gate"]["attempts"])
            per_task = sum(sum(v) / len(v) for v in cpu.values())
            print(
                f"{family}: {len(attempts)} tasks; CPU s per scenario: "
                + ", ".join(f"{c} {sum(v) / len(v):.1f}" for c, v in cpu.items())
                + f"; wall s per task {sum(sum(v) / len(v) for v in wall.values()):.1f}"
                + f"; location proposals per task {attempts}"
            )
            est = per_task * recipe.tasks.count
            total_est += est
            print(f"  all {recipe.tasks.count} tasks × 5 conditions: {est / 60:.1f} CPU min")
        metas = [json.loads(p.read_text()) for p in sorted(Path(tmp).glob("*/task_*/*/scenario.json"))]
        mjb = sum(m["model_size"] for m in metas)
        stored = sum(p.stat().st_size for p in (Path(tmp) / CHUNKS).rglob("*.gz"))
        print(
            f"model store: {len(metas)} models, {mjb / 1e6:.0f} MB of MJB in {stored / 1e6:.1f} MB of chunks "
            f"({stored / len(metas) / 1e3:.0f} kB per scenario)"
        )
    print(
        f"total for {', '.join(args.family)}: {total_est / 60:.1f} CPU min "
        f"({total_est / 120:.1f} min on 2 idle cores)"
    )


if __name__ == "__main__":
    main()
