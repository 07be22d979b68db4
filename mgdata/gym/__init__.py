"""Gymnasium environments over mgdata's locked scenarios (:class:`~mgdata.gym.env.ScenarioEnv`).

Importing this package registers ``mgdata/<family>-<condition>-v0`` for every family recipe and condition
(``mgdata/jar-base-v0``, ``mgdata/clutter_dry-location-v0`` …); keyword arguments of
:class:`~mgdata.gym.env.ScenarioEnv` pass through ``gymnasium.make``. The ids are registered without
Gymnasium's order-enforcing wrapper (the environment checks the order itself), so LeRobot's eval loop sees
the environment's own attributes (``task_description``, ``_max_episode_steps``).

Example::

    import gymnasium as gym
    import mgdata.gym

    env = gym.make("mgdata/jar-base-v0", tasks="0-3")
    env = gym.make("mgdata.gym:mgdata/jar-base-v0")   # the same, importing the package on the way
"""

from __future__ import annotations

import gymnasium as gym

from mgdata.gym.env import ScenarioEnv

NAMESPACE = "mgdata"
VERSION = 0


def env_id(family: str, condition: str = "base") -> str:
    """``mgdata/<family>-<condition>-v0``."""
    return f"{NAMESPACE}/{family}-{condition}-v{VERSION}"


def register_envs() -> tuple[str, ...]:
    """Register an id per family recipe and condition (again harmlessly); returns the ids."""
    from mgdata.tasks.recipe import family_recipes
    from mgdata.tasks.variants import CONDITIONS

    ids = []
    for family in family_recipes():
        for condition in CONDITIONS:
            name = env_id(family, condition)
            if name not in gym.registry:
                gym.register(name, entry_point="mgdata.gym.env:ScenarioEnv", order_enforce=False,
                             kwargs={"family": family, "condition": condition})
            ids.append(name)
    return tuple(ids)


__all__ = ["ScenarioEnv", "env_id", "register_envs"]

register_envs()
