"""``mgdata eval`` (closed-loop evaluation on the locked scenarios) and ``mgdata serve`` (the reference
policies over openpi's websocket protocol). docs/eval.md."""

from __future__ import annotations

import json
import signal
import sys
from pathlib import Path
from typing import TYPE_CHECKING, Annotated

import typer

from mgdata.console import plain_console
from mgdata.errors import RecipeError

if TYPE_CHECKING:
    from mgdata.evaluate.server import Policy

HOST_HELP = "Interface to bind (default: this machine only)."
PORT_HELP = "Port (0: any free port; the URL is printed)."


def _ints(text: str, option: str) -> tuple[int, ...]:
    try:
        values = tuple(int(v) for v in text.split(",") if v.strip())
    except ValueError:
        raise RecipeError(f"{option} {text!r}: expected integers separated by commas, e.g. 0,1,2") from None
    if not values or len(set(values)) != len(values):
        raise RecipeError(f"{option} {text!r}: expected distinct integers separated by commas, e.g. 0,1,2")
    return values


def register(app: typer.Typer) -> None:
    @app.command("eval")
    def eval_cmd(
        policy: Annotated[str, typer.Option(help="Policy server, ws://HOST:PORT (openpi protocol).")],
        scenarios: Annotated[Path, typer.Option(help="Scenario set (mgdata scenarios build --out).")],
        family: Annotated[list[str] | None, typer.Option(help="Only this family (repeatable).")] = None,
        condition: Annotated[list[str] | None, typer.Option(
            help="Only this condition (repeatable).")] = None,
        seeds: Annotated[str, typer.Option(help="Base seeds, e.g. 0,1,2.")] = "0,1,2",
        cameras: Annotated[str | None, typer.Option(
            help="Cameras sent, comma-separated (pi0/smolvla: overview,wrist; default: first overview + "
            "wrist).")] = None,
        convention: Annotated[str, typer.Option(
            help="Observation keys: pi0, smolvla, groot or state (no camera rendered).")] = "pi0",
        chunk_steps: Annotated[int | None, typer.Option(
            help="Actions executed per query (default: recipes/eval.toml).")] = None,
        ensemble: Annotated[float | None, typer.Option(
            help="Temporal ensembling (ACT): query the policy at every step and execute the weighted mean "
            "of every chunk's prediction for that step, the k-th oldest weighted exp(-ENSEMBLE*k) "
            "(e.g. 0.01; replaces --chunk-steps).")] = None,
        timeout: Annotated[float | None, typer.Option(
            help="Seconds to wait for a reply before the rollout fails (default: recipes/eval.toml).")
        ] = None,
        horizon: Annotated[int | None, typer.Option(
            help="Cut rollouts at this many steps (smoke runs; default: each scenario's horizon).")] = None,
        workers: Annotated[int, typer.Option(
            help="Rollout processes (same results for any count).")] = 1,
        video: Annotated[bool, typer.Option(
            help="Write a video per rollout with the monitor overlay.")] = False,
        record: Annotated[bool, typer.Option(
            help="Record every rollout (physics states, safety columns, outcome) as an episode of the "
            "LeRobot dataset OUT/rollouts/<family>, to preview, restore or correct (mgdata corrections)."
        )] = False,
        out: Annotated[Path, typer.Option(
            help="Results folder (rollouts.jsonl; resumable).")] = Path("results"),
    ) -> None:
        """Roll a policy out on every scenario × seed, monitored like generation, one JSON line per rollout
        in OUT/rollouts.jsonl (read it with mgdata metrics). Re-run to resume.

        Example: mgdata eval --policy ws://127.0.0.1:8000 --scenarios scenarios --family jar --out results
        """
        from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn

        from mgdata.evaluate.client import check_health, check_url
        from mgdata.evaluate.config import load_eval_config
        from mgdata.evaluate.conventions import CONVENTIONS, check_cameras, default_cameras
        from mgdata.evaluate.ensemble import ChunkEnsemble
        from mgdata.evaluate.rollout import LoopSettings
        from mgdata.evaluate.run import EvalJob, plan, run_eval

        config = load_eval_config().client
        if convention not in CONVENTIONS:
            raise RecipeError(f"--convention {convention!r}: expected one of {', '.join(CONVENTIONS)}")
        if workers < 1:
            raise RecipeError(f"--workers must be at least 1, got {workers}")
        steps = config.chunk_steps if chunk_steps is None else chunk_steps
        if steps < 1:
            raise RecipeError(f"--chunk-steps must be at least 1, got {steps}")
        wait_s = config.timeout_s if timeout is None else timeout
        if wait_s <= 0:
            raise RecipeError(f"--timeout must be positive, got {wait_s}")
        if horizon is not None and horizon < 1:
            raise RecipeError(f"--horizon must be at least 1, got {horizon}")
        if ensemble is not None:
            try:
                ChunkEnsemble(ensemble)  # its own check is the one rule
            except ValueError as e:
                raise RecipeError(f"--ensemble: {e}") from None
        check_url(policy)
        chosen = tuple(c.strip() for c in cameras.split(",") if c.strip()) if cameras else None
        settings = LoopSettings(policy, convention, chosen, steps, wait_s, config.connect_timeout_s,
                                out / "videos" if video else None, horizon, ensemble,
                                out / "rollouts" if record else None)
        job = EvalJob(scenarios, settings, _ints(seeds, "--seeds"), out,
                      tuple(family) if family else None, tuple(condition) if condition else None, workers)
        first = plan(job)[0]  # bad scenario folders and filters fail before the server is asked
        cams = list(json.loads((scenarios / first.scenario / "scenario.json").read_text())["cameras"])
        check_cameras(convention, chosen or default_cameras(convention, cams), cams)
        check_health(policy, config.connect_timeout_s)
        console = plain_console()
        outcomes: dict[str, int] = {}
        with Progress(TextColumn("eval"), BarColumn(), MofNCompleteColumn(), TextColumn("{task.description}"),
                      TimeElapsedColumn(), console=plain_console(stderr=True), transient=True) as bar:
            task = bar.add_task("", total=None)

            def planned(total: int, done: int) -> None:
                bar.update(task, total=total, completed=done)

            def finished(record: dict) -> None:
                outcomes[record["end"]] = outcomes.get(record["end"], 0) + 1
                ends = " ".join(f"{k} {v}" for k, v in sorted(outcomes.items()))
                bar.update(task, advance=1, description=ends)

            summary = run_eval(job, finished, planned)
        console.print(f"{summary.ran} rollouts run, {summary.resumed} already done, {summary.planned} in "
                      f"{summary.results}")
        if outcomes:
            console.print("ends: " + ", ".join(f"{k} {v}" for k, v in sorted(outcomes.items())))
        if summary.planned:
            from mgdata.evaluate.page import write_results_page
            from mgdata.metrics import load_records

            page = write_results_page(load_records(summary.results), out / "results.html")
            console.print(f"results page: {page}")
        if record:
            console.print(f"recorded rollouts: {out / 'rollouts'}/<family> (mgdata corrections "
                          f"{out / 'rollouts'}/<family> --out …)")
        console.print(f"metrics: mgdata metrics {summary.results} --by family,condition")

    serve = typer.Typer(help="Serve a reference policy over openpi's websocket protocol.",
                        no_args_is_help=True)
    app.add_typer(serve, name="serve")

    @serve.command("hold")
    def serve_hold(host: Annotated[str, typer.Option(help=HOST_HELP)] = "127.0.0.1",
                   port: Annotated[int, typer.Option(help=PORT_HELP)] = 8000) -> None:
        """Never move: every action is the joint command in force.

        Example: mgdata serve hold --port 8000
        """
        from mgdata.evaluate.config import load_eval_config
        from mgdata.evaluate.policies import HoldPolicy

        _serve(HoldPolicy(load_eval_config().serve.chunk), host, port)

    @serve.command("random")
    def serve_random(seed: Annotated[int, typer.Option(help="Seed mixed with each rollout's seed.")] = 0,
                     host: Annotated[str, typer.Option(help=HOST_HELP)] = "127.0.0.1",
                     port: Annotated[int, typer.Option(help=PORT_HELP)] = 8000) -> None:
        """Seeded random joint-target walks (table "random" of recipes/eval.toml); results depend only on
        the seed and each rollout's own seed, never on order or workers.

        Example: mgdata serve random --seed 0 --port 8000
        """
        from mgdata.evaluate.config import load_eval_config
        from mgdata.evaluate.policies import RandomPolicy

        _serve(RandomPolicy(seed, load_eval_config().random), host, port)

    @serve.command("replay")
    def serve_replay(
        dataset: Annotated[Path, typer.Option(help="A dataset with physics states (mgdata generate).")],
        scenarios: Annotated[Path | None, typer.Option(
            help="Match scenarios to episodes by their initial physics state (recommended).")] = None,
        host: Annotated[str, typer.Option(help=HOST_HELP)] = "127.0.0.1",
        port: Annotated[int, typer.Option(help=PORT_HELP)] = 8000,
    ) -> None:
        """Serve a recorded episode's actions for the scenario it started from.

        Example: mgdata serve replay --dataset datasets/jar --scenarios scenarios --port 8000
        """
        from mgdata.evaluate.config import load_eval_config
        from mgdata.evaluate.policies import ReplayPolicy

        policy = ReplayPolicy(dataset, chunk=load_eval_config().serve.chunk, scenarios=scenarios)
        if scenarios is not None:
            plain_console().print(f"replay: {len(policy.scenarios)} scenarios of {scenarios} start from an "
                                  f"episode of {dataset}")
        _serve(policy, host, port)


    @serve.command("lerobot")
    def serve_lerobot(
        checkpoint: Annotated[Path, typer.Option(help="A LeRobot save_pretrained folder (config.json …).")],
        device: Annotated[str, typer.Option(help="Torch device.")] = "cpu",
        host: Annotated[str, typer.Option(help=HOST_HELP)] = "127.0.0.1",
        port: Annotated[int, typer.Option(help=PORT_HELP)] = 8000,
    ) -> None:
        """Serve a LeRobot policy checkpoint (needs the lerobot extra); evaluate it with
        --convention smolvla.

        Example: mgdata serve lerobot --checkpoint outputs/train/act/checkpoints/last/pretrained_model
        """
        from mgdata.evaluate.lerobot_policy import LeRobotPolicy

        _serve(LeRobotPolicy(checkpoint, device), host, port)


def _serve(policy: Policy, host: str, port: int) -> None:
    from mgdata.errors import OutputError
    from mgdata.evaluate.server import PolicyServer

    if not 0 <= port <= 65535:
        raise RecipeError(f"--port {port}: expected 0 … 65535")
    try:
        server = PolicyServer(policy, host, port)
    except OSError as err:
        raise OutputError(f"cannot listen on {host}:{port}: {err.strerror or err}") from None
    signal.signal(signal.SIGTERM, lambda *_: server.shutdown())
    print(f"serving {policy.metadata['policy']} on {server.url} (health: GET /healthz)", flush=True)
    try:
        server.serve_forever()
    except KeyboardInterrupt:
        server.shutdown()
    sys.stdout.flush()
