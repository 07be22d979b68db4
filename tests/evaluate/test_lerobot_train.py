"""Opt-in (`-m lerobot`): the whole loop of docs/train.md on a 2-demo jar dataset: `mgdata export --format
state`, LeRobot's own `lerobot-train` (a tiny state-only ACT, a few steps), the checkpoint served from the
LeRobot environment (`mgdata.evaluate.lerobot_policy`, what `mgdata serve lerobot` runs) and scored by the
`mgdata eval` command with `--convention state`. Needs the venv of ``scripts/check_lerobot_compat.sh``
(``LEROBOT_VENV``)."""

from __future__ import annotations

import dataclasses
import json
import os
import subprocess
import sys
from pathlib import Path

import pyarrow.parquet as pq
import pytest

from mgdata.engine.executor import Executor
from mgdata.engine.init_gate import base_task, cached_grasp_db
from mgdata.paths import grasps_dir, project_root
from mgdata.record.recorder import schema_for
from mgdata.record.writer import DatasetWriter
from mgdata.skeleton.skeleton import load_family_recipe

pytestmark = pytest.mark.lerobot

MGDATA = [sys.executable, "-c", "import sys; from mgdata.cli import main; sys.argv[0] = 'mgdata'; main()"]


def _venv_python() -> str:
    venv = Path(os.environ.get("LEROBOT_VENV", project_root() / ".cache" / "lerobot-venv"))
    python = venv / "bin" / "python"
    if not python.exists() or subprocess.run([str(python), "-c", "import lerobot"]).returncode != 0:
        pytest.fail(f"no LeRobot environment at {venv}: run scripts/check_lerobot_compat.sh first")
    return str(python)


def _two_demos(out: Path) -> Path:
    """Two kept camera-free demonstrations of jar task 0 (the first two draws that pass the gate)."""
    recipe = load_family_recipe("jar")
    ex = Executor(base_task(recipe, 0), recipe, grasps=cached_grasp_db(grasps_dir()), render=False)
    schema = dataclasses.replace(schema_for(ex.scene, recipe.spec, None), image_height=0, image_width=0)
    with DatasetWriter.create(out, schema, spec=recipe.spec, hold_steps=recipe.tasks.hold_steps) as writer:
        kept = sum(ex.run(draw, writer).kept for draw in range(2))
        for draw in range(2, 8):
            if kept == 2:
                break
            kept += ex.run(draw, writer).kept
    assert kept == 2
    ex.close()
    return out


def test_lerobot_train_serve_eval_state_only(scenario_set: Path, tmp_path: Path) -> None:
    python, root = _venv_python(), project_root()
    data = _two_demos(tmp_path / "jar")
    state = tmp_path / "jar_state"
    subprocess.run([*MGDATA, "export", str(data), str(state), "--format", "state"], check=True)
    assert pq.read_table(next(state.glob("data/*/*.parquet"))).num_rows > 300
    env = {**os.environ, "PYTHONPATH": str(root), "HF_HUB_OFFLINE": "1", "HF_DATASETS_OFFLINE": "1",
           "WANDB_MODE": "disabled", "OMP_NUM_THREADS": "1"}
    out = tmp_path / "train"
    trained = subprocess.run(
        [python, "-m", "lerobot.scripts.lerobot_train", "--dataset.repo_id=mgdata/jar_state",
         f"--dataset.root={state}", "--policy.type=act", "--policy.device=cpu", "--policy.push_to_hub=false",
         "--wandb.enable=false", "--policy.pretrained_backbone_weights=null", "--policy.dim_model=32",
         "--policy.dim_feedforward=64", "--policy.n_encoder_layers=1", "--policy.n_decoder_layers=1",
         "--policy.use_vae=false", "--policy.chunk_size=10", "--policy.n_action_steps=10", "--batch_size=8",
         "--steps=6", "--save_freq=6", "--log_freq=2", "--num_workers=0", f"--output_dir={out}"],
        capture_output=True, text=True, env=env, timeout=900)
    assert trained.returncode == 0, trained.stderr[-3000:]
    ckpt = out / "checkpoints" / "last" / "pretrained_model"
    features = json.loads((ckpt / "config.json").read_text())["input_features"]
    assert set(features) == {"observation.state", "observation.environment_state"}
    serve = [python, "-m", "mgdata.evaluate.lerobot_policy", "--checkpoint", str(ckpt), "--port", "0"]
    proc = subprocess.Popen(serve, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env)
    try:
        assert proc.stdout is not None
        url = next(line.split(" on ")[1].split()[0] for line in proc.stdout if line.startswith("serving "))
        results = tmp_path / "results"
        subprocess.run([*MGDATA, "eval", "--policy", url, "--scenarios", str(scenario_set), "--convention",
                        "state", "--seeds", "0", "--horizon", "30", "--out", str(results)],
                       check=True, timeout=600)
    finally:
        proc.terminate()
        proc.wait(timeout=60)
    records = [json.loads(line) for line in (results / "rollouts.jsonl").read_text().splitlines()]
    assert [r["condition"] for r in records] == ["base", "target"]
    assert all(r["end"] == "timeout" and r["steps"] == 30 for r in records)
    assert json.loads((results / "eval.json").read_text())["policy_metadata"]["inputs"] == [
        "observation.state", "observation.environment_state"]
