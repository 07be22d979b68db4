"""Evaluation throughput: control steps per CPU-second, client and policy server together, two cameras
rendered (issue 15's target: >= 100).

Serves a reference policy with ``mgdata serve`` (a separate process, as in real use) and rolls it out in this
process on stored scenarios, each cut at ``--steps`` control steps, for each ``--chunk-steps`` value (1: the
cameras are rendered and the policy queried at every step; 8: the default). CPU time is this process's
(restore, physics, labelling, monitoring, rendering, encoding requests) plus the server's (from
``/proc/<pid>/stat``), so the figure does not depend on how busy the machine is; wall time is printed too.

Run: ``LP_NUM_THREADS=1 .venv/bin/python benchmarks/bench_eval.py --scenarios /tmp/scen``
(without ``--scenarios``, jar task 0's base scenario is built into a temporary folder first).
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from mgdata.evaluate.rollout import LoopSettings, RolloutJob, rollout
from mgdata.scenarios.store import build_scenario, read_manifest, write_manifest
from mgdata.skeleton.skeleton import load_family_recipe


def _server_cpu(pid: int) -> float:
    fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def _serve(policy: str) -> tuple[subprocess.Popen, str]:
    mgdata = str(Path(sys.executable).parent / "mgdata")
    args = ["random", "--seed", "0"] if policy == "random" else [policy]
    proc = subprocess.Popen([mgdata, "serve", *args, "--port", "0"], stdout=subprocess.PIPE, text=True)
    assert proc.stdout is not None
    for line in proc.stdout:
        if line.startswith("serving "):
            return proc, line.split(" on ")[1].split()[0]
    raise SystemExit("mgdata serve did not start")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scenarios", type=Path, help="a scenario set (default: build jar task 0 base)")
    parser.add_argument("--rollouts", type=int, default=2, help="rollouts per chunk-steps value")
    parser.add_argument("--steps", type=int, default=400, help="control steps per rollout")
    parser.add_argument("--chunk-steps", type=int, nargs="+", default=[1, 8])
    parser.add_argument("--policy", choices=["hold", "random"], default="random")
    parser.add_argument("--cameras", default="front,wrist")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        scenarios = args.scenarios
        if scenarios is None:
            scenarios = Path(tmp)
            build_scenario(load_family_recipe("jar"), 0, "base", scenarios)
            write_manifest(scenarios)
        entries = [e["path"] for e in read_manifest(scenarios)]
        proc, url = _serve(args.policy)
        try:
            print(f"policy {args.policy}, cameras {args.cameras}, {args.steps} steps per rollout, "
                  f"{args.rollouts} rollouts per row (restore included)")
            for k in args.chunk_steps:
                settings = LoopSettings(url, "pi0", tuple(args.cameras.split(",")), k, 60.0, 10.0, None,
                                        args.steps)
                c0, s0, w0 = time.process_time(), _server_cpu(proc.pid), time.perf_counter()
                steps = 0
                for i in range(args.rollouts):
                    rec = rollout(RolloutJob(scenarios, entries[i % len(entries)], i), settings).record
                    steps += rec["steps"]
                client, server = time.process_time() - c0, _server_cpu(proc.pid) - s0
                wall = time.perf_counter() - w0
                print(f"chunk-steps {k:2d}: {steps} steps, client {client:.2f} CPU s + server "
                      f"{server:.2f} CPU s -> {steps / (client + server):.0f} control steps per CPU-second "
                      f"(wall {wall:.1f} s, {steps / wall:.0f} steps/s)")
        finally:
            proc.terminate()
            proc.wait(timeout=30)


if __name__ == "__main__":
    main()
