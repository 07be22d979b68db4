"""``mgdata generate --family all``: the whole suite, one dataset per family under one folder.

Each family found by :func:`mgdata.tasks.recipe.family_recipes` is generated into ``<out>/<family>`` with
the same options (``--n`` or ``--per-task``, ``--tasks``, workers, seed, ...), one after the other, through
the ordinary :func:`~mgdata.generate.run.generate`; so the suite resumes as a whole (re-running the
command resumes every dataset, and a finished one has nothing to do) and every dataset is byte-identical to
generating that family alone. The final table has one row per family: kept, attempts, yield, failure
stages and time.

Example::

    rows = generate_suite(GenerateJob(family="all", n=0, out=Path("datasets/suite"), per_task=40))
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from pathlib import Path

from rich.table import Table

from mgdata.errors import RecipeError
from mgdata.generate.run import GenerateJob, generate
from mgdata.generate.summary import RunSummary, _fmt_time
from mgdata.tasks.recipe import family_recipes

ALL = "all"


def suite_jobs(job: GenerateJob) -> list[GenerateJob]:
    """One job per family: ``job`` with the family and ``out/<family>``."""
    if job.recipe is not None:
        raise RecipeError("--family all takes each family's own recipe; --recipe names one family's")
    families = family_recipes()
    if not families:
        raise RecipeError("no family recipes found in recipes/")
    return [dataclasses.replace(job, family=f, out=Path(job.out) / f) for f in families]


def generate_suite(job: GenerateJob, on_start: Callable[[GenerateJob], Callable[[RunSummary], None] | None]
                   | None = None) -> list[tuple[str, RunSummary]]:
    """Generate every family (module docstring); ``on_start(family_job)`` returns the progress callback of
    that family's run. Returns (family, summary) in family order."""
    out: list[tuple[str, RunSummary]] = []
    for fam_job in suite_jobs(job):
        callback = on_start(fam_job) if on_start is not None else None
        out.append((fam_job.family, generate(fam_job, on_attempt=callback)))
    return out


def suite_table(rows: list[tuple[str, RunSummary]]) -> Table:
    """Per family: kept in the dataset / target, this run's attempts and yield, failure stages, time."""
    table = Table(title="mgdata generate --family all", show_header=True)
    for name, justify in (("family", "left"), ("kept", "right"), ("attempts", "right"), ("yield", "right"),
                          ("failure stages", "left"), ("time", "right"), ("stopped", "left")):
        table.add_column(name, justify=justify)  # type: ignore[arg-type]
    for family, s in rows:
        stages = ", ".join(f"{k} {v}" for k, v in sorted(s.stages.items())) or "–"
        table.add_row(family, f"{s.total_kept}/{s.target}", str(s.attempts),
                      f"{s.yield_:.0%}" if s.attempts else "–", stages, _fmt_time(s.wall), s.stopped)
    return table
