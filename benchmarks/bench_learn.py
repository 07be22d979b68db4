"""Close the loop: generate → LeRobot's own ``lerobot-train`` (state-only ACT) → ``mgdata serve lerobot`` →
``mgdata eval``, on distinct starts; prints SSR, TSR, EVR, Eng., Safe|Eng. per condition, training steps, wall
and CPU time and the loss curve (docs/train.md).

Protocols (``--protocol``):

* ``family``: train on ``--per-task`` kept demos of each of the family's base tasks ``--tasks`` (jar: 26 × 8 =
  208); evaluate on the base scenarios, their ``location`` and ``target`` variants, and ``--heldout`` held-out
  draws: new layouts from the same layout rules through the same initial-state gate, never trained on.
* ``single``: the paper's single-task study: one task (task 0's objects pinned) at ``--layouts`` layouts,
  ``--per-task`` demos of each that differ by the variation draws (standoff, lift, push, goal offset; 20 × 3
  = 60); evaluate on those layouts, their ``location`` and ``target`` variants and ``--heldout`` held-out
  layouts of the same objects. (Demos of one layout only teach nothing about where a moved jar is: a
  policy trained so engaged 2 of 30 new layouts.)

``--grasp-cycle`` (default 1) sets the recipe's ``grasp_cycle``: every demo of a layout takes its most
natural reachable grasp. The recipes' default (0) cycles through every reachable grasp, which makes the
demos of one layout reach the jar from up to eight sides with arm configurations 1-2.5 rad apart at the
grasp (docs/train.md): data a deterministic policy averages into none of them.

Held-out draws: the recipe's tasks are independent draws from its layout rules (``SeedSequence([seed, k,
draw])``), so tasks ``count … count + heldout − 1`` of the same recipe with a larger ``[tasks] count`` are
new layouts that pass the same gate. The benchmark writes that recipe (and, for ``single``, one whose roles'
model pools are pinned to task 0's objects) into an ``MGDATA_ROOT`` copy under ``--out``; camera-free for
generation (state-only datasets skip rendering and encoding).

Example (CPU, about an hour on an idle 2-core machine)::

    LEROBOT_PYTHON=/work/lerobot-venv/bin/python .venv/bin/python benchmarks/bench_learn.py \\
        --protocol family --steps 6000 --workers 2 --out /tmp/learn_family
"""

from __future__ import annotations

import argparse
import json
import os
import re
import resource
import shlex
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parent.parent
MGDATA = [sys.executable, "-c", "import sys; from mgdata.cli import main; sys.argv[0] = 'mgdata'; main()"]


def _pythonpath() -> str:
    """This checkout first (the LeRobot environment serves mgdata's module from it), then what was set."""
    return os.pathsep.join(p for p in (str(REPO), os.environ.get("PYTHONPATH", "")) if p)


def log(msg: str) -> None:
    print(f"[bench_learn {time.strftime('%H:%M:%S')}] {msg}", flush=True)


def run(cmd: list[str], env: dict[str, str] | None = None, logfile: Path | None = None,
        timeout: float | None = None) -> bool:
    """Run ``cmd``; False if it was stopped after ``timeout`` seconds (SIGINT, then SIGKILL)."""
    log(" ".join(cmd[:1] + [c for c in cmd[1:] if not c.startswith("import sys")])[:400])
    full = {**os.environ, **(env or {})}
    if logfile is None:
        subprocess.run(cmd, env=full, check=True)
        return True
    with open(logfile, "w") as fh:
        proc = subprocess.Popen(cmd, env=full, stdout=fh, stderr=subprocess.STDOUT)
        try:
            proc.wait(timeout)
        except subprocess.TimeoutExpired:
            proc.send_signal(signal.SIGINT)
            try:
                proc.wait(30)
            except subprocess.TimeoutExpired:
                proc.kill()
                proc.wait()
            log(f"stopped after {timeout} s")
            return False
    if proc.returncode:
        print(logfile.read_text()[-3000:])
        raise subprocess.CalledProcessError(proc.returncode, cmd)
    return True


def make_root(out: Path, family: str, count: int, cameras: str, pins: dict[str, str] | None = None,
              grasp_cycle: int = 0, amplitude: float | None = None) -> Path:
    """An ``MGDATA_ROOT`` copy whose ``recipes/<family>.toml`` has ``count`` tasks, ``cameras``, for each
    role in ``pins`` a model pool of that one model, ``grasp_cycle`` in ``[params]`` and, if given, the
    ``[recovery] amplitude``."""
    if out.exists():
        shutil.rmtree(out)
    (out / "recipes").mkdir(parents=True)
    for item in REPO.iterdir():
        if item.name not in ("recipes", ".git", ".venv", ".gpu", ".whl"):
            (out / item.name).symlink_to(item)
    for item in (REPO / "recipes").iterdir():
        if item.name != f"{family}.toml":
            (out / "recipes" / item.name).symlink_to(item)
    text = (REPO / "recipes" / f"{family}.toml").read_text()
    text = re.sub(r"(?m)^count = \d+", f"count = {count}", text, count=1)
    text = re.sub(r"(?m)^cameras = .*$", f"cameras = {cameras}", text, count=1)
    for role, model in (pins or {}).items():
        text = re.sub(rf"(?ms)(^\[layout\.roles\.{role}\]\s*\nmodels = )\[[^\]]*\]", rf'\1["{model}"]', text,
                      count=1)
    text = re.sub(r"(?m)^grasp_cycle = .*\n", "", text)
    text = re.sub(r"(?m)^\[params\]\s*$", f"[params]\ngrasp_cycle = {grasp_cycle}", text, count=1)
    if amplitude is not None:
        text += f"\n[recovery]\namplitude = {amplitude}\n"
    (out / "recipes" / f"{family}.toml").write_text(text)
    return out


def task0_models(family: str) -> dict[str, str]:
    from mgdata.engine.init_gate import base_task
    from mgdata.tasks.recipe import load_recipe

    return {o.name: o.model for o in base_task(load_recipe(family), 0).objects}


def carry_grasp_step(grip: np.ndarray) -> int | None:
    """The step at which a demo's gripper command closes on what it carries: its first close, or, if it
    starts closed (the jar's lid is pushed shut with closed fingers), its first close after opening."""
    opened = np.flatnonzero(np.diff(grip) < 0)
    closes = np.flatnonzero(np.diff(grip) > 0)
    if grip[0] > 0.5:
        closes = closes[closes > opened[0]] if opened.size else closes[:0]
    return int(closes[0]) + 1 if closes.size else None


def demo_spread(data: Path) -> dict:
    """How alike the demos of a layout are: distinct grasps per layout, the arm configuration at the carry's
    grasp (:func:`carry_grasp_step`) as std per joint across all demos and as the largest spread within one
    layout, and how many demos swing joint 1 past ±1.5 rad."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    meta = pa.concat_tables([pq.read_table(f, columns=["mgdata/task_id", "mgdata/grasp_id"])
                             for f in sorted(data.glob("meta/episodes/*/*.parquet"))])
    frames = pa.concat_tables([pq.read_table(f, columns=["episode_index", "observation.state", "action"])
                               for f in sorted(data.glob("data/*/*.parquet"))])
    ep = frames.column("episode_index").to_numpy()
    state = np.stack(frames.column("observation.state").to_numpy(zero_copy_only=False))[:, :7]
    grip = np.stack(frames.column("action").to_numpy(zero_copy_only=False))[:, 7]
    tasks, grasps = meta.column("mgdata/task_id").to_pylist(), meta.column("mgdata/grasp_id").to_pylist()
    at_grasp, twisted = {}, 0
    for e in range(meta.num_rows):
        q, close = state[ep == e], carry_grasp_step(grip[ep == e])
        twisted += bool(np.abs(q[:, 0]).max() > 1.5)
        if close is not None:
            at_grasp[e] = q[close]
    by_task: dict[int, list[int]] = {}
    for e, t in enumerate(tasks):
        by_task.setdefault(t, []).append(e)
    within = [float(np.ptp(np.stack([at_grasp[e] for e in es if e in at_grasp]), axis=0).max())
              for es in by_task.values() if sum(e in at_grasp for e in es) > 1]
    per_layout = [len({grasps[e] for e in es}) for es in by_task.values()]
    std = np.stack(list(at_grasp.values())).std(axis=0)
    return {"grasps_per_layout": round(float(np.mean(per_layout)), 2),
            "grasp_config_std_rad": [round(float(v), 2) for v in std],
            "max_spread_within_layout_rad": round(max(within, default=0.0), 3),
            "demos_joint1_past_1.5rad": twisted}


def loss_curve(train_log: Path, log_freq: int) -> list[tuple[int, float]]:
    """(step, loss) of lerobot-train's log lines (``step:2K … loss:0.123``; LeRobot rounds the step, so the
    k-th line is taken as step ``k * log_freq``)."""
    losses = [float(m.group(1)) for line in train_log.read_text(errors="replace").splitlines()
              if (m := re.search(r"step:\S+ .*?loss:([0-9.]+)", line))]
    return [((k + 1) * log_freq, loss) for k, loss in enumerate(losses)]


def train(args: argparse.Namespace, dataset: Path, out: Path) -> tuple[Path, dict]:
    """lerobot-train a small state-only ACT; returns (checkpoint, timings)."""
    ckpt = out / "checkpoints" / "last" / "pretrained_model"
    logfile = out.parent / f"{out.name}.log"
    if args.reuse and ckpt.is_dir():
        return ckpt, json.loads((out.parent / f"{out.name}.json").read_text())
    shutil.rmtree(out, ignore_errors=True)
    log_freq = max(1, min(args.steps // 40, 100))
    cmd = [args.lerobot_python, "-m", "lerobot.scripts.lerobot_train",
           f"--dataset.repo_id=mgdata/{dataset.name}", f"--dataset.root={dataset}",
           "--policy.type=act", f"--policy.device={args.device}", "--policy.push_to_hub=false",
           "--wandb.enable=false", "--policy.pretrained_backbone_weights=null",
           f"--policy.dim_model={args.dim_model}", f"--policy.dim_feedforward={4 * args.dim_model}",
           f"--policy.n_encoder_layers={args.encoder_layers}", "--policy.n_decoder_layers=1",
           "--policy.use_vae=false", f"--policy.chunk_size={args.chunk}",
           f"--policy.n_action_steps={args.chunk}",
           f"--policy.optimizer_lr={args.lr}", f"--batch_size={args.batch}", f"--steps={args.steps}",
           f"--save_freq={save_interval(args)}", f"--log_freq={log_freq}",
           f"--num_workers={args.loader_workers}",
           f"--seed={args.seed}", f"--output_dir={out}", *schedule_args(args)]
    env = {"HF_HUB_OFFLINE": "1", "HF_DATASETS_OFFLINE": "1", "WANDB_MODE": "disabled",
           "OMP_NUM_THREADS": str(args.torch_threads), "PYTHONPATH": _pythonpath()}
    t0, c0 = time.time(), resource.getrusage(resource.RUSAGE_CHILDREN)
    finished = run(cmd, env, logfile, args.train_timeout)
    c1 = resource.getrusage(resource.RUSAGE_CHILDREN)
    curve = loss_curve(logfile, log_freq)
    saved = sorted((out / "checkpoints").glob("[0-9]*"))
    if not saved:
        raise RuntimeError(f"lerobot-train saved no checkpoint; see {logfile}")
    last = out / "checkpoints" / "last"
    if last.is_symlink() or last.exists():
        last.unlink()
    last.symlink_to(saved[-1].name)
    timing = {"steps": int(saved[-1].name), "steps_run": curve[-1][0] if curve else None,
              "finished": finished, "wall_s": round(time.time() - t0, 1),
              "cpu_s": round(c1.ru_utime + c1.ru_stime - c0.ru_utime - c0.ru_stime, 1),
              "loss": curve}
    (out.parent / f"{out.name}.json").write_text(json.dumps(timing))
    return ckpt, timing


def save_interval(args: argparse.Namespace) -> int:
    """Training steps between saved checkpoints."""
    return max(1, min(args.steps // 4, 500))


def schedule_args(args: argparse.Namespace) -> list[str]:
    """``lerobot-train`` options of ``--lr-schedule``: none for ACT's preset (constant), else the preset's
    optimizer spelled out (AdamW, ``--lr``, weight decay 1e-4) with a cosine decay after a 5 % warm-up."""
    if args.lr_schedule == "constant":
        return []
    return ["--use_policy_training_preset=false", "--optimizer.type=adamw", f"--optimizer.lr={args.lr}",
            "--optimizer.weight_decay=0.0001", "--scheduler.type=cosine_decay_with_warmup",
            f"--scheduler.num_warmup_steps={max(1, args.steps // 20)}",
            f"--scheduler.num_decay_steps={args.steps}", f"--scheduler.peak_lr={args.lr}",
            f"--scheduler.decay_lr={args.lr / 100}"]


class Server:
    """The checkpoint served by ``python -m mgdata.evaluate.lerobot_policy`` in the LeRobot environment."""

    def __init__(self, args: argparse.Namespace, ckpt: Path, logfile: Path) -> None:
        self.log = open(logfile, "w")  # noqa: SIM115 (closed by close())
        self.proc = subprocess.Popen(
            [args.lerobot_python, "-m", "mgdata.evaluate.lerobot_policy", "--checkpoint", str(ckpt),
             "--port", "0",
             "--device", args.serve_device], stdout=subprocess.PIPE, stderr=self.log, text=True,
            env={**os.environ, "PYTHONPATH": _pythonpath(), "HF_HUB_OFFLINE": "1", "OMP_NUM_THREADS": "1"})
        assert self.proc.stdout is not None
        m = None
        for _ in range(50):  # LeRobot prints a line or two of its own first
            line = self.proc.stdout.readline()
            m = re.search(r"(ws://[0-9.]+:\d+)", line)
            if m or not line:
                break
        if not m:
            raise RuntimeError(f"the policy server did not start: {line!r} {logfile.read_text()[-2000:]}")
        self.url = m.group(1)

    def close(self) -> None:
        self.proc.terminate()  # a non-interactive shell starts background jobs with SIGINT ignored
        try:
            self.proc.wait(20)
        except subprocess.TimeoutExpired:
            self.proc.kill()
        self.log.close()


def evaluate(args: argparse.Namespace, url: str, scenarios: Path, out: Path,
             env: dict[str, str], record: bool = False) -> list[dict]:
    cmd = [*MGDATA, "eval", "--policy", url, "--scenarios", str(scenarios), "--convention", "state",
           "--seeds", "0", "--workers", str(args.workers), "--chunk-steps", str(args.chunk_steps),
           "--out", str(out), *(["--record"] if record else [])]
    if args.horizon:
        cmd += ["--horizon", str(args.horizon)]
    if args.ensemble >= 0:
        cmd += ["--ensemble", str(args.ensemble)]
    run(cmd, env, out.parent / f"{out.name}.log")
    return [json.loads(line) for line in (out / "rollouts.jsonl").read_text().splitlines() if line.strip()]


def score_checkpoints(args: argparse.Namespace, out: Path, scenarios: Path,
                      env: dict[str, str]) -> dict[str, dict]:
    """``--checkpoints``: each named checkpoint of ``out/train`` served and scored on the held-out starts
    (``heldout@STEPS``)."""
    results = {}
    for steps in args.checkpoints:
        ckpt = out / "train" / "checkpoints" / f"{steps:06d}" / "pretrained_model"
        if not ckpt.is_dir():  # training stopped before it (--train-timeout): the rest of the report stands
            log(f"--checkpoints {steps}: not scored, no checkpoint {ckpt} (training stopped earlier?)")
            continue
        server = Server(args, ckpt, out / f"serve_{steps}.log")
        try:
            records = evaluate(args, server.url, scenarios, out / f"eval_heldout_{steps}", env)
        finally:
            server.close()
        results[f"heldout@{steps}"] = summarise(records, "heldout")
    return results


def score_average(args: argparse.Namespace, out: Path, last: int, scenarios: Path,
                  env: dict[str, str]) -> dict[str, dict]:
    """``--average SPAN``: the uniform mean of the weights saved over the last SPAN training steps
    (``average_checkpoints.py``) served and scored on the held-out starts (``heldout avg@FIRST-LAST``)."""
    first = max(save_interval(args), last - args.average)
    steps = list(range(first, last + 1, save_interval(args)))
    ckpts = [out / "train" / "checkpoints" / f"{n:06d}" / "pretrained_model" for n in steps]
    missing = [c for c in ckpts if not c.is_dir()]
    if missing:
        log(f"--average {args.average}: not scored, no checkpoint {missing[0]}")
        return {}
    averaged = out / f"averaged_{first}-{last}"
    run([args.lerobot_python, str(REPO / "benchmarks" / "average_checkpoints.py"), str(averaged),
         *map(str, ckpts)], {}, out / f"averaged_{first}-{last}.log")
    server = Server(args, averaged, out / f"serve_avg_{first}-{last}.log")
    try:
        records = evaluate(args, server.url, scenarios, out / f"eval_heldout_avg_{first}-{last}", env)
    finally:
        server.close()
    return {f"heldout avg@{first}-{last}": summarise(records, "heldout")}


def summarise(records: list[dict], label: str) -> dict:
    from mgdata.metrics import compute_metrics, parse_record

    m = compute_metrics([parse_record(r, label) for r in records]).as_dict()
    ends: dict[str, int] = {}
    for r in records:
        ends[r["end"]] = ends.get(r["end"], 0) + 1
    return {"n": len(records), **{k: m[k] for k in ("ssr", "tsr", "evr", "eng", "safe_given_eng", "svr")},
            "ttv": m["ttv"], "ends": ends, "timeouts_lacked": lacked(records)}


def lacked(records: list[dict]) -> dict[str, int]:
    """How many timed-out rollouts ended with each success condition false (``at_end``: a goal proposition
    or ``at_rest``); one rollout may lack several."""
    counts: dict[str, int] = {}
    for r in records:
        if r["end"] == "timeout" and r.get("at_end"):
            for name, held in r["at_end"].items():
                if not held:
                    counts[name] = counts.get(name, 0) + 1
    return counts


PASSED_ON = {"--ablation", "--out", "--tasks", "--recovery", "--amplitude", "--seed", "--heldout-from",
             "--scenarios-from", "--reuse", "--lr-schedule"}


def arm_args(spec: str, args: argparse.Namespace) -> tuple[list[str], int]:
    """The bench arguments of one ablation arm (``dart+x5+seed=1001``) and the layouts it trains on."""
    tasks, extra = args.tasks, ["--seed", str(args.seed)]
    for token in spec.split("+"):
        if token in ("dart", "replan"):
            extra += ["--recovery", token]
        elif token == "cosine":
            extra += ["--lr-schedule", "cosine"]
        elif token.startswith("a="):
            extra += ["--amplitude", token[2:]]
        elif re.fullmatch(r"x\d+", token):
            tasks = args.tasks * int(token[1:])
        elif token.startswith("seed="):
            extra[1] = token[5:]
        elif token != "plain":
            raise SystemExit(f"--ablation: unknown arm token {token!r} in {spec!r} (expected plain, dart, "
                             "replan, cosine, a=AMPLITUDE, xK, seed=N)")
    return ["--tasks", str(tasks), *extra], tasks


def data_args(extra: list[str]) -> tuple[tuple[str, str], ...]:
    """The arguments of an arm (``arm_args``) that shape its data, not its training (seed, schedule)."""
    pairs = zip(extra[::2], extra[1::2], strict=True)
    return tuple(p for p in pairs if p[0] not in ("--seed", "--lr-schedule"))


def passed_on(argv: list[str]) -> list[str]:
    """``argv`` without the options an ablation sets per arm."""
    out, skip = [], False
    for a in argv:
        if skip:
            skip = False
            continue
        key = a.split("=", 1)[0]
        if key in PASSED_ON:
            skip = "=" not in a and key != "--reuse"
            continue
        out.append(a)
    return out


def ablation(args: argparse.Namespace, parser: argparse.ArgumentParser) -> None:
    """Run each arm of ``--ablation`` as its own bench run under ``--out/<arm>`` (the first builds the
    scenarios, the others score on them), then print one table."""
    if args.protocol != "family":
        parser.error("--ablation runs the family protocol")
    specs = [a for a in args.ablation.split(",") if a]
    arms = {spec: arm_args(spec, args) for spec in specs}
    first_heldout = max(n for _, n in arms.values())
    if args.heldout_from is not None:  # fixed up front, so that arms added later share the starts
        if args.heldout_from < first_heldout:
            parser.error(f"--heldout-from {args.heldout_from}: an arm trains on layouts up to "
                         f"{first_heldout - 1}")
        first_heldout = args.heldout_from
    out = args.out.resolve()
    base = passed_on(sys.argv[1:])
    reports, data_of = {}, {}  # data_of: an arm's data arguments -> the first arm that generated them
    for i, (spec, (extra, _)) in enumerate(arms.items()):
        arm_out = out / spec.replace("=", "").replace("+", "_")
        cmd = [sys.executable, str(Path(__file__).resolve()), *base, *extra, "--heldout-from",
               str(first_heldout), "--out", str(arm_out)]
        if i:
            cmd += ["--scenarios-from", str(out / specs[0].replace("=", "").replace("+", "_"))]
        same = data_of.setdefault(data_args(extra), arm_out)
        if same != arm_out:  # another seed or schedule of an earlier arm's data: train on that data
            arm_out.mkdir(parents=True, exist_ok=True)
            for name in ("data", "data_state"):
                if not (arm_out / name).exists():
                    (arm_out / name).symlink_to(same / name)
        if args.reuse or same != arm_out:
            cmd.append("--reuse")
        if not (args.reuse and (arm_out / "report.json").is_file()):
            log(f"arm {spec}: " + " ".join(cmd[1:]))
            subprocess.run(cmd, check=True)
        reports[spec] = json.loads((arm_out / "report.json").read_text())
    (out / "ablation.json").write_text(json.dumps(reports, indent=1, default=str))
    print_ablation(reports)


def _rate(r: dict | None, key: str) -> str:
    """``SSR 29.0 ± 4.5`` style: the rate with its binomial standard error over the starts (EVR: engaged)."""
    if not r or r.get(key) is None:
        return "-"
    n = int(r["n"])
    if key == "evr":  # a rate over the engaged rollouts
        n = round(n * float(r["eng"]) / 100.0)
    p, n = float(r[key]) / 100.0, max(n, 1)
    return f"{100 * p:4.1f} ± {100 * (p * (1 - p) / n) ** 0.5:3.1f}"


def print_ablation(reports: dict[str, dict]) -> None:
    """One row per arm: data, yield, cost, held-out SSR / EVR / TSR and trained-layout SSR (% ± s.e.)."""
    head = ("arm", "demos", "frames", "yield", "kept/CPU-h", "steps", "held-out SSR", "EVR", "TSR",
            "trained SSR", "trained EVR")
    rows = []
    for spec, rep in reports.items():
        d, ev = rep["data"], rep.get("eval", {})
        cpu_h = float(d["cpu_s"]) / 3600.0
        kept_share = 100 * d["episodes"] / max(d["attempts"], 1)
        per_cpu_h = f"{d['episodes'] / cpu_h:.0f}" if d["cpu_s"] > 1 else "(reused)"  # data of another arm
        rows.append((spec, str(d["episodes"]), str(d["frames"]), f"{kept_share:.0f} %",
                     per_cpu_h, str(rep["train"]["steps"]),
                     _rate(ev.get("heldout"), "ssr"), _rate(ev.get("heldout"), "evr"),
                     _rate(ev.get("heldout"), "tsr"), _rate(ev.get("base"), "ssr"),
                     _rate(ev.get("base"), "evr")))
    widths = [max(len(h), *(len(r[i]) for r in rows)) for i, h in enumerate(head)]
    print("\n" + "  ".join(h.ljust(w) for h, w in zip(head, widths, strict=True)))
    for r in rows:
        print("  ".join(c.ljust(w) for c, w in zip(r, widths, strict=True)))
    for spec, rep in reports.items():
        ckpts = {k: r for k, r in rep.get("eval", {}).items() if k.startswith("heldout@")}
        if ckpts:
            ssr = [float(r["ssr"]) for r in ckpts.values()]
            print(f"{spec}: held-out SSR by checkpoint: "
                  + ", ".join(f"{k[8:]} {float(r['ssr']):.1f} % (EVR {_rate(r, 'evr')})"
                              for k, r in ckpts.items())
                  + f"; mean {np.mean(ssr):.1f} %, spread {min(ssr):.1f}-{max(ssr):.1f} %")
    for spec, rep in reports.items():
        print(f"{spec}: {rep.get('command', '')}")


def steps_list(text: str) -> tuple[int, ...]:
    """``--checkpoints 15000,17500`` → (15000, 17500)."""
    try:
        steps = tuple(int(x) for x in text.split(",") if x.strip())
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r}: expected training steps, e.g. 15000,17500") from None
    if any(n <= 0 for n in steps):
        raise argparse.ArgumentTypeError(f"{text!r}: steps must be positive")
    return steps


def build_parser() -> argparse.ArgumentParser:
    """The benchmark's options (also the learner settings of ``bench_corrections.py``)."""
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--protocol", choices=("family", "single"), default="family")
    p.add_argument("--family", default="jar")
    p.add_argument("--tasks", type=int, default=26, help="base tasks trained on (family) ")
    p.add_argument("--layouts", type=int, default=20, help="layouts of the one task trained on (single)")
    p.add_argument("--per-task", type=int, default=None, help="kept demos per task (family 8, single 3)")
    p.add_argument("--grasp-cycle", type=int, default=1,
                   help="the recipe's grasp_cycle: demos cycle through this many of the most natural "
                        "reachable grasps (0: all, round-robin; the recipes' default)")
    p.add_argument("--heldout", type=int, default=None, help="held-out draws (family 100, single 30)")
    p.add_argument("--variants", default="location,target", help="OOD conditions evaluated besides base")
    p.add_argument("--seen", type=int, default=None,
                   help="evaluate the first this many trained layouts (default: all of them; with "
                   "hundreds of layouts a sample is enough)")
    p.add_argument("--steps", type=int, default=6000)
    p.add_argument("--batch", type=int, default=32)
    p.add_argument("--dim-model", type=int, default=128)
    p.add_argument("--encoder-layers", type=int, default=2)
    p.add_argument("--chunk", type=int, default=20)
    p.add_argument("--chunk-steps", type=int, default=10, help="actions executed per query")
    p.add_argument("--ensemble", type=float, default=0.01,
                   help="temporal ensembling coefficient (mgdata eval --ensemble; queries every step; ACT's "
                   "0.01 by default: without it the policy's chunk switches jitter the held jar past the "
                   "goal's at-rest limit); a negative value turns it off (--chunk-steps)")
    p.add_argument("--lr", type=float, default=1e-4)
    p.add_argument("--lr-schedule", choices=("constant", "cosine"), default="constant",
                   help="constant: ACT's preset (AdamW at --lr throughout); cosine: the same AdamW with "
                   "LeRobot's cosine_decay_with_warmup (5 %% warm-up, then down to --lr / 100 at the last "
                   "step)")
    p.add_argument("--seed", type=int, default=1000)
    p.add_argument("--device", default="cpu", help="training device")
    p.add_argument("--serve-device", default="cpu")
    p.add_argument("--workers", type=int, default=2, help="generation and evaluation processes")
    p.add_argument("--loader-workers", type=int, default=0)
    p.add_argument("--torch-threads", type=int, default=1)
    p.add_argument("--train-timeout", type=float, default=None,
                   help="stop training after this many seconds and use its last checkpoint")
    p.add_argument("--horizon", type=int, default=None, help="cut rollouts (smoke runs)")
    p.add_argument("--lerobot-python", default=os.environ.get("LEROBOT_PYTHON", sys.executable))
    p.add_argument("--reuse", action="store_true",
                   help="reuse data, state view, scenarios and checkpoint already under --out "
                   "(a missing state view is exported again from the data)")
    p.add_argument("--recovery", choices=("off", "dart", "replan"), default="off",
                   help="generate the training demos with this recovery mode (mgdata generate --recovery)")
    p.add_argument("--amplitude", type=float, default=None,
                   help="the recipe copy's [recovery] amplitude (rad; default: the recipe's)")
    p.add_argument("--heldout-from", type=int, default=None,
                   help="first held-out task (default: right after the trained ones); an ablation puts it "
                   "after its largest arm's layouts so that every arm is scored on the same starts")
    p.add_argument("--scenarios-from", type=Path, default=None,
                   help="use the seen and held-out scenarios another run built under this --out")
    p.add_argument("--ablation", default=None, metavar="ARMS",
                   help="run one arm per comma-separated spec, the same learner, steps, seed and held-out "
                   "starts, only the data changed, and print their table; a spec joins with '+': "
                   "'plain', 'dart' or 'replan' (recovery), 'a=0.05' (its amplitude), 'x5' (5x the layouts, "
                   "--per-task each), 'seed=1001' (another training seed: trained on the data of the earlier "
                   "arm it differs from only in seed or schedule); e.g. plain,dart,x5,dart+seed=1001")
    p.add_argument("--checkpoints", type=steps_list, default=(), metavar="STEPS",
                   help="also score these saved checkpoints (comma-separated training steps, multiples of "
                   "the save interval, min(steps/4, 500)) on the held-out starts: one run's closed-loop "
                   "rate swings from checkpoint to checkpoint, and their mean is a steadier figure")
    p.add_argument("--average", type=int, default=0, metavar="SPAN",
                   help="also score the uniform mean of the weights saved over the last SPAN training "
                   "steps (every save interval; average_checkpoints.py) on the held-out starts")
    p.add_argument("--stop-after", choices=("data", "train"), default=None)
    p.add_argument("--record", action="store_true",
                   help="record the trained-layout rollouts (mgdata eval --record: eval_seen/rollouts), the "
                        "input of mgdata corrections")
    p.add_argument("--out", type=Path, required=True)
    return p


def main() -> None:
    p = build_parser()
    args = p.parse_args()
    bad = [n for n in args.checkpoints if n > args.steps or n % save_interval(args)]
    if bad:
        p.error(f"--checkpoints {bad[0]}: not saved (checkpoints every {save_interval(args)} steps up to "
                f"--steps {args.steps})")
    if args.ablation:
        ablation(args, p)
        return
    single = args.protocol == "single"
    per_task = args.per_task or (3 if single else 8)
    heldout = args.heldout if args.heldout is not None else (30 if single else 100)
    ntasks = args.layouts if single else args.tasks
    out = args.out.resolve()
    out.mkdir(parents=True, exist_ok=True)
    first_heldout = ntasks if args.heldout_from is None else args.heldout_from
    if first_heldout < ntasks:
        raise SystemExit(f"--heldout-from {first_heldout} would score trained layouts (0-{ntasks - 1})")
    count = first_heldout + heldout
    pins = task0_models(args.family) if single else None
    train_root = make_root(out / "root_train", args.family, count, "[]", pins, args.grasp_cycle,
                           args.amplitude)
    eval_root = make_root(out / "root_eval", args.family, count, '["front", "wrist"]', pins, args.grasp_cycle)
    t_start = time.time()
    report: dict = {"protocol": args.protocol, "family": args.family, "per_task": per_task, "tasks": ntasks,
                    "grasp_cycle": args.grasp_cycle, "recovery": args.recovery, "amplitude": args.amplitude,
                    "heldout_tasks": f"{first_heldout}-{count - 1}", "command": shlex.join(sys.argv),
                    "heldout": heldout, "args": {k: str(v) for k, v in vars(args).items()}}
    data, state = out / "data", out / "data_state"
    c0 = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.time()
    if not (args.reuse and (data / "meta/info.json").is_file()):
        run([*MGDATA, "generate", "--family", args.family, "--tasks", f"0-{ntasks - 1}", "--per-task",
             str(per_task), "--workers", str(args.workers), "--out", str(data), "--recovery", args.recovery],
            {"MGDATA_ROOT": str(train_root)}, out / "generate.log")
    if not (args.reuse and state.is_dir()):
        shutil.rmtree(state, ignore_errors=True)
        run([*MGDATA, "export", str(data), str(state), "--format", "state"], {"MGDATA_ROOT": str(train_root)})
    c1 = resource.getrusage(resource.RUSAGE_CHILDREN)
    info = json.loads((state / "meta/info.json").read_text())
    report["data"] = {"episodes": info["total_episodes"], "frames": info["total_frames"],
                      "wall_s": round(time.time() - t0, 1),
                      "cpu_s": round(c1.ru_utime + c1.ru_stime - c0.ru_utime - c0.ru_stime, 1),
                      "attempts": json.loads((data / "meta/mgdata_generate.json").read_text())["attempts"],
                      "environment_state": info["features"]["observation.environment_state"]["names"],
                      "spread": demo_spread(data)}
    log(f"demos alike: {report['data']['spread']}")
    log(f"data: {report['data']['episodes']} episodes, {report['data']['frames']} frames")
    shared = args.scenarios_from.resolve() if args.scenarios_from else out
    scen = {"seen": shared / "scen_seen", "heldout": shared / "scen_heldout"}
    conds = ["base", *[c for c in args.variants.split(",") if c]]
    if args.scenarios_from is None and not (args.reuse and (scen["seen"] / "manifest.json").exists()):
        seen = min(args.seen or ntasks, ntasks)
        cmd = [*MGDATA, "scenarios", "build", "--family", args.family, "--tasks", f"0-{seen - 1}",
               "--workers", str(args.workers), "--out", str(scen["seen"])]
        for c in conds:
            cmd += ["--condition", c]
        run(cmd, {"MGDATA_ROOT": str(eval_root)}, out / "scen_seen.log")
        if heldout:
            run([*MGDATA, "scenarios", "build", "--family", args.family, "--tasks",
                 f"{first_heldout}-{count - 1}",
                 "--condition", "base", "--workers", str(args.workers), "--out", str(scen["heldout"])],
                {"MGDATA_ROOT": str(eval_root)}, out / "scen_heldout.log")
    if args.stop_after == "data":
        print(json.dumps(report, indent=1))
        return
    ckpt, timing = train(args, state, out / "train")
    report["train"] = timing
    log(f"trained {timing['steps']} steps in {timing['wall_s']} s wall, {timing['cpu_s']} s CPU")
    if args.stop_after == "train":
        print(json.dumps(report, indent=1))
        return
    server = Server(args, ckpt, out / "serve.log")
    results: dict = {}
    try:
        env = {"MGDATA_ROOT": str(eval_root)}
        records = evaluate(args, server.url, scen["seen"], out / "eval_seen", env, args.record)
        for c in conds:
            results[c] = summarise([r for r in records if r["condition"] == c], c)
        if heldout:
            records = evaluate(args, server.url, scen["heldout"], out / "eval_heldout", env)
            results["heldout"] = summarise(records, "heldout")
    finally:
        server.close()
    if heldout:
        results.update(score_checkpoints(args, out, scen["heldout"], {"MGDATA_ROOT": str(eval_root)}))
        if args.average:
            results.update(score_average(args, out, timing["steps"], scen["heldout"],
                                         {"MGDATA_ROOT": str(eval_root)}))
    report["eval"] = results
    report["wall_s"] = round(time.time() - t_start, 1)
    (out / "report.json").write_text(json.dumps(report, indent=1, default=str))
    print(f"\n{args.protocol} protocol, {args.family}: {report['data']['episodes']} demos, "
          f"{timing['steps']} steps ({timing['wall_s']} s wall, {timing['cpu_s']} s CPU)")
    w = max(10, *map(len, results))
    print(f"{'condition':<{w}} {'n':>4} {'SSR':>6} {'TSR':>6} {'EVR':>6} {'Eng.':>6} {'Safe|Eng':>8}")
    for c, r in results.items():
        def pct(v: object) -> str:
            return "-" if v is None else f"{float(v):5.1f}%"
        print(f"{c:<{w}} {r['n']:>4} {pct(r.get('ssr')):>6} {pct(r.get('tsr')):>6} {pct(r.get('evr')):>6} "
              f"{pct(r.get('eng')):>6} {pct(r.get('safe_given_eng')):>8}  ends {r['ends']}"
              + (f", timeouts lacked {r['timeouts_lacked']}" if r.get("timeouts_lacked") else ""))
    print("loss curve (step, loss):", timing["loss"])


if __name__ == "__main__":
    main()
