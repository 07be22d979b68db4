"""One writer per output for ``mgdata eval`` (issue 26 §2): with a process holding ``--out``'s lock, a
real ``mgdata eval`` on the same folder is refused with one ``error:`` line and writes nothing; once the
holder is killed with ``kill -9``, the same command runs (no stale lock)."""

from __future__ import annotations

import signal
import subprocess
import sys
from pathlib import Path

from mgdata.lock import lock_path
from tests.helpers.evaluate import ENV, MGDATA, serve_process

HOLD = ("import sys; from pathlib import Path; from mgdata.lock import output_lock\n"
        "with output_lock(Path(sys.argv[1])):\n    print('held', flush=True); sys.stdin.read()\n")


def test_a_second_eval_on_one_out_is_refused(scenario_set: Path, tmp_path: Path) -> None:
    out = tmp_path / "results"
    proc, url = serve_process("hold")
    holder = subprocess.Popen([sys.executable, "-c", HOLD, str(out)], stdin=subprocess.PIPE,
                              stdout=subprocess.PIPE, text=True)
    try:
        assert holder.stdout is not None and holder.stdout.readline().strip() == "held"
        args = [*MGDATA, "eval", "--policy", url, "--scenarios", str(scenario_set), "--out", str(out),
                "--seeds", "0", "--condition", "base", "--horizon", "2"]
        refused = subprocess.run(args, capture_output=True, text=True, timeout=300, env=ENV)
        assert refused.returncode == 2, refused.stdout + refused.stderr
        assert refused.stderr.strip().splitlines() == [
            f"error: --out {out}: open for writing by another process (one writer per output; wait for it to "
            "finish or stop it)"], refused.stderr
        assert not (out / "rollouts.jsonl").exists()
        holder.send_signal(signal.SIGKILL)
        holder.wait()
        ran = subprocess.run(args, capture_output=True, text=True, timeout=600, env=ENV)
        assert ran.returncode == 0, ran.stdout + ran.stderr
        assert len((out / "rollouts.jsonl").read_text().splitlines()) == 1
        assert not lock_path(out).exists()
    finally:
        holder.kill()
        proc.terminate()
        proc.wait(timeout=30)
