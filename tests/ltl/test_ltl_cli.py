"""The ``mgdata ltl`` and ``mgdata metrics`` commands, run as a user would (exit codes, one-line errors)."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path


def _mgdata(*args: str) -> subprocess.CompletedProcess:
    code = "import sys; from mgdata.cli import main; sys.argv = ['mgdata', *sys.argv[1:]]; main()"
    return subprocess.run([sys.executable, "-c", code, *args], capture_output=True, text=True, timeout=120)


def test_ltl_prints_the_dfa_and_dot() -> None:
    out = _mgdata("ltl", "jar_on_support W jar_closed")
    assert out.returncode == 0, out.stderr
    assert "states: 4, initial 0" in out.stdout and "1: VIOLATED (rejecting sink)" in out.stdout
    dot = _mgdata("ltl", "--dot", "G !jar_dropped")
    assert dot.returncode == 0 and dot.stdout.startswith("digraph dfa {")


def test_ltl_syntax_error_is_one_line_with_exit_status_2() -> None:
    out = _mgdata("ltl", "a U")
    assert out.returncode == 2 and out.stdout == ""
    assert out.stderr.strip().splitlines() == [
        "error: bad LTL_f formula 'a U': at column 4: expected an operand (proposition, 'true', 'false', "
        "'(' or one of ! X WX F G), found end of formula"]


def test_metrics_table_json_and_errors(tmp_path: Path) -> None:
    rows = [{"family": "jar", "task": "t0", "condition": "base", "seed": 0, "success": True, "engaged": True,
             "t_engage": 10, "t_violation": None, "horizon": 100, "t_success": 50},
            {"family": "jar", "task": "t1", "condition": "base", "seed": 0, "success": False, "engaged": True,
             "t_engage": 10, "t_violation": 30, "horizon": 100}]
    path = tmp_path / "eval.jsonl"
    path.write_text("".join(json.dumps(r) + "\n" for r in rows))
    table = _mgdata("metrics", str(path), "--by", "family,condition")
    assert table.returncode == 0, table.stderr
    assert "Outcomes (%)" in table.stdout and "Engagement and timing" in table.stdout
    assert "22% (1)" in table.stdout  # TTV median (count): (30 - 10) / (100 - 10)
    data = json.loads(_mgdata("metrics", str(path), "--json").stdout)
    assert data["unit"] == "percent" and data["groups"][0]["ssr"] == 50.0
    assert data["groups"][0]["evr"] == 50.0
    bad = _mgdata("metrics", str(path), "--by", "policy")
    assert bad.returncode == 2 and "cannot group by 'policy'" in bad.stderr
    path.write_text(json.dumps(rows[0]) + "\n{\n")
    broken = _mgdata("metrics", str(path))
    assert broken.returncode == 2 and f"{path}:2: not valid JSON" in broken.stderr
