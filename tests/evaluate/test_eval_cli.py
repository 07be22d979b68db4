"""`mgdata eval` end to end against `mgdata serve` processes: records `mgdata metrics` reads, resume after a
kill, and bad input as one error line with exit status 2."""

from __future__ import annotations

import json
import os
import signal
import socket
import subprocess
import time
from pathlib import Path

from tests.helpers.evaluate import ENV, MGDATA, serve_process


def _eval(url: str, scenarios: Path, out: Path, *extra: str) -> list[str]:
    return [*MGDATA, "eval", "--policy", url, "--scenarios", str(scenarios), "--out", str(out), *extra]


def test_eval_resumes_after_a_kill_and_feeds_metrics(scenario_set: Path, tmp_path: Path) -> None:
    proc, url = serve_process("hold")
    out = tmp_path / "results"
    try:
        cmd = _eval(url, scenario_set, out, "--seeds", "0,1", "--horizon", "40", "--chunk-steps", "4")
        run = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=ENV)
        results = out / "rollouts.jsonl"
        deadline = time.monotonic() + 240
        while time.monotonic() < deadline and not (results.exists() and results.read_text().count("\n") >= 1):
            time.sleep(0.05)
        run.send_signal(signal.SIGKILL)
        run.wait(timeout=60)
        first = results.read_text().splitlines()
        assert 1 <= len([ln for ln in first if ln.endswith("}")]) < 4
        done = subprocess.run(cmd, capture_output=True, text=True, timeout=300, env=ENV)
        assert done.returncode == 0, done.stderr
        kept = len([ln for ln in first if ln.endswith("}")])
        assert f"{4 - kept} rollouts run, {kept} already done, 4 in" in done.stdout
        records = [json.loads(line) for line in results.read_text().splitlines()]
        assert [(r["scenario"], r["seed"]) for r in records] == [
            ("jar/task_0000/base", 0), ("jar/task_0000/base", 1), ("jar/task_0000/target", 0),
            ("jar/task_0000/target", 1)]
        assert records[0] == json.loads(first[0]) or json.loads(first[0]) in records  # not re-run, kept
        again = subprocess.run(cmd, capture_output=True, text=True, timeout=300, env=ENV)
        assert "0 rollouts run, 4 already done" in again.stdout
        table = subprocess.run([*MGDATA, "metrics", str(results), "--by", "family,condition"],
                               capture_output=True, text=True, timeout=120, env=ENV)
        assert table.returncode == 0, table.stderr
        rows = [ln for ln in table.stdout.splitlines() if ln.startswith("│ jar")]
        assert len(rows) == 4 and all("target" in r or "base" in r for r in rows)
    finally:
        proc.terminate()
        proc.wait(timeout=30)


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def test_bad_input_is_one_error_line(scenario_set: Path, tmp_path: Path) -> None:
    cases = [
        (_eval(f"ws://127.0.0.1:{_free_port()}", scenario_set, tmp_path / "a"),
         "cannot reach the policy server"),
        (_eval("http://localhost", scenario_set, tmp_path / "b"), "expected ws://HOST:PORT"),
        (_eval("ws://127.0.0.1:9", tmp_path / "nothing", tmp_path / "c"), "no scenario manifest"),
    ]
    for cmd, message in cases:
        proc = subprocess.run(cmd, capture_output=True, text=True, timeout=120, env=ENV)
        lines = proc.stderr.strip().splitlines()
        assert proc.returncode == 2 and len(lines) == 1, (cmd, proc.stderr)
        assert lines[0].startswith("error: ") and message in lines[0], lines
        assert "Traceback" not in proc.stderr
    assert not (tmp_path / "a" / "rollouts.jsonl").exists()
    assert os.listdir(tmp_path) == [] or all(not (tmp_path / d / "rollouts.jsonl").exists()
                                              for d in os.listdir(tmp_path))
