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


@pytest.fixture(scope="module")
def state_view(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The state view (``mgdata export --format state``) of two kept jar demos."""
    tmp = tmp_path_factory.mktemp("lerobot")
    data = _two_demos(tmp / "jar")
    state = tmp / "jar_state"
    subprocess.run([*MGDATA, "export", str(data), str(state), "--format", "state"], check=True)
    assert pq.read_table(next(state.glob("data/*/*.parquet"))).num_rows > 300
    return state


def _env() -> dict[str, str]:
    return {**os.environ, "PYTHONPATH": str(project_root()), "HF_HUB_OFFLINE": "1",
            "HF_DATASETS_OFFLINE": "1", "WANDB_MODE": "disabled", "OMP_NUM_THREADS": "1"}


def _train(state: Path, out: Path, policy: list[str]) -> Path:
    """``lerobot-train`` a few steps on ``state``; the checkpoint folder."""
    trained = subprocess.run(
        [_venv_python(), "-m", "lerobot.scripts.lerobot_train", "--dataset.repo_id=mgdata/jar_state",
         f"--dataset.root={state}", "--policy.device=cpu", "--policy.push_to_hub=false",
         "--wandb.enable=false", "--policy.pretrained_backbone_weights=null", *policy, "--batch_size=8",
         "--steps=6", "--save_freq=6", "--log_freq=2", "--num_workers=0", f"--output_dir={out}"],
        capture_output=True, text=True, env=_env(), timeout=900)
    assert trained.returncode == 0, trained.stderr[-3000:]
    return out / "checkpoints" / "last" / "pretrained_model"


def _serve_and_eval(ckpt: Path, scenarios: Path, results: Path, *extra: str) -> list[dict]:
    """Serve ``ckpt`` from the LeRobot environment, run ``mgdata eval`` on it; the rollout records."""
    serve = [_venv_python(), "-m", "mgdata.evaluate.lerobot_policy", "--checkpoint", str(ckpt), "--port", "0"]
    proc = subprocess.Popen(serve, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=_env())
    try:
        assert proc.stdout is not None
        url = next(line.split(" on ")[1].split()[0] for line in proc.stdout if line.startswith("serving "))
        subprocess.run([*MGDATA, "eval", "--policy", url, "--scenarios", str(scenarios), "--convention",
                        "state", "--seeds", "0", "--out", str(results), *extra], check=True, timeout=600)
    finally:
        proc.terminate()
        proc.wait(timeout=60)
    return [json.loads(line) for line in (results / "rollouts.jsonl").read_text().splitlines()]


ACT = ["--policy.type=act", "--policy.dim_model=32", "--policy.dim_feedforward=64",
       "--policy.n_encoder_layers=1", "--policy.n_decoder_layers=1", "--policy.use_vae=false",
       "--policy.chunk_size=10", "--policy.n_action_steps=10"]
DIFFUSION = ["--policy.type=diffusion", "--policy.down_dims=[16,32]", "--policy.diffusion_step_embed_dim=16",
             "--policy.num_inference_steps=2"]


def test_lerobot_train_serve_eval_state_only(scenario_set: Path, state_view: Path, tmp_path: Path) -> None:
    ckpt = _train(state_view, tmp_path / "train", ACT)
    features = json.loads((ckpt / "config.json").read_text())["input_features"]
    assert set(features) == {"observation.state", "observation.environment_state"}
    results = tmp_path / "results"
    records = _serve_and_eval(ckpt, scenario_set, results, "--horizon", "30")
    assert [r["condition"] for r in records] == ["base", "target"]
    assert all(r["end"] == "timeout" and r["steps"] == 30 for r in records)
    assert json.loads((results / "eval.json").read_text())["policy_metadata"]["inputs"] == [
        "observation.state", "observation.environment_state"]


HISTORY_PROBE = """
import json, sys
import numpy as np
from mgdata.evaluate.lerobot_policy import LeRobotPolicy
p = LeRobotPolicy(sys.argv[1])
width = p.policy.config.input_features["observation.environment_state"].shape[0]
def obs(step, only=False):
    o = {"observation.state": np.full(8, 0.1 * step, np.float32), "task": "t", "episode_seed": 7,
         "observation.environment_state": np.zeros(width, np.float32), "mgdata/step": step,
         "mgdata/scenario": "jar/task_0000/base"}
    return {**o, "mgdata/observe_only": True} if only else o
shapes = [p.infer(obs(0))["actions"].shape, p.infer(obs(1, True))["actions"].shape,
          p.infer(obs(2))["actions"].shape]
queued = [float(s[0, 0]) for s in p.policy._queues["observation.state"]]
expected = [float(p.pre(p.policy_frame(obs(k)))["observation.state"][0, 0]) for k in (1, 2)]
print(json.dumps({"history": p.metadata["observation_history"], "shapes": shapes, "queued": queued,
                  "expected": expected}))
"""


def test_a_diffusion_policy_sees_every_step(scenario_set: Path, state_view: Path, tmp_path: Path) -> None:
    """Diffusion reads the last two observations (``n_obs_steps``): the server keeps them per rollout as
    LeRobot's ``select_action`` does, ``mgdata eval`` sends the steps between queries observe-only, and the
    queue at a query holds the previous step's observation and this one's."""
    ckpt = _train(state_view, tmp_path / "train", DIFFUSION)
    probe = subprocess.run([_venv_python(), "-c", HISTORY_PROBE, str(ckpt)], capture_output=True, text=True,
                           env=_env(), timeout=600)
    assert probe.returncode == 0, probe.stderr[-3000:]
    got = json.loads(probe.stdout.strip().splitlines()[-1])
    assert got["history"] == 2
    assert got["shapes"][1] == [0, 8] and got["shapes"][0] == got["shapes"][2] and got["shapes"][0][1] == 8
    assert got["queued"] == pytest.approx(got["expected"], abs=1e-6)
    records = _serve_and_eval(ckpt, scenario_set, tmp_path / "results", "--horizon", "20",
                              "--chunk-steps", "8")
    assert all(r["end"] == "timeout" and r["steps"] == 20 for r in records)


CONCURRENT_PROBE = """
import json, sys, threading
import numpy as np
from mgdata.evaluate.lerobot_policy import LeRobotPolicy
p = LeRobotPolicy(sys.argv[1])
width = p.policy.config.input_features["observation.environment_state"].shape[0]
def obs(k):
    return {"observation.state": np.full(8, 0.05 * k, np.float32), "task": "t", "episode_seed": k,
            "observation.environment_state": np.full(width, 0.01 * k, np.float32), "mgdata/step": 0,
            "mgdata/scenario": "s"}
alone = {k: p.infer(obs(k))["actions"] for k in range(4)}
wrong = []
def worker(k):
    for _ in range(150):
        if not np.array_equal(p.infer(obs(k))["actions"], alone[k]):
            wrong.append(k)
threads = [threading.Thread(target=worker, args=(k,)) for k in range(4)]
[t.start() for t in threads]
[t.join() for t in threads]
print(json.dumps({"wrong": len(wrong), "distinct": len({a.tobytes() for a in alone.values()})}))
"""


def test_concurrent_queries_get_their_own_answers(state_view: Path, tmp_path: Path) -> None:
    """The server answers each connection in a thread; four threads querying one policy at once each get
    the answer their observation gets alone (LeRobot's processor steps hold the transition they work on:
    unserialised, two rollouts' observations crossed)."""
    ckpt = _train(state_view, tmp_path / "train", ACT)
    probe = subprocess.run([_venv_python(), "-c", CONCURRENT_PROBE, str(ckpt)], capture_output=True,
                           text=True, env=_env(), timeout=600)
    assert probe.returncode == 0, probe.stderr[-3000:]
    got = json.loads(probe.stdout.strip().splitlines()[-1])
    assert got == {"wrong": 0, "distinct": 4}


def test_lerobot_eval_scores_a_checkpoint_on_mgdata_scenarios(scenario_set: Path, state_view: Path,
                                                              tmp_path: Path) -> None:
    """LeRobot's own ``lerobot-eval`` with ``--env.type=mgdata`` (mgdata.gym.lerobot_env) rolls the checkpoint
    out on the scenarios; its episodes are the records ``mgdata eval`` writes for the same checkpoint, and
    ``mgdata metrics`` reads them."""
    ckpt = _train(state_view, tmp_path / "train", ACT)
    records = tmp_path / "lerobot_eval" / "rollouts.jsonl"
    evaluated = subprocess.run(
        [_venv_python(), "-m", "lerobot.scripts.lerobot_eval", "--env.discover_packages_path=mgdata.gym",
         "--env.type=mgdata", "--env.family=jar", "--env.tasks=0", f"--env.scenarios={scenario_set}",
         "--env.horizon=30", f"--env.records={records}", f"--policy.path={ckpt}", "--policy.device=cpu",
         "--eval.n_episodes=2", "--eval.batch_size=1", "--seed=0",
         f"--output_dir={tmp_path / 'lerobot_eval'}"],
        capture_output=True, text=True, env={**_env(), "MUJOCO_GL": "egl"}, timeout=900)
    assert evaluated.returncode == 0, evaluated.stderr[-3000:]
    info = json.loads((tmp_path / "lerobot_eval" / "eval_info.json").read_text())
    assert info["overall"]["n_episodes"] == 2 and info["overall"]["pc_success"] == 0.0
    got = [json.loads(line) for line in records.read_text().splitlines()]
    # seeds 0 and 1 over one task: task 0 under base seeds 0 and 1, as `mgdata eval --seeds 0,1`
    assert [(r["scenario"], r["seed"]) for r in got] == [("jar/task_0000/base", 0), ("jar/task_0000/base", 1)]
    assert all(r["steps"] == 30 and r["end"] == "timeout" for r in got)
    served = _serve_and_eval(ckpt, scenario_set, tmp_path / "mgdata_eval", "--horizon", "30",
                             "--chunk-steps", "10", "--seeds", "0,1", "--condition", "base")
    assert sorted(got, key=lambda r: r["seed"]) == sorted(served, key=lambda r: r["seed"])
    metrics = subprocess.run([*MGDATA, "metrics", str(records)], capture_output=True, text=True, check=True)
    assert "SSR" in metrics.stdout
