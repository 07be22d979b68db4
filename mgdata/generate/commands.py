"""``mgdata generate`` (demonstrations into a LeRobot dataset) and ``mgdata preview`` (watch some of them)."""

from __future__ import annotations

import os
from collections.abc import Callable
from pathlib import Path
from typing import Annotated

import typer

from mgdata.console import plain_console
from mgdata.errors import DatasetError, OutputError, RecipeError
from mgdata.options import parse_ids
from mgdata.paths import datasets_dir


def parse_shard(text: str | None) -> tuple[int, int] | None:
    """``"1/4"`` -> ``(1, 4)``."""
    if text is None:
        return None
    i, sep, n = text.partition("/")
    try:
        if not sep:
            raise ValueError(text)
        return int(i), int(n)
    except ValueError:
        raise RecipeError(f"--shard {text!r}: expected i/N, e.g. 0/4") from None


def register(app: typer.Typer) -> None:
    @app.command("tasks")
    def tasks_cmd(
        family: Annotated[str, typer.Argument(help="Task family (a recipe under recipes/).")],
        tasks: Annotated[str, typer.Option(help="Base tasks: 'all' or e.g. '0-3,7'.")] = "all",
        render: Annotated[bool, typer.Option(help="Also draw the initial scenes into a contact sheet.")]
        = False,
        out: Annotated[Path | None, typer.Option(help="Contact sheet PNG (default: <family>_tasks.png).")]
        = None,
    ) -> None:
        """List a family's base tasks as the initial-state gate accepts them: objects, goal, prompt, reachable
        grasps; --render draws each task's initial scene from two cameras into one PNG.

        Exit status 2 if a task fails the gate (its row says why).

        Example: mgdata tasks clutter_dry --tasks 0-5 --render --out clutter_tasks.png
        """
        from mgdata.generate.task_report import gate_report, write_sheet
        from mgdata.skeleton.skeleton import load_family_recipe

        recipe = load_family_recipe(family)
        chosen = parse_ids(tasks) or tuple(range(recipe.tasks.count))
        bad = [k for k in chosen if not 0 <= k < recipe.tasks.count]
        if bad:
            raise RecipeError(f"--tasks: {family} has tasks 0 … {recipe.tasks.count - 1}, not {bad[0]}")
        sheet = out or Path(f"{family}_tasks.png")
        if render and (sheet.is_dir() or not sheet.parent.is_dir()):
            raise OutputError(f"--out {sheet}: expected a file path in an existing folder")
        console = plain_console()
        rows = []
        for row in gate_report(recipe, chosen):
            console.print(row.line())
            rows.append(row)
        failed = [r for r in rows if r.task is None]
        if render:
            path = write_sheet([r.task for r in rows if r.task is not None], sheet)
            console.print(f"wrote {path}")
        console.print(f"{len(rows) - len(failed)} of {len(rows)} tasks pass the initial-state gate")
        if failed:
            raise RecipeError(f"{len(failed)} task(s) fail the initial-state gate: "
                              f"{', '.join(str(r.task_id) for r in failed)}")

    @app.command()
    def generate(
        family: Annotated[str, typer.Option(
            help="Task family (recipe + skeleton), or 'all': one dataset per family under --out.")] = "jar",
        n: Annotated[int | None, typer.Option("--n", help="Kept demonstrations wanted in the dataset "
                                                          "\\[default: 40].", show_default=False)] = None,
        per_task: Annotated[int | None, typer.Option(
            help="Kept demonstrations wanted per base task (instead of --n; the paper's release: 40).")]
        = None,
        tasks: Annotated[str, typer.Option(help="Base tasks, round-robin: 'all' or e.g. '0-3,7'.")] = "all",
        task: Annotated[int | None, typer.Option(help="A single base task (same as --tasks K).")] = None,
        out: Annotated[Path | None, typer.Option(help="Dataset folder (default: datasets/<family>).")] = None,
        workers: Annotated[int | None, typer.Option(
            help="Parallel attempt processes, at least 1 (default: one per CPU core; same output for any "
                 "count).",
            show_default=False)] = None,
        seed: Annotated[int, typer.Option(help="Seed mixed into every attempt's seed.")] = 0,
        keep_failed: Annotated[bool, typer.Option(help="Also keep failed/unsafe attempts, in <out>_failed.")]
        = False,
        max_attempts: Annotated[int | None, typer.Option(help="Attempt budget (4 × missing).")] = None,
        codec: Annotated[str, typer.Option(help="Video codec of a new dataset: h264 or av1.")] = "h264",
        recipe: Annotated[Path | None, typer.Option(help="Use this recipe file.")] = None,
        shard: Annotated[str | None, typer.Option(
            help="Generate shard i of N ('i/N', with --per-task): tasks i, i+N, …; join with mgdata merge.")]
        = None,
        ray: Annotated[str | None, typer.Option(
            "--ray", metavar="[ADDRESS]",
            help="Run the attempts on Ray (the optional ray extra of mgdata): --workers actors on a "
                 "private local instance, or on the cluster at ADDRESS; nodes that would not reproduce "
                 "this machine's bytes are refused.")] = None,
        render_after: Annotated[bool, typer.Option(
            "--render-after/--render-during",
            help="Render only the recorded episodes, after the gate, from their physics states (same "
                 "bytes as rendering every step during execution, faster when attempts fail).")] = True,
        condition: Annotated[str, typer.Option(
            help="Generate in a scenario condition: base, target, language, location, environment (or env), "
                 "or all (a task's draws cycle through the five).")] = "base",
        recovery: Annotated[str | None, typer.Option(
            help="Demonstrations that show recovery: 'dart' executes every planned segment with a smooth "
                 "seeded offset on its joint targets (the recipe's \\[recovery] amplitude) and records the "
                 "plan's targets as the actions; 'replan' pushes the arm off each planned segment once and "
                 "plans the rest again from there; 'off' plain demos \\[default: the recipe's \\[recovery] "
                 "mode, off].", show_default=False)] = None,
    ) -> None:
        """Generate safety-gated demonstrations into a LeRobot v3.0 dataset; re-run to resume.

        Example: mgdata generate --family jar --n 40 --workers 2
        """
        from mgdata.generate.run import GenerateJob
        from mgdata.generate.run import generate as run
        from mgdata.generate.suite import ALL, generate_suite, suite_table
        from mgdata.generate.summary import ProgressView, RunSummary, print_summary

        if n is not None and per_task is not None:
            raise RecipeError("--n and --per-task exclude each other: give the dataset's total or the "
                              "per-task quota")
        job = GenerateJob(family=family, n=40 if n is None else n, out=out or datasets_dir() / family,
                          tasks=(task,) if task is not None else parse_ids(tasks),
                          workers=len(os.sched_getaffinity(0)) if workers is None else workers, seed=seed,
                          keep_failed=keep_failed, max_attempts=max_attempts, codec=codec, recipe=recipe,
                          render_after=render_after, per_task=per_task, shard=parse_shard(shard),
                          ray=ray, condition="environment" if condition == "env" else condition,
                          recovery=recovery)
        console = plain_console()
        if family == ALL:
            views: list[ProgressView] = []

            def start(fam_job: GenerateJob) -> Callable[[RunSummary], None]:
                for old in views:
                    old.__exit__(None)
                console.print(f"{fam_job.family} -> {fam_job.out}")
                views.append(ProgressView(RunSummary(out=fam_job.out, target=fam_job.n), console))
                return views[-1].update

            try:
                rows = generate_suite(job, on_start=start)
            finally:
                for view in views:
                    view.__exit__(None)
            console.print(suite_table(rows))
            if any(s.total_kept < s.target for _, s in rows):
                raise typer.Exit(1)
            return
        with ProgressView(RunSummary(out=job.out, target=job.n), console) as view:
            summary = run(job, on_attempt=view.update)
        print_summary(summary, console)
        if summary.total_kept < summary.target:
            raise typer.Exit(1)

    @app.command()
    def corrections(
        rollouts: Annotated[Path, typer.Argument(
            help="Recorded rollouts of one family: the folder mgdata eval --record wrote, "
                 "<eval out>/rollouts/<family>.")],
        out: Annotated[Path, typer.Option("--out", help="Corrections dataset folder (created, or resumed).")],
        tasks: Annotated[str, typer.Option(
            help="Correct the rollouts of these base tasks only, e.g. '0-31': leave held-out tasks out, "
                 "or their layouts become training data.")] = "all",
        back: Annotated[int, typer.Option(help="Frames between restart candidates, counted back from the "
                                               "failure (20 = 1 s).")] = 20,
        candidates: Annotated[int, typer.Option(
            help="Restart frames tried per failed rollout (frames the restart rules refuse do not count).")]
        = 4,
        tries: Annotated[int, typer.Option(help="Draws (planning seeds) per restart candidate.")] = 2,
        per_failure: Annotated[int, typer.Option(help="Kept corrections wanted per failed rollout.")] = 1,
        workers: Annotated[int | None, typer.Option(
            help="Parallel processes, a rollout each (default: one per CPU core; same output for any "
                 "count).", show_default=False)] = None,
        seed: Annotated[int, typer.Option(help="Seed mixed into every correction's seed.")] = 0,
        codec: Annotated[str, typer.Option(help="Video codec of a new dataset: h264 or av1.")] = "h264",
        recipe: Annotated[Path | None, typer.Option(help="Use this recipe file (the one the scenarios were "
                                                         "built from).")] = None,
        grasps: Annotated[Path | None, typer.Option(help="Grasp database folder.")] = None,
        shard: Annotated[str | None, typer.Option(
            help="Correct shard i of N ('i/N'): the selected failed rollouts i, i+N, … in the rollouts' "
                 "order, with the unsharded run's draws; join the N shards with mgdata merge.")] = None,
    ) -> None:
        """Demonstrations restarted where a policy went wrong: for every failed rollout (a violation, or no
        success), restart the planner from the rollout's own recorded state a little before the first
        violation (or before the end, where the policy stalled), and keep what the physics gate keeps.

        Candidates are the frames failure − back, failure − 2·back, …; one the restart rules refuse
        (objects moving, the spec already violated, an object in the hand) is passed over, and after
        --candidates frames tried the rollout is left. Each rollout's tries are listed in
        <out>/meta/mgdata_corrections.json. Re-run to resume. With --shard i/N on N machines, mgdata
        merge joins the N shard datasets into the one an unsharded run writes, byte for byte.

        Example: mgdata corrections eval/rollouts/jar --out datasets/jar_corrections --tasks 0-31
        Example: mgdata corrections eval/rollouts/jar --out ds/jar_corr_1 --tasks 0-31 --shard 1/4
        """
        from mgdata.generate.corrections import NOTHING_TO_CORRECT, CorrectionJob, correct
        from mgdata.generate.summary import ProgressView, RunSummary, print_summary

        job = CorrectionJob(rollouts=rollouts, out=out, tasks=parse_ids(tasks), back=back,
                            candidates=candidates, tries=tries, per_failure=per_failure,
                            workers=len(os.sched_getaffinity(0)) if workers is None else workers, seed=seed,
                            codec=codec, grasps=grasps, recipe=recipe, shard=parse_shard(shard))
        if not rollouts.is_dir():
            raise DatasetError(f"{rollouts}: no such rollouts folder")
        console = plain_console()
        with ProgressView(RunSummary(out=out, target=0), console, "corrections") as view:
            summary = correct(job, on_attempt=view.update)
        if not summary.attempts and summary.kept_before == 0 and summary.target == 0:
            where = "; nothing written" if summary.stopped == NOTHING_TO_CORRECT else f" ({out})"
            console.print(f"{rollouts}: {summary.stopped}{where}")
            return
        print_summary(summary, console, "corrections")
        console.print(f"tries per rollout: {out / 'meta' / 'mgdata_corrections.json'}")

    @app.command()
    def preview(
        dataset: Annotated[Path, typer.Argument(help="Dataset folder.")],
        episodes: Annotated[str | None, typer.Option(
            help="Episode indices, e.g. '0-2,5' (default: the first three, or all if fewer).")] = None,
        out: Annotated[Path | None, typer.Option(help="Output mp4 (default: <dataset>/preview.mp4).")] = None,
    ) -> None:
        """Render an mp4 of some episodes: every camera in a grid, with the step's safety labels.

        Example: mgdata preview datasets/jar --episodes 0-2 --out jar_preview.mp4
        """
        from mgdata.generate.preview import render_preview

        chosen = None if episodes is None else parse_ids(episodes, "--episodes")
        if not dataset.is_dir():
            raise DatasetError(f"{dataset}: no such dataset folder")
        target = out or dataset / "preview.mp4"
        if target.is_dir() or not target.parent.is_dir():
            raise OutputError(f"--out {target}: expected a file path in an existing folder")
        try:
            path = render_preview(dataset, chosen, target)
        except OSError as err:
            raise OutputError(f"--out {target}: cannot write the preview ({err.strerror or err})") from None
        plain_console().print(f"wrote {path}")

    @app.command()
    def merge(
        shards: Annotated[list[Path], typer.Argument(
            help="The shard datasets (of one mgdata generate --shard i/N or mgdata corrections --shard i/N "
                 "run), or with --concat any datasets of one family.")],
        out: Annotated[Path, typer.Option("--out", help="Merged dataset folder (must not exist).")],
        concat: Annotated[bool, typer.Option(
            "--concat", help="Join datasets of different runs (e.g. demos and their corrections) into a "
                             "training set: every episode of the first, then of the next, …")] = False,
    ) -> None:
        """Join shard datasets into the dataset one run over all their tasks writes, byte for byte (shards
        of mgdata corrections: the dataset the unsharded run writes); with --concat, join datasets of one
        family, schema and spec in the order given.

        Example: mgdata merge ds/jar_0 ds/jar_1 --out datasets/jar
        Example: mgdata merge ds/jar_corr_0 ds/jar_corr_1 ds/jar_corr_2 ds/jar_corr_3 --out ds/jar_corr
        Example: mgdata merge --concat datasets/jar datasets/jar_corrections --out datasets/jar_round2
        """
        from mgdata.generate.merge import concat_datasets, merge_shards

        for shard in shards:
            if not shard.is_dir():
                raise DatasetError(f"{shard}: no such dataset folder")
        if concat:
            n = concat_datasets(list(shards), out)
            plain_console().print(f"wrote {out} ({n} episodes from {len(shards)} datasets)")
            return
        n = merge_shards(list(shards), out)
        plain_console().print(f"wrote {out} ({n} episodes from {len(shards)} shards)")
