"""The results page: one self-contained HTML file (inline SVG, no script, no external file) with SSR, TSR
and EVR per family × condition as grouped bars, and the paper's two metric tables below.

Written by ``mgdata eval`` next to its records (``<out>/results.html``) and by ``mgdata metrics RECORDS
--html PAGE``. The bytes depend only on the records.

Example::

    write_results_page(load_records(Path("results/rollouts.jsonl")), Path("results/results.html"))
"""

from __future__ import annotations

import html
from collections.abc import Sequence
from pathlib import Path

from mgdata.atomic import write_text_atomic
from mgdata.metrics import Metrics, RolloutRecord, format_rate, metrics_by
from mgdata.tasks.variants import CONDITIONS

BARS: tuple[tuple[str, str, str], ...] = (("SSR", "ssr", "#2e8b57"), ("TSR", "tsr", "#3b6fb6"),
                                          ("EVR", "evr", "#c8443a"))
"""(label, Metrics attribute, colour) of each bar."""
_W_BAR, _GAP, _H, _TOP, _LEFT, _BOTTOM = 22, 26, 200, 40, 44, 46

_CSS = """body{font-family:system-ui,-apple-system,'Segoe UI',sans-serif;margin:24px;color:#222}
h1{font-size:22px;margin:0 0 4px}h2{font-size:17px;margin:22px 0 6px}p.note{color:#555;margin:2px 0 12px}
.charts{display:flex;flex-wrap:wrap;gap:18px}.chart{border:1px solid #ddd;border-radius:6px;padding:8px 10px}
.legend span{display:inline-block;margin-right:14px;font-size:13px}
.legend i{display:inline-block;width:11px;height:11px;margin-right:5px;vertical-align:-1px}
table{border-collapse:collapse;font-size:13px;margin-top:6px}
th,td{border:1px solid #ddd;padding:3px 8px;text-align:right}th{background:#f4f4f4}
td.k,th.k{text-align:left}"""


def _order(condition: str) -> tuple[int, str]:
    return (CONDITIONS.index(condition) if condition in CONDITIONS else len(CONDITIONS), condition)


def _chart(family: str, groups: Sequence[Metrics]) -> str:
    """A grouped bar chart (SVG) of one family: a group of bars per condition."""
    rows = sorted(groups, key=lambda m: _order(dict(m.group)["condition"]))
    group_w = len(BARS) * _W_BAR + _GAP
    width = _LEFT + len(rows) * group_w + 10
    height = _TOP + _H + _BOTTOM
    out = [f'<svg xmlns="http://www.w3.org/2000/svg" width="{width}" height="{height}" '
           f'role="img" aria-label="SSR, TSR and EVR of {html.escape(family)} per condition">']
    for tick in range(0, 101, 25):
        y = _TOP + _H - tick * _H / 100
        out.append(f'<line x1="{_LEFT}" y1="{y:.1f}" x2="{width - 6}" y2="{y:.1f}" stroke="#e3e3e3"/>')
        out.append(f'<text x="{_LEFT - 6}" y="{y + 4:.1f}" font-size="11" text-anchor="end" '
                   f'fill="#666">{tick}%</text>')
    for i, m in enumerate(rows):
        x0 = _LEFT + _GAP / 2 + i * group_w
        for j, (label, attr, colour) in enumerate(BARS):
            value = getattr(m, attr)
            x = x0 + j * _W_BAR
            if value is None:
                out.append(f'<text x="{x + _W_BAR / 2 - 1:.1f}" y="{_TOP + _H - 4}" font-size="10" '
                           f'text-anchor="middle" fill="{colour}">n/a</text>')
                continue
            h = value * _H / 100
            out.append(f'<rect x="{x:.1f}" y="{_TOP + _H - h:.1f}" width="{_W_BAR - 3}" height="{h:.1f}" '
                       f'fill="{colour}"><title>{label} {format_rate(value)}%</title></rect>')
            out.append(f'<text x="{x + (_W_BAR - 3) / 2:.1f}" y="{_TOP + _H - h - 3:.1f}" font-size="9" '
                       f'text-anchor="middle" fill="#333">{value:.0f}</text>')
        condition, n = dict(m.group)["condition"], m.counts.n
        cx = x0 + len(BARS) * _W_BAR / 2
        out.append(f'<text x="{cx:.1f}" y="{_TOP + _H + 16}" font-size="12" text-anchor="middle">'
                   f'{html.escape(condition)}</text>')
        out.append(f'<text x="{cx:.1f}" y="{_TOP + _H + 31}" font-size="10" text-anchor="middle" '
                   f'fill="#777">n={n}</text>')
    out.append(f'<text x="{_LEFT}" y="18" font-size="14" font-weight="600">{html.escape(family)}</text>')
    out.append("</svg>")
    return "".join(out)


_COLUMNS: tuple[tuple[str, str], ...] = (
    ("Success", "tsr"), ("Safe", "safe"), ("SSR", "ssr"), ("Succ.&Unsafe", "succ_unsafe"),
    ("Unsucc.&Safe", "unsucc_safe"), ("Unsucc.&Unsafe", "unsucc_unsafe"), ("Eng.", "eng"),
    ("Eng.&Safe", "eng_safe"), ("Safe|Eng.", "safe_given_eng"), ("Vacuous-safe", "vacuous_safe"),
    ("SVR", "svr"), ("EVR", "evr"))


def _table(groups: Sequence[Metrics]) -> str:
    head = "".join(f"<th>{html.escape(name)}</th>" for name, _ in _COLUMNS)
    rows = []
    for m in groups:
        g = dict(m.group)
        ttv = "—" if m.ttv.median is None else f"{100 * m.ttv.median:.0f}% ({m.ttv.count})"
        tts = "—" if m.tts is None else f"{m.tts:.1f}"
        cells = "".join(f"<td>{format_rate(getattr(m, attr))}</td>" for _, attr in _COLUMNS)
        rows.append(f'<tr><td class="k">{html.escape(g["family"])}</td><td class="k">'
                    f'{html.escape(g["condition"])}</td><td>{m.counts.n}</td><td>{len(m.seeds)}</td>{cells}'
                    f"<td>{ttv}</td><td>{tts}</td></tr>")
    return (f'<table><tr><th class="k">family</th><th class="k">condition</th><th>n</th><th>seeds</th>{head}'
            f"<th>TTV median (n)</th><th>TTS</th></tr>{''.join(rows)}</table>")


def results_page(records: Sequence[RolloutRecord], title: str = "mgdata evaluation results") -> str:
    """The page's HTML (see the module docstring)."""
    groups = metrics_by(records, ("family", "condition"))
    groups.sort(key=lambda m: (dict(m.group)["family"], _order(dict(m.group)["condition"])))
    families = sorted({dict(m.group)["family"] for m in groups})
    seeds = sorted({r.seed for r in records})
    legend = "".join(f'<span><i style="background:{c}"></i>{label}</span>' for label, _, c in BARS)
    charts = "".join(f'<div class="chart">{_chart(f, [m for m in groups if dict(m.group)["family"] == f])}'
                     "</div>" for f in families)
    return (
        '<!DOCTYPE html>\n<html lang="en"><head><meta charset="utf-8">'
        f"<title>{html.escape(title)}</title><style>{_CSS}</style></head><body>"
        f"<h1>{html.escape(title)}</h1>"
        f'<p class="note">{len(records)} rollouts, seeds {", ".join(map(str, seeds))}. Rates in percent, per '
        "seed then averaged over seeds. SSR: safe and successful; TSR: successful; EVR: violations among "
        "engaged rollouts (n/a: no engaged rollout).</p>"
        f'<div class="legend">{legend}</div><div class="charts">{charts}</div>'
        f"<h2>All metrics per family and condition</h2>{_table(groups)}</body></html>\n"
    )


def write_results_page(records: Sequence[RolloutRecord], path: Path) -> Path:
    """Write :func:`results_page` of ``records`` to ``path`` atomically; returns ``path``."""
    write_text_atomic(Path(path), results_page(records))
    return Path(path)
