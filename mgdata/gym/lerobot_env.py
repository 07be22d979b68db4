"""``--env.type=mgdata``: mgdata's locked scenarios in LeRobot's own ``lerobot-eval`` (LeRobot 0.4.4).

LeRobot 0.4.4 builds an evaluation environment from a registered ``EnvConfig`` (a draccus choice) by
``gymnasium.make(cfg.gym_id, **cfg.gym_kwargs)``, and ``lerobot-eval --env.discover_packages_path=PKG``
imports ``PKG`` and its modules before it parses the rest of the command line: that is how a third-party
environment registers (no fork, no entry point of ours). This module registers :class:`MgdataEnvConfig`
as ``mgdata``; it imports LeRobot, so it is imported only there (mgdata and its dependencies must be
installed in LeRobot's environment: ``scripts/check_lerobot_compat.sh`` does it)::

    MUJOCO_GL=egl lerobot-eval --env.discover_packages_path=mgdata.gym --env.type=mgdata \\
        --env.family=jar --env.tasks=1040-1059 --env.records=out/eval/rollouts.jsonl \\
        --policy.path=ckpt/pretrained_model --policy.device=cpu \\
        --eval.n_episodes=20 --eval.batch_size=1 --seed=0 --output_dir=out/eval
    mgdata metrics out/eval/rollouts.jsonl       # SSR, EVR … beside LeRobot's pc_success

Seed ``s`` of ``lerobot-eval`` runs task ``tasks[s mod n]`` under base seed ``s // n``
(:mod:`mgdata.gym.env`), so ``--seed 0 --eval.n_episodes n·R`` runs every task ``R`` times, and
LeRobot's ``pc_success`` counts successes as ``mgdata eval`` does (the success hold; safe or not).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from lerobot.configs.types import FeatureType, PolicyFeature
from lerobot.envs.configs import EnvConfig
from lerobot.utils.constants import ACTION, OBS_ENV_STATE, OBS_IMAGES, OBS_STATE

from mgdata.gym import env_id
from mgdata.gym.scenario_cache import ScenarioCache
from mgdata.options import parse_ids
from mgdata.sim.environment_state import EnvironmentLayout


@EnvConfig.register_subclass("mgdata")
@dataclass
class MgdataEnvConfig(EnvConfig):
    """An mgdata family's scenarios (the keyword arguments of :class:`~mgdata.gym.env.ScenarioEnv`;
    ``cameras`` comma-separated, empty for a state-only policy)."""

    family: str = "jar"
    condition: str = "base"
    tasks: str | None = None
    scenarios: str | None = None
    recipe: str | None = None
    cameras: str = ""
    horizon: int | None = None
    records: str | None = None
    fps: int = 20
    features: dict[str, PolicyFeature] = field(default_factory=dict)
    features_map: dict[str, str] = field(default_factory=dict)

    def __post_init__(self) -> None:
        from mgdata.skeleton.skeleton import load_family_recipe

        recipe = load_family_recipe(self.recipe or self.family)
        first = (parse_ids(self.tasks) if self.tasks else ()) or (0,)
        restored = ScenarioCache(recipe, self.scenarios).restore(first[0], self.condition)
        width = len(EnvironmentLayout(restored.scene.model).names)
        size = int(restored.meta["image_size"])
        self.features = {ACTION: PolicyFeature(type=FeatureType.ACTION, shape=(8,)),
                         "agent_pos": PolicyFeature(type=FeatureType.STATE, shape=(8,)),
                         "environment_state": PolicyFeature(type=FeatureType.ENV, shape=(width,))}
        self.features_map = {ACTION: ACTION, "agent_pos": OBS_STATE, "environment_state": OBS_ENV_STATE}
        for camera in self._cameras:
            self.features[f"pixels/{camera}"] = PolicyFeature(type=FeatureType.VISUAL, shape=(size, size, 3))
            self.features_map[f"pixels/{camera}"] = f"{OBS_IMAGES}.{camera}"

    @property
    def _cameras(self) -> tuple[str, ...]:
        return tuple(c.strip() for c in self.cameras.split(",") if c.strip())

    @property
    def package_name(self) -> str:
        return "mgdata.gym"

    @property
    def gym_id(self) -> str:
        return env_id(self.family, self.condition)

    @property
    def gym_kwargs(self) -> dict[str, Any]:
        return {"tasks": self.tasks, "scenarios": self.scenarios, "recipe": self.recipe,
                "cameras": self._cameras, "horizon": self.horizon, "records": self.records,
                "render_mode": "rgb_array"}
