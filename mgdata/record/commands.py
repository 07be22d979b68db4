"""CLI commands on datasets: ``mgdata validate``, ``mgdata card``, ``mgdata info``, ``mgdata export``,
``mgdata render``."""

from __future__ import annotations

import json
from dataclasses import asdict
from pathlib import Path
from typing import Annotated

import typer

from mgdata.errors import DatasetError
from mgdata.record.summary import format_summary, summarize
from mgdata.record.validate import validate_dataset
from mgdata.record.views import FORMATS

Dataset = Annotated[Path, typer.Argument(help="Dataset folder (LeRobot v3.0 written by mgdata).")]


def register(app: typer.Typer) -> None:
    """Add the dataset commands to the ``mgdata`` app."""

    @app.command("validate")
    def validate(
        dataset: Dataset,
        decode_all: Annotated[bool, typer.Option("--decode-all", help="Decode every video frame.")] = False,
        repair: Annotated[bool, typer.Option(
            "--repair", help="Copy the episodes whose files match their checksums into --out instead.")] \
        = False,
        out: Annotated[Path | None, typer.Option(help="New dataset folder of --repair.")] = None,
    ) -> None:
        """Check structure, counts, timestamps, stats, checksums and the safety record of a dataset.

        Prints one 'problem:' line per problem. Exit status: 0 valid; 1 the dataset is invalid (corrupt or
        inconsistent: any problem); 2 DATASET is not a folder. With --repair --out NEW: copy the intact
        episodes (every file they live in matches its checksum) into NEW, which generate can resume.
        Example: mgdata validate datasets/jar; mgdata validate --repair datasets/jar --out datasets/jar_ok
        """
        if not dataset.is_dir():
            raise DatasetError(f"{dataset}: no such dataset folder")
        if repair or out is not None:
            from mgdata.record.repair import repair_dataset

            if not repair or out is None:
                raise DatasetError("--repair and --out go together: mgdata validate --repair DATASET "
                                   "--out NEW")
            done = repair_dataset(dataset, out)
            dropped = ", ".join(map(str, done.dropped)) or "none"
            typer.echo(f"wrote {done.out}: {len(done.kept)} intact episodes copied; dropped {dropped} "
                       f"({len(done.damaged)} damaged files)")
            return
        report = validate_dataset(dataset, decode_all=decode_all)
        for note in report.notes:
            typer.echo(f"note: {note}")
        for problem in report.problems:
            typer.echo(f"problem: {problem}")
        if report.problems:
            typer.echo(f"{dataset}: {len(report.problems)} problem(s)", err=True)
            raise typer.Exit(1)
        typer.echo(f"{dataset}: ok ({report.episodes} episodes, {report.frames} frames)")

    @app.command("card")
    def card(dataset: Dataset) -> None:
        """Write a dataset's card, README.md (the page the Hugging Face Hub shows), from its metadata.

        Every command that writes a dataset writes its card; this rewrites it for a dataset written before
        cards or one whose card was edited (mgdata validate reports both).
        Example: mgdata card datasets/jar
        """
        from mgdata.record.card import write_card

        if not dataset.is_dir():
            raise DatasetError(f"{dataset}: no such dataset folder")
        typer.echo(f"wrote {write_card(dataset)}")

    @app.command("info")
    def info(
        dataset: Dataset,
        as_json: Annotated[bool, typer.Option("--json", help="Print the summary as JSON.")] = False,
    ) -> None:
        """Summarise a dataset: episodes, frames, families, conditions, kept vs negatives, yield, size.
        Every file is first checked against its recorded checksum: a damaged dataset is one error, exit 2.

        Example: mgdata info datasets/jar
        """
        from mgdata.record.integrity import check_intact

        if not dataset.is_dir():
            raise DatasetError(f"{dataset}: no such dataset folder")
        check_intact(dataset, "the summary would describe a damaged dataset")
        summary = summarize(dataset)
        if as_json:
            data = asdict(summary) | {"root": str(summary.root), "yield": summary.yield_}
            typer.echo(json.dumps(data, indent=2))
        else:
            for line in format_summary(summary):
                typer.echo(line)

    @app.command("export")
    def export(
        dataset: Dataset,
        out: Annotated[Path, typer.Argument(help="Output folder (must not exist).")],
        fmt: Annotated[str, typer.Option("--format", help=f"One of: {', '.join(FORMATS)}.")],
        overview: Annotated[str | None, typer.Option(help="Overview camera (pi0, smolvla).")] = None,
        wrist: Annotated[str | None, typer.Option(help="Wrist camera (pi0, smolvla; default wrist).")] = None,
        cameras: Annotated[str | None, typer.Option(help="Comma-separated cameras (v2.1, groot).")] = None,
        add: Annotated[list[str] | None, typer.Option(
            help="Derived feature to add: environment_state (v3.0 views; the state format has it).")] = None,
    ) -> None:
        """Write a loader view of a dataset (camera subset and keys per model convention), no re-encoding.
        --format state: no cameras, plus observation.environment_state (state-only training).

        Example: mgdata export datasets/jar datasets/jar-smolvla --format smolvla --overview front
        """
        from mgdata.errors import DatasetError

        unknown = [a for a in add or [] if a != "environment_state"]
        if unknown:
            raise DatasetError(f"--add {unknown[0]!r}: expected environment_state")
        cams = tuple(c.strip() for c in cameras.split(",") if c.strip()) if cameras else None
        from mgdata.record.export import export_dataset  # here: the v2.1 writer is slow to import

        path = export_dataset(dataset, out, fmt, overview=overview, wrist=wrist, cameras=cams,
                              add_environment_state=bool(add))
        typer.echo(f"wrote {path} ({fmt})")

    @app.command("render")
    def render(
        dataset: Dataset,
        out: Annotated[Path, typer.Option("--out", help="New dataset folder (must not exist).")],
        size: Annotated[int | None, typer.Option(help="Image side in pixels (default: the source's).")] \
        = None,
        cameras: Annotated[str | None, typer.Option(
            help="Comma-separated cameras, e.g. front,wrist (default: the source's).")] = None,
        codec: Annotated[str | None, typer.Option(help="h264 or av1 (default: the source's).")] = None,
        appearance: Annotated[int, typer.Option(
            help="Render every episode K times, each with its own appearance draw (table, floor and wall "
                 "materials, object tints, lights, camera jitter, visual-only distractors; the family "
                 "recipe's \\[appearance] settings, else their defaults): K x the episodes, physics the "
                 "source's bit for bit. 0: the scenes as stored.", metavar="K")] = 0,
        appearance_seed: Annotated[int, typer.Option(
            help="Mixed into every appearance draw's seed: another K draws of the same episodes.")] = 0,
    ) -> None:
        """Re-render a dataset from its stored physics states: other cameras, size or codec, or K
        appearance draws per episode (augmentation at render cost); labels, states, actions and metadata
        carried over. Re-run the same command to continue an interrupted one.

        Example: mgdata render datasets/jar --out datasets/jar_224 --size 224 --cameras front,wrist
        Example: mgdata render datasets/jar --out datasets/jar_x4 --appearance 4
        """
        from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn, TimeRemainingColumn

        from mgdata.console import plain_console
        from mgdata.record.rerender import RenderJob, rerender

        cams = tuple(c.strip() for c in cameras.split(",") if c.strip()) if cameras is not None else None
        job = RenderJob(dataset, out, size=size, cameras=cams, codec=codec, appearance=appearance,
                        appearance_seed=appearance_seed)
        console = plain_console()
        progress = Progress(TextColumn("render"), BarColumn(),
                            TextColumn("{task.completed}/{task.total} episodes"), TimeElapsedColumn(),
                            TextColumn("ETA"), TimeRemainingColumn(), console=console)
        bar = progress.add_task("render", total=None)

        def advance(done: int, total: int) -> None:
            if not progress.live.is_started:
                progress.start()
            progress.update(bar, completed=done, total=total)

        try:
            summary = rerender(job, on_episode=advance)
        finally:
            progress.stop()
        rate = summary.frames / summary.wall if summary.wall > 0 else 0.0
        console.print(f"wrote {summary.out}: {summary.total_episodes} episodes ({summary.episodes} rendered "
                      f"now, {summary.frames} frames, {rate:.1f} frames/s)")
