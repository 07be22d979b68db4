"""The corrections round (issue 43): does a policy learn more from corrections of its own failures than from
as many more plain demos?

1. **Round 1** (``bench_learn.py`` with ``--record``): N plain demos → ``lerobot-train`` (state-only ACT) →
   ``mgdata eval`` on the trained layouts (recorded: ``round1/eval_seen/rollouts``) and on held-out layouts.
2. **Corrections**: ``mgdata corrections`` from round 1's failed rollouts on *trained* layouts only
   (``--tasks`` the trained ones: the held-out starts never become training data): M kept corrections.
3. **Corrections arm**: the N demos + the M corrections (``mgdata merge --concat``), trained from scratch with
   the same learner, steps and seed, evaluated on the same trained and held-out starts.
4. **Plain arm**: N + M plain demos (round 1's data resumed with ``--n N+M``: draw 1 of the first M trained
   layouts), trained and evaluated the same way.

Prints held-out and trained-layout SSR / EVR / TSR with binomial standard errors per arm, the corrections'
tries (restart steps, refusals, kept), and writes ``round.json``. Every option of ``bench_learn.py`` applies
(the family protocol); ``--reuse`` keeps the finished steps.

Example (CPU, about 1.5 hours on an idle 2-core machine)::

    LEROBOT_PYTHON=/work/lerobot-venv/bin/python .venv/bin/python benchmarks/bench_corrections.py \\
        --tasks 208 --per-task 1 --heldout 100 --variants "" --seen 52 --steps 10000 --horizon 500 \\
        --loader-workers 1 --workers 2 --out /tmp/round
"""

from __future__ import annotations

import argparse
import collections
import json
import shlex
import shutil
import subprocess
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
import bench_learn as bl

OWN = {"--per-failure", "--back", "--candidates", "--tries", "--out", "--extra-seeds"}


def _passed_on(argv: list[str]) -> list[str]:
    """``argv`` without this script's own options (``bench_learn.py`` gets the rest)."""
    out, skip = [], False
    for a in argv:
        if skip:
            skip = False
            continue
        key = a.split("=", 1)[0]
        if key in OWN:
            skip = "=" not in a
            continue
        out.append(a)
    return out


def _episodes(root: Path) -> int:
    return int(json.loads((root / "meta" / "info.json").read_text())["total_episodes"])


def _arm(args, name: str, data: Path, r1: Path, out: Path) -> dict:  # type: ignore[no-untyped-def]
    """Export the state view of ``data``, train from scratch, evaluate on round 1's starts."""
    arm = out / name
    state = arm / "data_state"
    train_env = {"MGDATA_ROOT": str(r1 / "root_train")}
    if not (args.reuse and state.is_dir()):
        shutil.rmtree(state, ignore_errors=True)
        bl.run([*bl.MGDATA, "export", str(data), str(state), "--format", "state"], train_env)
    if args.reuse and (arm / "report.json").is_file():
        return json.loads((arm / "report.json").read_text())
    ckpt, timing = bl.train(args, state, arm / "train")
    bl.log(f"{name}: trained {timing['steps']} steps in {timing['wall_s']} s")
    server = bl.Server(args, ckpt, arm / "serve.log")
    env = {"MGDATA_ROOT": str(r1 / "root_eval")}
    try:
        seen = bl.evaluate(args, server.url, r1 / "scen_seen", arm / "eval_seen", env)
        heldout = bl.evaluate(args, server.url, r1 / "scen_heldout", arm / "eval_heldout", env)
    finally:
        server.close()
    report = {"episodes": _episodes(data), "train": timing,
              "eval": {"base": bl.summarise([r for r in seen if r["condition"] == "base"], "base"),
                       "heldout": bl.summarise(heldout, "heldout")}}
    (arm / "report.json").write_text(json.dumps(report, indent=1, default=str))
    return report


def _tries(report_file: Path) -> dict:
    """What the corrections' tries gave: per outcome, and the restart offsets of the kept ones."""
    rollouts = json.loads(report_file.read_text())["rollouts"]
    stages: collections.Counter[str] = collections.Counter()
    kept_back = []
    for r in rollouts:
        for t in r["tries"]:
            stages["kept" if t["kept"] else (t["stage"] or "?")] += 1
            if t["kept"]:
                kept_back.append(r["failure_step"] - t["step"])
    return {"failed_rollouts": len(rollouts), "corrected": sum(r["corrections"] > 0 for r in rollouts),
            "tries": dict(stages), "kept_frames_before_failure": kept_back,
            "failures": dict(collections.Counter(r["failure"] for r in rollouts))}


def main() -> None:
    p = bl.build_parser()
    p.add_argument("--per-failure", type=int, default=2, help="kept corrections per failed rollout")
    p.add_argument("--back", type=int, default=20, help="frames between restart candidates")
    p.add_argument("--candidates", type=int, default=4, help="restart candidates per failed rollout")
    p.add_argument("--tries", type=int, default=2, help="draws per restart candidate")
    p.add_argument("--extra-seeds", default="",
                   help="more training seeds (e.g. 1001,1002): each trains round 1's data, the corrections "
                   "arm's and the plain arm's again, scored on the same starts (one training run's outcome "
                   "varies more than the starts' binomial error)")
    args = p.parse_args()
    if args.protocol != "family" or args.ablation:
        p.error("the corrections round runs the family protocol, without --ablation")
    out = args.out.resolve()
    out.mkdir(parents=True, exist_ok=True)
    r1, t0 = out / "round1", time.time()
    ntasks = args.tasks
    # 1. round 1: plain demos, trained-layout rollouts recorded
    if not (args.reuse and (r1 / "report.json").is_file()):
        subprocess.run([sys.executable, str(Path(bl.__file__).resolve()), *_passed_on(sys.argv[1:]),
                        "--record", "--out", str(r1)], check=True)
    round1 = json.loads((r1 / "report.json").read_text())
    n = round1["data"]["episodes"]
    # 2. corrections from the failures on trained layouts
    rollouts = r1 / "eval_seen" / "rollouts" / args.family
    corr = out / "corrections"
    if not (args.reuse and (corr / "meta" / "mgdata_corrections.json").is_file()):
        shutil.rmtree(corr, ignore_errors=True)
        bl.run([*bl.MGDATA, "corrections", str(rollouts), "--out", str(corr), "--tasks", f"0-{ntasks - 1}",
                "--back", str(args.back), "--candidates", str(args.candidates), "--tries", str(args.tries),
                "--per-failure", str(args.per_failure), "--workers", str(args.workers)],
               {"MGDATA_ROOT": str(r1 / "root_train")}, out / "corrections.log")
    m = _episodes(corr) if (corr / "meta" / "info.json").is_file() else 0
    tries = _tries(corr / "meta" / "mgdata_corrections.json")
    bl.log(f"corrections: {m} kept from {tries}")
    if m == 0:
        raise SystemExit("no correction was kept; nothing to compare (see corrections.log)")
    # 3. N demos + M corrections
    joined = out / "with_corrections" / "data"
    if not joined.is_dir():
        joined.parent.mkdir(parents=True, exist_ok=True)
        bl.run([*bl.MGDATA, "merge", "--concat", str(r1 / "data"), str(corr), "--out", str(joined)])
    with_corr = _arm(args, "with_corrections", joined, r1, out)
    # 4. N + M plain demos
    plain = out / "plain_more" / "data"
    if not (args.reuse and plain.is_dir() and _episodes(plain) == n + m):
        shutil.rmtree(plain, ignore_errors=True)
        plain.parent.mkdir(parents=True, exist_ok=True)
        shutil.copytree(r1 / "data", plain)
        bl.run([*bl.MGDATA, "generate", "--family", args.family, "--tasks", f"0-{ntasks - 1}", "--n",
                str(n + m), "--workers", str(args.workers), "--out", str(plain)],
               {"MGDATA_ROOT": str(r1 / "root_train")}, out / "plain_more.log")
    plain_more = _arm(args, "plain_more", plain, r1, out)
    seeds: dict[str, dict] = {}
    for seed in [int(x) for x in args.extra_seeds.split(",") if x]:
        other = argparse.Namespace(**{**vars(args), "seed": seed})
        for name, data in (("plain", r1 / "data"), ("with_corrections", joined), ("plain_more", plain)):
            seeds[f"{name}_seed{seed}"] = _arm(other, f"{name}_seed{seed}", data, r1, out)
    report = {"command": shlex.join(sys.argv), "n": n, "m": m, "corrections": tries,
              "round1": {"episodes": n, "train": round1["train"], "eval": round1["eval"]},
              "with_corrections": with_corr, "plain_more": plain_more, "other_seeds": seeds,
              "wall_s": round(time.time() - t0, 1),
              "training": "from scratch, the same learner, steps and seed in every arm"}
    (out / "round.json").write_text(json.dumps(report, indent=1, default=str))
    rows = {f"round 1: {n} plain (seed {args.seed})": round1,
            f"{n} plain + {m} corrections (seed {args.seed})": with_corr,
            f"{n + m} plain (seed {args.seed})": plain_more}
    for name, rep_ in seeds.items():
        arm, seed = name.rsplit("_seed", 1)
        label = {"plain": f"{n} plain", "with_corrections": f"{n} plain + {m} corrections",
                 "plain_more": f"{n + m} plain"}[arm]
        rows[f"{label} (seed {seed})"] = rep_
    head = ("arm", "steps", "held-out SSR", "held-out EVR", "held-out TSR", "trained SSR", "trained EVR")
    table = [(name, str(r["train"]["steps"]), bl._rate(r["eval"].get("heldout"), "ssr"),
              bl._rate(r["eval"].get("heldout"), "evr"), bl._rate(r["eval"].get("heldout"), "tsr"),
              bl._rate(r["eval"].get("base"), "ssr"), bl._rate(r["eval"].get("base"), "evr"))
             for name, r in rows.items()]
    widths = [max(len(h), *(len(r[i]) for r in table)) for i, h in enumerate(head)]
    print("\n" + "  ".join(h.ljust(w) for h, w in zip(head, widths, strict=True)))
    for row in table:
        print("  ".join(c.ljust(w) for c, w in zip(row, widths, strict=True)))
    print(f"corrections: {json.dumps(tries)}")
    print(f"command: {report['command']}")


if __name__ == "__main__":
    main()
