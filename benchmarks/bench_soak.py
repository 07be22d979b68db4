"""Soak and kill (issue 26 §6): ``kill -9`` at random moments in the long commands, each resumed, compared
byte for byte with an uninterrupted run, and checked for stale state; plus peak RSS per worker over a
``generate --family all`` run.

**Kill trials.** A *chain* runs one command, kills it with SIGKILL at a uniformly random moment within 10-90 %
of the uninterrupted run's wall time, runs it again (killing again with probability ``--rekill``), and finally
lets it finish; every kill is one *fault*. A first run that finishes before its kill moment (the load fell) is
thrown away and started over with the moment drawn within its own time (up to three times), so every chain
injects at least one fault. A chain passes when the final output equals the uninterrupted run's output byte
for byte (every file, the work area ``.mgdata`` excepted) and no stale state is left: no ``.mgdata`` work
area, no lock file beside the output (``.<name>.lock``), no ``*.partial`` folder, no ``*.tmp`` file, no
process of the command still alive. The commands, round-robin: ``generate`` of each family in ``--families``
(its recipe with one 32² camera, ``--n 2`` (``--n``), task 0, two workers), ``render`` (a generated jar
dataset at 48², two cameras), ``merge`` (two ``--shard`` datasets of jar), ``scenarios build`` (jar tasks 0-1,
base + target) and ``eval`` (``mgdata serve hold``, two seeds, horizon 40), families and the other commands
alternating. Each command's uninterrupted run comes just before its first chain. ``--minutes M`` starts no
chain after M minutes and prints the summary of what ran, with the kills per command.

**RSS.** ``--rss``: ``mgdata generate --family all --per-task K --tasks T --workers W`` with the shipped
recipes, sampling the resident set size of the main process and of every worker (``/proc``) every second,
printed per family (peak per worker, at the first and the last third of the family's run).

Run: ``nice -n 5 .venv/bin/python benchmarks/bench_soak.py --trials 30 [--families jar,stack]`` and
``nice -n 5 .venv/bin/python benchmarks/bench_soak.py --rss --per-task 2`` (``--minutes M`` stops the
generate run after M minutes and prints what it sampled).
"""

from __future__ import annotations

import argparse
import contextlib
import json
import os
import random
import re
import shutil
import signal
import subprocess
import sys
import tempfile
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

from mgdata.paths import recipes_dir

MGDATA = str(Path(sys.executable).parent / "mgdata")
ENV = os.environ | {"LP_NUM_THREADS": "1"}
SERVERS: list[subprocess.Popen] = []
"""The policy server the eval trials use (stopped at the end)."""
FAMILIES = ("jar", "clutter_dry", "clutter_liquid", "stack", "lid", "cabinet", "dusty")


def small_recipe(family: str, folder: Path) -> Path:
    """``recipes/<family>.toml`` with one 32² camera and its spec path made absolute."""
    text = (recipes_dir() / f"{family}.toml").read_text()
    text = re.sub(r'^spec = "(.*)"', lambda m: f'spec = "{recipes_dir() / m.group(1)}"', text, count=1,
                  flags=re.M)
    text = re.sub(r"^cameras = \[.*\]", 'cameras = ["front"]', text, count=1, flags=re.M)
    text = re.sub(r"^image_size = \d+", "image_size = 32", text, count=1, flags=re.M)
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / f"{family}.toml"
    path.write_text(text)
    return path


def files(root: Path) -> dict[str, bytes]:
    return {str(p.relative_to(root)): p.read_bytes() for p in sorted(root.rglob("*"))
            if p.is_file() and ".mgdata" not in p.parts}


def stale(out: Path) -> list[str]:
    """What a finished command must not leave: its work area, lock file, partial folders, temp files."""
    found = []
    if (out / ".mgdata").exists():
        found.append(f"{out}/.mgdata")
    lock = out.parent / f".{out.name}.lock"
    if lock.exists():
        found.append(str(lock))
    found += [str(p) for p in out.parent.glob(f"{out.name}*.partial")]
    found += [str(p) for p in out.rglob("*.tmp")] if out.exists() else []
    return found


def alive_mentioning(text: str) -> list[int]:
    """Processes whose command line mentions ``text`` (this script's own output folders)."""
    pids = []
    for entry in Path("/proc").iterdir():
        if entry.name.isdigit() and int(entry.name) != os.getpid():
            try:
                if text in (entry / "cmdline").read_bytes().decode(errors="replace"):
                    pids.append(int(entry.name))
            except OSError:
                continue
    return pids


@dataclass
class Command:
    """One long command: ``argv(out)`` writes ``out``; ``compare(out)`` what must equal the reference."""

    name: str
    argv: Callable[[Path], list[str]]
    compare: Callable[[Path], dict[str, bytes]] = files
    wall: float = 0.0
    reference: dict[str, bytes] = field(default_factory=dict)


def run(argv: list[str], timeout: float = 3600) -> subprocess.CompletedProcess:
    return subprocess.run([MGDATA, *argv], capture_output=True, text=True, timeout=timeout, env=ENV)


def prepare(tmp: Path, families: list[str], n: int, log: Callable[[str], None]) -> list[Command]:
    recipes = {f: small_recipe(f, tmp / "recipes") for f in {*families, "jar"}}
    commands = []
    for f in families:
        commands.append(Command(f"generate {f}", lambda out, f=f: [
            "generate", "--family", f, "--recipe", str(recipes[f]), "--n", str(n), "--tasks", "0",
            "--workers", "2", "--out", str(out)]))
    base = tmp / "inputs"
    jar = base / "jar"
    shards = [base / "shard0", base / "shard1"]
    scen = base / "scenarios"
    for argv in (["generate", "--family", "jar", "--recipe", str(recipes["jar"]), "--n", "2", "--tasks", "0",
                  "--workers", "1", "--out", str(jar)],
                 *[["generate", "--family", "jar", "--recipe", str(recipes["jar"]), "--per-task", "1",
                    "--tasks", "0-1", "--shard", f"{i}/2", "--workers", "1", "--out", str(s)]
                   for i, s in enumerate(shards)],
                 ["scenarios", "build", "--out", str(scen), "--family", "jar", "--tasks", "0",
                  "--condition", "base"]):
        proc = run(argv)
        if proc.returncode != 0:
            raise SystemExit(f"input {argv}: {proc.stderr}")
        log(f"input ready: {argv[0]} {argv[-1]}")
    others = [Command("render", lambda out: ["render", str(jar), "--out", str(out), "--size", "48",
                                             "--cameras", "front,wrist"]),
              Command("merge", lambda out: ["merge", *map(str, shards), "--out", str(out)]),
              Command("scenarios build", lambda out: ["scenarios", "build", "--out", str(out), "--family",
                                                      "jar", "--tasks", "0-1", "--condition", "base",
                                                      "--condition", "target"])]
    server = subprocess.Popen([MGDATA, "serve", "hold", "--port", "0"], stdout=subprocess.PIPE, text=True,
                              env=ENV)
    SERVERS.append(server)
    assert server.stdout is not None
    url = server.stdout.readline().split(" on ")[1].split()[0]
    others.append(Command("eval", lambda out: ["eval", "--policy", url, "--scenarios", str(scen), "--out",
                                               str(out), "--seeds", "0,1", "--horizon", "40"],
                          compare=lambda out: {k: v for k, v in files(out).items() if k == "rollouts.jsonl"}))
    mixed = []  # families and the other commands alternate, so a run cut short still covers both kinds
    for i in range(max(len(commands), len(others))):
        mixed += commands[i:i + 1] + others[i:i + 1]
    return mixed


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--trials", type=int, default=30, help="kill -9 faults to inject (at least)")
    parser.add_argument("--families", default="cabinet,clutter_liquid,dusty,jar,clutter_dry,stack,lid")
    parser.add_argument("--commands", default="all", help="'all', or a comma list of command names")
    parser.add_argument("--n", type=int, default=2, help="kept episodes of each family's generate")
    parser.add_argument("--rekill", type=float, default=0.3, help="chance of killing a resumed run again")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--minutes", type=float, default=None,
                        help="start no new chain (--rss: stop the run) after this many minutes")
    parser.add_argument("--rss", action="store_true", help="the RSS run instead of the kill trials")
    parser.add_argument("--per-task", type=int, default=2)
    parser.add_argument("--tasks", default=None, help="the RSS run's --tasks (default: every task)")
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--keep", action="store_true", help="keep the temporary folder")
    args = parser.parse_args()
    tmp = Path(tempfile.mkdtemp(prefix="bench_soak_"))
    t0 = time.monotonic()

    def log(text: str) -> None:
        print(f"[{time.monotonic() - t0:7.1f} s] {text}", flush=True)

    try:
        if args.rss:
            rss_run(tmp, args, log)
        else:
            trials(tmp, args, log)
    finally:
        for server in SERVERS:
            server.terminate()
            server.wait(timeout=30)
        if not args.keep:
            shutil.rmtree(tmp, ignore_errors=True)


def trials(tmp: Path, args: argparse.Namespace, log: Callable[[str], None]) -> None:
    rng = random.Random(args.seed)
    families = [f for f in args.families.split(",") if f]
    commands = prepare(tmp, families, args.n, log)
    if args.commands != "all":
        wanted = set(args.commands.split(","))
        commands = [c for c in commands if c.name in wanted or c.name.split()[0] in wanted]
    start_all = time.monotonic()

    def reference(c: Command) -> None:
        """The uninterrupted run of ``c``, before its first chain (a run cut short still has chains)."""
        out = tmp / "ref" / c.name.replace(" ", "_")
        start = time.monotonic()
        proc = run(c.argv(out))
        c.wall = time.monotonic() - start
        if proc.returncode != 0:
            raise SystemExit(f"reference {c.name}: {proc.stdout}{proc.stderr}")
        c.reference = c.compare(out)
        log(f"reference {c.name}: {c.wall:.1f} s, {len(c.reference)} files")
    faults = chains = identical = clean = 0
    failures: list[str] = []
    per_command: dict[str, list[int]] = {c.name: [0, 0] for c in commands}  # kills, chains
    k = 0
    while faults < args.trials and (args.minutes is None or time.monotonic() - start_all < 60 * args.minutes):
        c = commands[k % len(commands)]
        k += 1
        if not c.reference:
            reference(c)
        out = tmp / "trial" / f"{k:03d}_{c.name.replace(' ', '_')}"
        kills, runs, missed = 0, 0, 0
        span = c.wall  # the kill moment is drawn within this: the reference run's time, then the missed run's
        while True:
            runs += 1
            started = time.monotonic()
            proc = subprocess.Popen([MGDATA, *c.argv(out)], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                                    text=True, env=ENV, start_new_session=True)
            if kills == 0 or rng.random() < args.rekill:
                delay = rng.uniform(0.1, 0.9) * span
                try:
                    proc.wait(timeout=delay)
                except subprocess.TimeoutExpired:
                    os.killpg(proc.pid, signal.SIGKILL)  # the command and its workers, like a node dying
                    proc.communicate()
                    kills += 1
                    faults += 1
                    continue
                if kills == 0 and missed < 3:  # it finished before the kill: start over, killing earlier
                    proc.communicate()
                    missed += 1
                    span = time.monotonic() - started
                    shutil.rmtree(out, ignore_errors=True)
                    continue
            _, err = proc.communicate(timeout=3600)
            if proc.returncode != 0:
                failures.append(f"{out.name}: resume exited {proc.returncode}: {err.strip()[-300:]}")
            break
        chains += 1
        per_command[c.name][0] += kills
        per_command[c.name][1] += 1
        same = proc.returncode == 0 and c.compare(out) == c.reference
        left = stale(out) + [f"pid {p}" for p in alive_mentioning(str(out))]
        identical += same
        clean += not left
        if not same:
            failures.append(f"{out.name}: bytes differ from the uninterrupted run")
        if left:
            failures.append(f"{out.name}: stale state {left}")
        log(f"chain {chains} {c.name}: {kills} kill(s), {runs} run(s) ({missed} finished before the kill), "
            f"bytes identical: {same}, stale state: {left or 'none'}")
        shutil.rmtree(out, ignore_errors=True)
    print(f"\nfaults injected (kill -9): {faults}; chains: {chains}; resumed to completion: "
          f"{chains - sum('resume exited' in f for f in failures)}; bytes identical: {identical}/{chains}; "
          f"no stale state: {clean}/{chains}")
    print("kills per command (chains): "
          + ", ".join(f"{name} {kc[0]} ({kc[1]})" for name, kc in per_command.items()))
    for f in failures:
        print("FAIL", f)


def rss_of(pid: int) -> int:
    with contextlib.suppress(OSError):  # the process has ended: it holds no memory
        for line in Path(f"/proc/{pid}/status").read_text().splitlines():
            if line.startswith("VmRSS:"):
                return int(line.split()[1]) * 1024
    return 0


def descendants(pid: int) -> list[int]:
    parent: dict[int, int] = {}
    for entry in Path("/proc").iterdir():
        if entry.name.isdigit():
            try:
                parent[int(entry.name)] = int((entry / "stat").read_text().rsplit(")", 1)[1].split()[1])
            except (OSError, ValueError, IndexError):
                continue
    found, frontier = [], [pid]
    while frontier:
        p = frontier.pop()
        kids = [c for c, pp in parent.items() if pp == p]
        found += kids
        frontier += kids
    return found


def rss_run(tmp: Path, args: argparse.Namespace, log: Callable[[str], None]) -> None:
    out = tmp / "suite"
    argv = [MGDATA, "generate", "--family", "all", "--per-task", str(args.per_task),
            *(["--tasks", args.tasks] if args.tasks else []), "--workers", str(args.workers),
            "--out", str(out)]
    log(" ".join(argv[1:]))
    proc = subprocess.Popen(argv, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, env=ENV,
                            start_new_session=True)
    cut = threading.Timer(60 * (args.minutes or 1e6), lambda: os.killpg(proc.pid, signal.SIGKILL))
    cut.daemon = True
    cut.start()
    samples: list[tuple[float, str, int, int, list[int]]] = []  # (t, family, episodes so far, main, workers)
    stop = threading.Event()

    def sample() -> None:
        while not stop.is_set():
            folders = [p for p in out.iterdir() if p.is_dir()] if out.exists() else []
            family = max(folders, key=lambda p: p.stat().st_mtime).name if folders else "-"
            kids = [rss_of(p) for p in descendants(proc.pid)]
            samples.append((time.monotonic(), family, episodes_in(out), rss_of(proc.pid),
                            [r for r in kids if r]))
            if len(samples) % 30 == 1:  # live, in case the run is cut short
                _, fam, episodes, main_rss, workers = samples[-1]
                log(f"rss {fam}, {episodes} episodes so far: main {main_rss / 2**20:.0f} MB, workers "
                    f"{[round(r / 2**20) for r in workers]} MB")
            stop.wait(1.0)

    thread = threading.Thread(target=sample, daemon=True)
    thread.start()
    assert proc.stdout is not None
    for line in proc.stdout:
        print("  | " + line.rstrip(), flush=True)
    proc.wait()
    cut.cancel()
    stop.set()
    thread.join()
    log(f"exit {proc.returncode}{' (stopped at --minutes)' if proc.returncode == -signal.SIGKILL else ''}; "
        f"{len(samples)} samples")
    mb = 1 / 2**20
    print("family           samples  main peak MB  worker peak MB (first third / last third / all)")
    for family in dict.fromkeys(s[1] for s in samples):
        rows = [s for s in samples if s[1] == family]
        third = max(1, len(rows) // 3)
        peak = lambda rs: max((max(s[4]) if s[4] else 0) for s in rs) * mb  # noqa: E731
        print(f"{family:16s} {len(rows):7d}  {max(s[3] for s in rows) * mb:12.0f}  "
              f"{peak(rows[:third]):6.0f} / {peak(rows[-third:]):6.0f} / {peak(rows):6.0f}")
    print("RSS over episode count (every count seen): episodes kept so far, family, samples, main peak MB, "
          "worker peak MB")
    for episodes in dict.fromkeys(s[2] for s in samples):
        rows = [s for s in samples if s[2] == episodes]
        print(f"  {episodes:5d}  {rows[-1][1]:16s} {len(rows):5d}  {max(s[3] for s in rows) * mb:6.0f}  "
              f"{max((max(s[4]) if s[4] else 0) for s in rows) * mb:6.0f}")
    print("RSS over time (every ~30 s): t, family, episodes so far, main MB, workers MB")
    t_first = samples[0][0] if samples else 0.0
    for s in samples[::30]:
        workers = [round(r * mb) for r in s[4]]
        print(f"  {s[0] - t_first:7.0f} s  {s[1]:16s} {s[2]:5d}  {s[3] * mb:6.0f}  {workers}")


def episodes_in(out: Path) -> int:
    """Kept episodes committed so far under ``out`` (each family's ``meta/info.json``)."""
    total = 0
    for info in out.glob("*/meta/info.json") if out.exists() else []:
        with contextlib.suppress(OSError, ValueError):  # replaced atomically; a family may not have one yet
            total += int(json.loads(info.read_text()).get("total_episodes", 0))
    return total


if __name__ == "__main__":
    main()
