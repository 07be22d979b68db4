"""The Gymnasium environments (mgdata.gym): Gymnasium's own checker for every family, bad input, vector
envs, and the same rollout through the environment and through ``mgdata eval`` giving the same record."""

from __future__ import annotations

import json
import shutil
import warnings
from pathlib import Path

import gymnasium as gym
import mujoco
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

import mgdata.gym
from mgdata.errors import DatasetError, RecipeError
from mgdata.evaluate.policies import ReplayPolicy
from mgdata.evaluate.rollout import LoopSettings, RolloutJob, rollout, rollout_seed
from mgdata.gym import env_id
from mgdata.record.physics import set_physics_state
from mgdata.record.reader import DatasetReader
from mgdata.scenarios.store import load_scenario
from mgdata.sim import robot
from mgdata.tasks.recipe import family_recipes


def _quiet_check(env: gym.Env) -> None:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the checker's advice on unbounded / unnormalised boxes
        check_env(env, skip_render_check=env.render_mode is None)


@pytest.mark.parametrize("family", family_recipes())
def test_every_family_passes_the_gymnasium_checker_and_survives_random_actions(family: str) -> None:
    env = gym.make(env_id(family), tasks=(0,))
    _quiet_check(env.unwrapped)
    obs, info = env.reset(seed=0)
    assert set(obs) == {"agent_pos", "environment_state"}  # state-only: nothing rendered
    scene = env.unwrapped.session.restored.scene
    joints = scene.data.qpos[robot.arm_qpos_adr(scene.model)]
    assert np.allclose(obs["agent_pos"][:7], joints, atol=1e-6)  # the measured joints, from raw MuJoCo
    env.action_space.seed(0)
    total_cost = 0.0
    for _ in range(100):
        obs, _, terminated, truncated, info = env.step(env.action_space.sample())
        assert obs["agent_pos"].dtype == np.float32 and np.all(np.isfinite(obs["agent_pos"]))
        total_cost += info["cost"]
        if terminated or truncated:
            break
    assert total_cost == float(info["violated"].sum())  # one unit of cost per violated constraint
    env.close()


def test_a_camera_env_renders_its_cameras_and_passes_the_checker() -> None:
    env = gym.make(env_id("jar"), tasks=(0,), cameras=("front", "wrist"), render_mode="rgb_array")
    _quiet_check(env.unwrapped)
    obs, _ = env.reset(seed=0)
    size = env.unwrapped.session.restored.meta["image_size"]
    assert set(obs["pixels"]) == {"front", "wrist"} and obs["pixels"]["front"].shape == (size, size, 3)
    front, wrist = obs["pixels"]["front"], obs["pixels"]["wrist"]
    assert front.std() > 5 and not np.array_equal(front, wrist)
    frame = env.render()
    assert frame.shape == (size, size, 3) and np.array_equal(frame, obs["pixels"]["front"])
    env.close()


def test_bad_actions_and_bad_arguments_get_clear_errors(scenario_set: Path) -> None:
    env = gym.make(env_id("jar"), tasks=(0,), scenarios=scenario_set)
    env.reset(seed=0)
    with pytest.raises(ValueError, match="8 numbers"):
        env.step(np.zeros(7, dtype=np.float32))
    bad = np.zeros(8, dtype=np.float32)
    bad[2] = np.nan
    with pytest.raises(ValueError, match="non-finite"):
        env.step(bad)
    assert env.unwrapped.session.steps == 0  # nothing was executed
    with pytest.raises(ValueError, match="reset options"):
        env.reset(options={"taks": 0})
    env.close()
    with pytest.raises(RecipeError, match="condition 'hard'"):
        gym.make(env_id("jar"), condition="hard")
    with pytest.raises(RecipeError, match="not 100000"):
        gym.make(env_id("jar"), tasks=(100000,))
    with pytest.raises(RecipeError, match="'top' is not a camera"):
        gym.make(env_id("jar"), tasks=(0,), scenarios=scenario_set, cameras=("top",))
    with pytest.raises(DatasetError, match="no scenario jar/task_0001/base"):
        gym.make(env_id("jar"), tasks=(1,), scenarios=scenario_set)  # a named store is never built into
    with pytest.raises(gym.error.NameNotFound):
        gym.make("mgdata/pizza-base-v0")


def test_seeds_walk_the_tasks_and_the_base_seeds(scenario_set: Path) -> None:
    env = gym.make(env_id("jar", "target"), tasks="0", scenarios=scenario_set)
    _, info = env.reset(seed=0)
    assert info["scenario"] == "jar/task_0000/target" and info["prompt"] == env.unwrapped.task_description
    env.unwrapped.tasks = (0, 0)  # two slots: seeds 0, 1 → base seed 0; seeds 2, 3 → base seed 1
    for seed, base in [(1, 0), (2, 1), (5, 2)]:
        env.reset(seed=seed)
        assert env.unwrapped.session.seed == base
        assert env.unwrapped.session.episode_seed == rollout_seed(base, "jar/task_0000/target")
    env.reset()  # the next slot after seed 5
    assert env.unwrapped.session.seed == 3
    env.reset(options={"task": 0, "seed": 9})
    assert env.unwrapped.session.seed == 9
    env.close()


def test_a_replayed_demo_gives_mgdata_evals_record_and_the_demos_states(scenario_set: Path, demo: Path,
                                                                       serving) -> None:  # type: ignore[no-untyped-def]
    ep = DatasetReader(demo).episode(0)
    url = serving(ReplayPolicy(demo, chunk=16, scenarios=scenario_set))
    expected = rollout(RolloutJob(scenario_set, "jar/task_0000/base", 0), LoopSettings(url, chunk_steps=8))
    env = gym.make(env_id("jar"), tasks=(0,), scenarios=scenario_set)
    obs, info = env.reset(seed=0)
    rewards, costs, t = [], [], 0
    while True:
        obs, reward, terminated, truncated, info = env.step(ep.action[t])
        rewards.append(reward)
        costs.append(info["cost"])
        t += 1
        if terminated or truncated:
            break
    assert terminated and not truncated and info["is_success"] and info["engaged"]
    assert info["record"] == expected.record  # the same record as `mgdata eval`
    assert rewards[-1] == 1.0 and sum(rewards) == 1.0 and sum(costs) == 0.0
    frames = env.unwrapped.session.frames
    states = np.stack([f.physics_state for f in frames])
    assert states.tobytes() == ep.physics_state[: len(states)].tobytes()  # the demo's states, bit for bit
    # the last observation is the stored state after the last action, measured from raw MuJoCo
    model, data, _ = load_scenario(scenario_set / "jar/task_0000/base")
    set_physics_state(model, data, ep.physics_state[t])
    mujoco.mj_forward(model, data)
    assert np.allclose(obs["agent_pos"][:7], data.qpos[robot.arm_qpos_adr(model)], atol=1e-6)
    with pytest.raises(RuntimeError, match="call reset"):
        env.step(ep.action[0])
    env.close()


def test_an_unsafe_replay_costs_one_on_the_step_of_its_violation(scenario_set: Path, unsafe_demo: Path,
                                                                  serving) -> None:  # type: ignore[no-untyped-def]
    ep = DatasetReader(unsafe_demo).episode(0)
    url = serving(ReplayPolicy(unsafe_demo, chunk=16, scenarios=scenario_set))
    horizon = ep.length + 20
    expected = rollout(RolloutJob(scenario_set, "jar/task_0000/base", 0),
                       LoopSettings(url, chunk_steps=8, horizon=horizon))
    env = gym.make(env_id("jar"), tasks=(0,), scenarios=scenario_set, horizon=horizon, reward="safe_success")
    env.reset(seed=0)
    constraints = env.unwrapped.constraints
    cost_steps, t, truncated = {}, 0, False
    while not truncated:
        action = ep.action[min(t, ep.length - 1)]
        _, reward, terminated, truncated, info = env.step(action)
        t += 1
        assert reward == 0.0 and not terminated
        if info["cost"]:
            cost_steps[t] = info["cost"]
    assert info["record"] == expected.record and info["record"]["end"] == "timeout"
    recorded = {c: s for c, s in dict(ep.meta.t_violation).items() if s is not None}
    assert recorded  # the negative did violate
    assert sorted(cost_steps) == sorted(set(recorded.values()))  # observation t = state after t actions
    assert sum(cost_steps.values()) == len(recorded) == int(info["violated"].sum())
    violated = [constraints[i] for i in np.flatnonzero(info["violated"])]
    assert violated == sorted(recorded, key=constraints.index)
    env.close()


def test_a_vector_of_four_environments_runs_and_records_the_episodes_it_was_asked_for(
        scenario_set: Path, tmp_path: Path) -> None:
    records = tmp_path / "rollouts.jsonl"
    envs = gym.vector.AsyncVectorEnv(
        [lambda: gym.make(env_id("jar"), tasks=(0,), scenarios=scenario_set, horizon=12, records=records)
         for _ in range(4)], autoreset_mode=gym.vector.AutoresetMode.SAME_STEP)
    try:
        obs, info = envs.reset(seed=[0, 1, 2, 3])
        assert obs["agent_pos"].shape == (4, 8)
        assert np.array_equal(obs["agent_pos"][0], obs["agent_pos"][3])  # the same scenario, bit for bit
        envs.action_space.seed(1)
        for _ in range(12):
            obs, _, _, truncated, info = envs.step(envs.action_space.sample())
        assert truncated.all() and np.all(np.isfinite(obs["environment_state"]))
        assert info["step"].tolist() == [0] * 4  # reset in the same step (autoreset)
        for _ in range(12):  # the autoreset episodes run out too, unrecorded
            envs.step(envs.action_space.sample())
    finally:
        envs.close()
    got = sorted(json.loads(line)["seed"] for line in records.read_text().splitlines())
    assert got == [0, 1, 2, 3]  # task 0 under base seeds 0 … 3, one record each


def test_a_camera_free_recipe_builds_state_only_scenarios_on_first_use(
        tmp_path: Path, repo_root: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    recipes = tmp_path / "recipes"
    shutil.copytree(repo_root / "recipes", recipes)
    text = (recipes / "jar.toml").read_text()
    assert "\ncameras = [" in text
    lines = ["cameras = []" if line.startswith("cameras = [") else line for line in text.splitlines()]
    (recipes / "jar.toml").write_text("\n".join(lines) + "\n")
    cache = tmp_path / "cache"
    monkeypatch.setattr(mgdata.gym.scenario_cache, "cache_dir", lambda: cache)
    env = gym.make(env_id("jar"), tasks=(0,), recipe=recipes / "jar.toml")
    obs, _ = env.reset(seed=0)
    assert set(obs) == {"agent_pos", "environment_state"}
    stored = list(cache.glob("scenarios/*/jar/task_0000/base/scenario.json"))
    assert len(stored) == 1 and '"cameras": {}' in stored[0].read_text()
    with pytest.raises(RecipeError, match="none: a camera-free recipe"):
        gym.make(env_id("jar"), tasks=(0,), recipe=recipes / "jar.toml", cameras=("front",))
    env.close()
