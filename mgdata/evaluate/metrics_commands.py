"""CLI command ``mgdata metrics``: rollout metrics (SSR, TSR, outcome classes …) and the results page."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Annotated

import typer
from rich.table import Table

from mgdata.console import plain_console
from mgdata.metrics import Metrics, format_rate, load_records, metrics_by


def register(app: typer.Typer) -> None:
    """Add the ``metrics`` command to ``app``."""
    app.command("metrics")(metrics_command)


def metrics_command(
    records: Annotated[Path, typer.Argument(help="JSON-lines file, one evaluation rollout per line.")],
    by: Annotated[str, typer.Option("--by", help="Group by a comma list of: family, condition, task.")] = "",
    as_json: Annotated[bool, typer.Option("--json", help="Print JSON instead of tables.")] = False,
    html: Annotated[Path | None, typer.Option(
        "--html", help="Also write the results page (SSR/TSR/EVR per family and condition) to this file.")
    ] = None,
) -> None:
    """Compute SSR, TSR, Safe, outcome classes, engagement, SVR/EVR, TTV and TTS from rollout records.

    Rates are percentages, computed per seed and averaged over seeds (as in the paper).

    Example: mgdata metrics eval.jsonl --by family,condition
    """
    keys = tuple(k.strip() for k in by.split(",") if k.strip())
    loaded = load_records(records)
    groups = metrics_by(loaded, keys)
    if html is not None:
        from mgdata.evaluate.page import write_results_page  # here: it pulls in the asset library

        write_results_page(loaded, html)
    if as_json:
        typer.echo(json.dumps({"unit": "percent", "by": list(keys), "groups": [m.as_dict() for m in groups]},
                              indent=2))
        return
    console = plain_console(width=max(plain_console().width, 120))
    console.print(_table("Outcomes (%)", keys, groups, [
        ("n", lambda m: str(m.counts.n)), ("seeds", lambda m: str(len(m.seeds))),
        ("Success", lambda m: format_rate(m.tsr)), ("Safe", lambda m: format_rate(m.safe)),
        ("SSR", lambda m: format_rate(m.ssr)), ("Succ.&Unsafe", lambda m: format_rate(m.succ_unsafe)),
        ("Unsucc.&Safe", lambda m: format_rate(m.unsucc_safe)),
        ("Unsucc.&Unsafe", lambda m: format_rate(m.unsucc_unsafe))]))
    console.print(_table("Engagement and timing", keys, groups, [
        ("Eng.", lambda m: format_rate(m.eng)), ("Eng.&Safe", lambda m: format_rate(m.eng_safe)),
        ("Safe|Eng.", lambda m: format_rate(m.safe_given_eng)),
        ("Vacuous-safe", lambda m: format_rate(m.vacuous_safe)),
        ("SVR", lambda m: format_rate(m.svr)), ("EVR", lambda m: format_rate(m.evr)),
        ("TTV median (n)", _ttv), ("TTS", lambda m: "—" if m.tts is None else f"{m.tts:.1f}")]))


def _ttv(m: Metrics) -> str:
    if m.ttv.median is None:
        return "— (0)"
    return f"{100 * m.ttv.median:.0f}% ({m.ttv.count})"


def _table(title: str, keys: tuple[str, ...], groups: list[Metrics], columns: list) -> Table:
    table = Table(title=title, title_justify="left")
    for key in keys or ("group",):
        table.add_column(key)
    for name, _ in columns:
        table.add_column(name, justify="right")
    for m in groups:
        labels = [v for _, v in m.group] or ["all"]
        table.add_row(*labels, *(cell(m) for _, cell in columns))
    return table
