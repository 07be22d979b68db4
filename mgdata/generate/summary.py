"""What a generation run did: counts per outcome, time per phase, and how it is shown (progress, table).

Example::

    summary = RunSummary(out=Path("datasets/jar"), target=40)
    summary.add(result, write_seconds=0.2)
    print_summary(summary, plain_console())
"""

from __future__ import annotations

import collections
from dataclasses import dataclass, field
from pathlib import Path

from rich.console import Console
from rich.progress import BarColumn, Progress, TaskID, TextColumn, TimeElapsedColumn
from rich.table import Table

from mgdata.engine.executor import AttemptResult
from mgdata.episode.gate import STAGES
from mgdata.episode.timing import PHASES, Timings
from mgdata.errors import MgdataError


@dataclass
class RunSummary:
    """Counters of one ``mgdata generate`` run.

    Attributes:
        out: the dataset; ``failed_out``: the labelled-negatives dataset (``--keep-failed``) or ``None``.
        target: kept episodes wanted in the dataset; ``kept_before``: how many it had when the run began.
        kept, attempts: this run's kept episodes and attempts (kept or not).
        stages: failure stage -> count (this run).
        timings: CPU seconds per phase, summed over attempts (the workers' and the committing process's CPU
            time, not wall time).
        wall: wall-clock seconds of the run.
        stopped: why the run ended (``target reached``, ``max attempts``, ``interrupted``).
    """

    out: Path
    target: int
    failed_out: Path | None = None
    kept_before: int = 0
    kept: int = 0
    attempts: int = 0
    stages: collections.Counter[str] = field(default_factory=collections.Counter)
    timings: Timings = field(default_factory=Timings)
    wall: float = 0.0
    stopped: str = ""

    def add(self, result: AttemptResult, write_seconds: float = 0.0) -> None:
        self.attempts += 1
        if result.kept:
            self.kept += 1
        else:
            self.stages[result.stage or "goal_not_reached"] += 1
        self.timings.add(result.timings)
        self.timings.writing += write_seconds

    @property
    def total_kept(self) -> int:
        return self.kept_before + self.kept

    @property
    def yield_(self) -> float:
        return self.kept / self.attempts if self.attempts else 0.0

    def eta(self) -> float | None:
        """Seconds to the target at this run's rate of kept episodes (``None`` before the first)."""
        if not self.kept or self.wall <= 0:
            return None
        return max(0, self.target - self.total_kept) * self.wall / self.kept


def _fmt_time(seconds: float | None) -> str:
    if seconds is None:
        return "–"
    seconds = round(seconds)
    return f"{seconds // 3600}:{seconds % 3600 // 60:02d}:{seconds % 60:02d}"


class ProgressView:
    """A rich progress bar: kept / target, attempts, yield, ETA. It appears on the first :meth:`update`
    (when the run has started), so a run refused for bad input prints only its error line."""

    def __init__(self, summary: RunSummary, console: Console, label: str = "generate") -> None:
        self._started = False
        self._progress = Progress(
            TextColumn("[bold]{task.description}"), BarColumn(),
            TextColumn("{task.completed}/{task.total} kept · {task.fields[attempts]} attempted"),
            TextColumn("· yield {task.fields[yield_]} · ETA {task.fields[eta]}"),
            TimeElapsedColumn(), console=console, transient=False)
        self._task: TaskID = self._progress.add_task(
            label, total=summary.target, completed=summary.total_kept, attempts=0, yield_="–", eta="–")

    def __enter__(self) -> ProgressView:
        return self

    def __exit__(self, exc_type: type[BaseException] | None, *exc: object) -> None:
        if not self._started:
            return
        if exc_type is not None and issubclass(exc_type, MgdataError):
            self._progress.live.transient = True  # bad input: leave only the error line on screen
        self._progress.stop()

    def update(self, summary: RunSummary) -> None:
        if not self._started:
            self._started = True
            self._progress.start()
        self._progress.update(self._task, total=summary.target, completed=summary.total_kept,
                              attempts=summary.attempts,
                              yield_=f"{summary.yield_:.0%}" if summary.attempts else "–",
                              eta=_fmt_time(summary.eta()))


def summary_table(summary: RunSummary, command: str = "generate") -> Table:
    """Outcomes (kept and each failure stage) and the time split of the run."""
    table = Table(title=f"mgdata {command}: {summary.stopped or 'done'}", show_header=True)
    table.add_column("outcome")
    table.add_column("attempts", justify="right")
    table.add_column("share", justify="right")
    n = max(summary.attempts, 1)
    table.add_row("kept", str(summary.kept), f"{summary.kept / n:.0%}")
    for stage in [*STAGES, *sorted(set(summary.stages) - set(STAGES))]:
        if summary.stages.get(stage):
            table.add_row(stage, str(summary.stages[stage]), f"{summary.stages[stage] / n:.0%}")
    total = summary.timings.total or 1.0
    table.add_section()
    for phase in PHASES:
        sec = getattr(summary.timings, phase)
        table.add_row(f"CPU: {phase}", f"{sec:.1f} s", f"{sec / total:.0%}")
    table.add_row("wall time", _fmt_time(summary.wall), "")
    return table


def print_summary(summary: RunSummary, console: Console, command: str = "generate") -> None:
    console.print(summary_table(summary, command))
    console.print(f"dataset: {summary.out} ({summary.total_kept} of {summary.target} kept episodes; "
                  f"{summary.kept} new from {summary.attempts} attempts)")
    if summary.failed_out is not None:
        console.print(f"labelled negatives: {summary.failed_out}")
