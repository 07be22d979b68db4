"""The results page renders in a real headless Chromium: one chart per family, a bar per defined rate with
the rate `mgdata metrics` computes, n/a where EVR is undefined, and the metric table."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import pytest

from mgdata.evaluate.page import write_results_page
from mgdata.metrics import metrics_by, parse_record
from tests.helpers.cli import mgdata_here


def _record(family: str, condition: str, seed: int, success: bool, t_engage: int | None,
            t_violation: int | None) -> dict:
    return {"family": family, "task": "task_0000", "condition": condition, "seed": seed, "success": success,
            "engaged": t_engage is not None, "t_engage": t_engage, "t_violation": t_violation, "horizon": 100}


def test_the_page_shows_the_metrics_in_chromium(tmp_path: Path) -> None:
    raw = [_record("jar", "base", s, s == 0, 10, None if s == 0 else 20) for s in (0, 1)]
    raw += [_record("jar", "location", s, False, None, None) for s in (0, 1)]
    raw += [_record("clutter_dry", "base", s, True, 5, None) for s in (0, 1)]
    records = [parse_record(r, "test") for r in raw]
    page = write_results_page(records, tmp_path / "results.html")
    chromium = shutil.which("chromium") or shutil.which("chromium-browser")
    if chromium is None:
        pytest.fail("Debian's chromium is not installed: run scripts/setup.sh --dev")
    from playwright.sync_api import sync_playwright

    expected = {(dict(m.group)["family"], dict(m.group)["condition"]): m
                for m in metrics_by(records, ("family", "condition"))}
    with sync_playwright() as pw:
        browser = pw.chromium.launch(executable_path=chromium, headless=True,
                                     args=["--no-sandbox", "--disable-gpu", "--no-first-run"])
        tab = browser.new_page(viewport={"width": 1400, "height": 800})
        errors: list[str] = []
        tab.on("console", lambda msg: errors.append(msg.text) if msg.type == "error" else None)
        requests: list[str] = []
        tab.on("request", lambda req: requests.append(req.url))
        tab.goto(page.as_uri())
        charts = tab.locator("svg")
        assert charts.count() == 2  # clutter_dry, jar
        assert [charts.nth(i).get_attribute("aria-label") for i in range(2)] == [
            "SSR, TSR and EVR of clutter_dry per condition", "SSR, TSR and EVR of jar per condition"]
        titles = sorted(charts.nth(1).locator("rect title").all_text_contents())
        jar_base, jar_loc = expected[("jar", "base")], expected[("jar", "location")]
        assert jar_base.ssr == 50.0 and jar_base.evr == 50.0 and jar_loc.evr is None
        assert titles == sorted(["SSR 50.00%", "TSR 50.00%", "EVR 50.00%", "SSR 0.00%", "TSR 0.00%"])
        assert "n/a" in charts.nth(1).text_content()
        bars = charts.nth(1).locator("rect")
        heights = sorted(float(bars.nth(i).get_attribute("height") or 0) for i in range(bars.count()))
        assert heights == [0.0, 0.0, 100.0, 100.0, 100.0]  # 50 % of the 200-px axis
        rows = tab.locator("table tr")
        assert rows.count() == 4 and "clutter_dry" in rows.nth(1).inner_text()
        box = charts.nth(0).bounding_box()
        assert box is not None and box["width"] > 100 and box["height"] > 200
        browser.close()
    assert errors == [] and requests == [page.as_uri()]  # self-contained: nothing else is fetched


def test_metrics_html_writes_the_page(tmp_path: Path) -> None:
    records = tmp_path / "rollouts.jsonl"
    rows = [_record("jar", "base", s, s == 0, 10, None) for s in (0, 1)]
    records.write_text("".join(json.dumps(r) + "\n" for r in rows))
    proc = mgdata_here("metrics", records, "--html", tmp_path / "results.html")
    assert proc.returncode == 0, proc.stderr
    assert "jar" in (tmp_path / "results.html").read_text()
