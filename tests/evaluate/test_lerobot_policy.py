"""Opt-in (`-m lerobot`): a real LeRobot checkpoint (a tiny ACT policy built by LeRobot itself) served from a
LeRobot environment and evaluated by `mgdata eval`'s loop. Needs the venv of
``scripts/check_lerobot_compat.sh`` (``LEROBOT_VENV``, default ``.cache/lerobot-venv``)."""

from __future__ import annotations

import os
import subprocess
from pathlib import Path

import numpy as np
import pytest

from mgdata.evaluate.rollout import LoopSettings, RolloutJob, rollout
from tests.helpers.repo import REPO

pytestmark = pytest.mark.lerobot


def _venv_python() -> str:
    root = REPO
    venv = Path(os.environ.get("LEROBOT_VENV", root / ".cache" / "lerobot-venv"))
    python = venv / "bin" / "python"
    if not python.exists() or subprocess.run([str(python), "-c", "import lerobot"]).returncode != 0:
        pytest.fail(f"no LeRobot environment at {venv}: run scripts/check_lerobot_compat.sh first")
    return str(python)


def test_a_lerobot_checkpoint_is_evaluated(scenario_set: Path, tmp_path: Path) -> None:
    python, root = _venv_python(), REPO
    env = {**os.environ, "PYTHONPATH": str(root), "HF_HUB_OFFLINE": "1"}
    ckpt = tmp_path / "act"
    built = subprocess.run([python, str(root / "scripts" / "lerobot_tiny_policy.py"), str(ckpt), "256"],
                           capture_output=True, text=True, env=env, timeout=600)
    assert built.returncode == 0, built.stderr
    serve = [python, "-m", "mgdata.evaluate.lerobot_policy", "--checkpoint", str(ckpt), "--port", "0"]
    proc = subprocess.Popen(serve, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env)
    try:
        assert proc.stdout is not None
        url = next(line.split(" on ")[1].split()[0] for line in proc.stdout if line.startswith("serving "))
        settings = LoopSettings(url, convention="smolvla", chunk_steps=8, horizon=24, timeout_s=120)
        runs = [rollout(RolloutJob(scenario_set, "jar/task_0000/base", 0), settings) for _ in range(2)]
    finally:
        proc.terminate()
        proc.wait(timeout=60)
    rec = runs[0].record
    assert rec["end"] == "timeout" and rec["steps"] == 24 and rec["horizon"] == 24
    actions = np.stack([f.action for f in runs[0].frames])
    assert actions.shape == (24, 8) and np.isfinite(actions).all()
    assert np.abs(actions[0, :7] - runs[0].frames[0].state[:7]).max() > 1e-3  # the untrained net does move
    # the same requests give the same chunks: the rollouts are identical
    assert runs[1].record == rec and all(np.array_equal(a.action, b.action)
                                         for a, b in zip(runs[0].frames, runs[1].frames, strict=True))
