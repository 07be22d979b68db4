"""``ScenarioEnv``: a Gymnasium environment over one family's locked scenarios under one condition.

``reset`` restores a stored scenario bit for bit (:mod:`mgdata.gym.scenario_cache`) and ``step`` runs the
step of generation and ``mgdata eval`` (:class:`~mgdata.evaluate.session.RolloutSession`), so a rollout
here and one through ``mgdata eval`` give the same record.

* **Tasks and seeds.** ``tasks`` (default: all of the family's base tasks) in order; ``reset(seed=s)``
  starts task ``tasks[s mod n]`` under base seed ``s // n`` (``mgdata eval --seed``), so seeds
  ``0 … n·R − 1`` cover every task ``R`` times (``lerobot-eval --seed 0 --eval.n_episodes n·R``);
  ``reset()`` takes the next pair; ``options={"task": k, "seed": b}`` picks both.
* **Observation** (LeRobot's gym names, which its ``preprocess_observation`` turns into the dataset's
  ``observation.state``, ``observation.environment_state`` and ``observation.images.<camera>``):
  ``agent_pos`` float32 (8,) (7 joints, rad + gripper opening, m), ``environment_state`` float32
  (:mod:`mgdata.sim.environment_state`) and, with ``cameras``, ``pixels`` {camera: uint8 (H, W, 3)}.
  State-only (no ``cameras``, the default) renders nothing. The prompt is ``env.unwrapped.task_description``
  (and ``info["prompt"]``).
* **Action** float32 (8,): 7 joint targets (rad; clipped to the actuator ranges, the space's bounds) and a
  gripper value, thresholded at 0.5 (≥ 0.5 closes, as the dataset's binary command). A non-finite action or
  one of another shape is a ``ValueError``.
* **Episode end.** ``terminated`` when the success column (goal ∧ at rest) has held for ``hold_steps``, as
  ``mgdata eval`` scores success; ``truncated`` at the scenario's horizon, or if the physics diverged
  (``info["end"]``). A safety violation does not end the episode.
* **Reward** (sparse, ``reward=``): ``"success"`` 1.0 on the step the success hold completes;
  ``"safe_success"`` the same only if no constraint was ever violated (the paper's SSR). No shaped reward.
* **Info, every step:** the safety monitor: ``labels`` (bool, ``env.unwrapped.propositions`` order),
  ``dfa_state`` (int16) and ``violated`` (bool, latched; ``env.unwrapped.constraints`` order), ``engaged``,
  ``success`` (the success column at this state), ``cost`` (Safety-Gymnasium style: 1.0 for each constraint
  whose first violation is this step, so an episode's costs sum to the constraints it violated),
  ``is_success`` (LeRobot's key: the episode ended in success), ``step``, ``scenario``, ``prompt``; on the
  last step also ``record``, the ``mgdata eval`` record. With ``records=PATH`` the records of the episodes
  started by ``reset(seed=…)`` or ``reset(options=…)`` are appended to ``PATH`` as JSON lines, which
  ``mgdata metrics`` reads (SSR, EVR …); a vector env's argument-less autoreset starts an unrecorded episode,
  so ``lerobot-eval``'s batches record exactly the episodes it scores (:mod:`mgdata.gym.lerobot_env`).

Example::

    import gymnasium as gym
    import mgdata.gym  # registers mgdata/<family>-<condition>-v0

    env = gym.make("mgdata/jar-base-v0", tasks="0-9")
    obs, info = env.reset(seed=3)            # task 3, base seed 0
    obs, reward, terminated, truncated, info = env.step(env.action_space.sample())
"""

from __future__ import annotations

import json
import os
from collections.abc import Sequence
from pathlib import Path
from typing import Any, ClassVar

import gymnasium as gym
import numpy as np

from mgdata.errors import RecipeError
from mgdata.evaluate.session import RolloutSession
from mgdata.gym.scenario_cache import ScenarioCache
from mgdata.options import parse_ids
from mgdata.sim import robot
from mgdata.sim.renderer import CameraRig
from mgdata.tasks.variants import CONDITIONS

REWARDS = ("success", "safe_success")


class ScenarioEnv(gym.Env[dict[str, Any], np.ndarray]):
    """One family's locked scenarios under one condition (see the module docstring).

    Args:
        family: a family name (its recipe) unless ``recipe`` is given.
        condition: base, target, language, location or environment.
        tasks: base task ids (a sequence or a string such as ``"0-9,12"``); default: all of the family's.
        scenarios: a store built by ``mgdata scenarios build``; default: built on first use in the cache.
        recipe: a family recipe file to build from (e.g. a camera-free copy); its family must be ``family``.
        cameras: cameras to observe (``pixels``); default none (state-only).
        horizon: control steps before truncation; default the scenario's.
        render_mode: ``"rgb_array"`` (:meth:`render` draws ``render_camera``) or ``None``.
        reward: ``"success"`` or ``"safe_success"``.
        records: a JSONL file the records of explicitly started episodes are appended to.
    """

    metadata: ClassVar[dict[str, Any]] = {"render_modes": ["rgb_array"], "render_fps": 20}

    def __init__(self, family: str = "jar", condition: str = "base", tasks: str | Sequence[int] | None = None,
                 scenarios: str | Path | None = None, recipe: str | Path | None = None,
                 cameras: Sequence[str] = (), horizon: int | None = None, render_mode: str | None = None,
                 render_camera: str = "front", reward: str = "success",
                 records: str | Path | None = None) -> None:
        from mgdata.skeleton.skeleton import load_family_recipe

        if condition not in CONDITIONS:
            raise RecipeError(f"condition {condition!r}: expected one of {', '.join(CONDITIONS)}")
        if render_mode not in (None, *self.metadata["render_modes"]):
            raise RecipeError(f"render_mode {render_mode!r}: expected 'rgb_array' or None")
        if reward not in REWARDS:
            raise RecipeError(f"reward {reward!r}: expected one of {', '.join(REWARDS)}")
        loaded = load_family_recipe(recipe if recipe is not None else family)
        if loaded.family != family:
            raise RecipeError(f"recipe {recipe} is a {loaded.family} recipe, not {family}")
        count = loaded.tasks.count
        ids = parse_ids(tasks) if isinstance(tasks, str) else tuple(tasks or ())
        self.tasks: tuple[int, ...] = tuple(ids) or tuple(range(count))
        bad = [k for k in self.tasks if not 0 <= k < count]
        if bad:
            raise RecipeError(f"tasks: {family} has tasks 0 … {count - 1}, not {bad[0]}")
        self.family, self.condition, self.reward_kind = family, condition, reward
        self.cameras, self.render_mode, self.render_camera = tuple(cameras), render_mode, render_camera
        self._cache = ScenarioCache(loaded, scenarios)
        self._horizon = horizon
        self._records = Path(records) if records is not None else None
        self._record_to: Path | None = None  # where this episode's record goes (explicitly started ones)
        self._session: RolloutSession | None = None
        self._rig: CameraRig | None = None
        self._render_rig: CameraRig | None = None
        self._next = 0
        self._open(self.tasks[0], 0)  # the spaces come from a scenario of the family
        session = self._live
        scene, meta = session.restored.scene, session.restored.meta
        self.propositions = tuple(scene.task.safety.proposition_names)
        self.constraints = tuple(c.id for c in scene.task.safety.constraints)
        self._env_size = session.environment_state().size
        self._max_episode_steps = session.horizon  # what lerobot-eval reads through env.call
        act = robot.arm_actuator_ids(scene.model)[:7]
        low = np.append(scene.model.actuator_ctrlrange[act, 0], 0.0).astype(np.float32)
        high = np.append(scene.model.actuator_ctrlrange[act, 1], 1.0).astype(np.float32)
        self.action_space = gym.spaces.Box(low, high, dtype=np.float32)
        spaces: dict[str, gym.Space[Any]] = {
            "agent_pos": gym.spaces.Box(-np.inf, np.inf, (8,), np.float32),
            "environment_state": gym.spaces.Box(-np.inf, np.inf, (self._env_size,), np.float32),
        }
        size = int(meta["image_size"])
        if self.cameras:
            spaces["pixels"] = gym.spaces.Dict(
                {c: gym.spaces.Box(0, 255, (size, size, 3), np.uint8) for c in self.cameras})
        self.observation_space = gym.spaces.Dict(spaces)

    # -- Gymnasium API -----------------------------------------------------------------------------------
    def reset(self, *, seed: int | None = None,
              options: dict[str, Any] | None = None) -> tuple[dict[str, Any], dict[str, Any]]:
        super().reset(seed=seed)
        explicit = seed is not None or bool(options)
        options = dict(options or {})
        n = len(self.tasks)
        index = seed if seed is not None else self._next
        task, base = self.tasks[index % n], index // n
        task, base = int(options.pop("task", task)), int(options.pop("seed", base))
        if options:
            raise ValueError(f"reset options {sorted(options)}: expected 'task' and/or 'seed'")
        self._next = index + 1
        self._open(task, base)
        self._record_to = self._records if explicit else None
        obs = self._observation()
        if obs["environment_state"].size != self._env_size:
            raise RecipeError(f"{self._live.scenario}: its environment state has another size than the "
                              f"family's first task ({self._env_size}); use one environment per layout")
        return obs, self._info(0.0)

    def step(self, action: np.ndarray) -> tuple[dict[str, Any], float, bool, bool, dict[str, Any]]:
        session = self._live
        if session.end is not None:
            raise RuntimeError(f"the episode has ended ({session.end}); call reset()")
        a = np.asarray(action, dtype=np.float64)
        if a.shape != (8,):
            raise ValueError(f"an action is 8 numbers (7 joint targets, rad + gripper), got shape {a.shape}")
        if not np.all(np.isfinite(a)):
            raise ValueError(f"the action has non-finite values: {a.tolist()}")
        violations = list(session.monitor.first_violation)
        end = session.step(a)
        cost = float(sum(before is None and after is not None
                         for before, after in zip(violations, session.monitor.first_violation, strict=True)))
        success = end == "success"
        safe = all(v is None for v in session.monitor.first_violation)
        reward = float(success and (self.reward_kind == "success" or safe))
        info = self._info(cost)
        if end is not None:
            info["record"] = session.record()
            if self._record_to is not None:
                _append_line(self._record_to, json.dumps(info["record"], sort_keys=True))
        return self._observation(), reward, success, end in ("timeout", "sim_diverged"), info

    def render(self) -> np.ndarray | None:
        if self.render_mode != "rgb_array":
            return None
        session = self._live
        if self._render_rig is None:
            self._render_rig = CameraRig(session.restored.scene, (self.render_camera,),
                                         int(session.restored.meta["image_size"]))
        return self._render_rig.render()[self.render_camera]

    def close(self) -> None:
        self._close_scenario()

    # -- mgdata --------------------------------------------------------------------------------------------
    @property
    def task_description(self) -> str:
        """The current scenario's prompt (LeRobot reads it as the policy's ``task``)."""
        return str(self._live.restored.meta["prompt"])

    @property
    def task(self) -> str:
        return self.task_description

    @property
    def session(self) -> RolloutSession:
        """The rollout in progress (scene, monitor, frames, record)."""
        return self._live

    @property
    def _live(self) -> RolloutSession:
        if self._session is None:
            raise RuntimeError("the environment is closed; make a new one")
        return self._session

    def _open(self, task: int, base_seed: int) -> None:
        self._close_scenario()
        restored = self._cache.restore(task, self.condition)
        available = list(restored.meta["cameras"])
        unknown = [c for c in self.cameras if c not in available]
        if unknown:
            raise RecipeError(f"cameras: {unknown[0]!r} is not a camera of the scenarios "
                              f"({', '.join(available) or 'none: a camera-free recipe'})")
        self._session = RolloutSession(restored, self._cache.path(task, self.condition), base_seed,
                                       self._horizon)
        self._session.start()
        if self.cameras:
            self._rig = CameraRig(restored.scene, self.cameras, int(restored.meta["image_size"]))

    def _close_scenario(self) -> None:
        for rig in (self._rig, self._render_rig):
            if rig is not None:
                rig.close()
        self._rig = self._render_rig = None
        if self._session is not None:
            self._session.close()
            self._session = None

    def _observation(self) -> dict[str, Any]:
        session = self._live
        obs: dict[str, Any] = {"agent_pos": session.state(), "environment_state": session.environment_state()}
        if self._rig is not None:
            obs["pixels"] = self._rig.render()
        return obs

    def _info(self, cost: float) -> dict[str, Any]:
        session = self._live
        monitor, recorder = session.monitor, session.recorder
        return {
            "labels": recorder.labels.copy(), "dfa_state": monitor.dfa_state.copy(),
            "violated": monitor.violated.copy(), "engaged": recorder.t_engage is not None,
            "success": recorder.success, "cost": cost, "is_success": session.end == "success",
            "step": session.steps, "scenario": session.scenario, "prompt": self.task_description,
        }


def _append_line(path: Path, line: str) -> None:
    """Append one line with a single ``write`` on an ``O_APPEND`` descriptor (the processes of a vector env
    share the file; lines of a record's size are never interleaved)."""
    path.parent.mkdir(parents=True, exist_ok=True)
    fd = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_APPEND, 0o644)
    try:
        os.write(fd, (line + "\n").encode())
    finally:
        os.close(fd)
