"""The reference policies ``mgdata serve`` ships: ``hold``, ``random`` and ``replay``.

Each reads the request keys :mod:`mgdata.evaluate.conventions` adds to every observation
(``mgdata/command``, ``mgdata/step``, ``mgdata/scenario``, ``episode_seed``) and answers ``{"actions":
(H, 8) float32}``. None keeps state between requests, so a reply depends only on the request: results do
not depend on scenario order, worker count or how rollouts share connections.

* :class:`HoldPolicy`: the joint command in force, repeated (the robot never moves).
* :class:`RandomPolicy`: a seeded random walk of the joint targets from the command in force, and a gripper
  command that flips at random; the generator is seeded by ``(seed, episode_seed, step)``.
* :class:`ReplayPolicy`: a recorded episode's actions ``[step, step + H)`` (its last action repeated past
  its end) for the episode that starts from the request's scenario.

Example::

    policy = ReplayPolicy(Path("datasets/jar"), scenarios=Path("scenarios"), chunk=16)
    policy.infer({"mgdata/scenario": "jar/task_0000/base", "mgdata/step": 0, ...})["actions"].shape
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

import mgdata
from mgdata.errors import DatasetError, PolicyError
from mgdata.evaluate.config import RandomConfig


def _get(obs: Mapping[str, Any], key: str) -> Any:
    if key not in obs:
        raise PolicyError(f"the request has no {key!r} (send observations with `mgdata eval`)")
    return obs[key]


def _command(obs: Mapping[str, Any]) -> np.ndarray:
    cmd = np.asarray(_get(obs, "mgdata/command"), dtype=np.float32)
    if cmd.shape != (8,):
        raise PolicyError(f"'mgdata/command' must have shape (8,), got {cmd.shape}")
    return cmd


class HoldPolicy:
    """Repeats the joint command in force: the robot holds still."""

    def __init__(self, chunk: int) -> None:
        self.chunk = chunk

    @property
    def metadata(self) -> dict[str, Any]:
        return {"policy": "hold", "chunk": self.chunk, "mgdata": mgdata.__version__}

    def infer(self, obs: dict[str, Any]) -> dict[str, Any]:
        return {"actions": np.repeat(_command(obs)[None], self.chunk, axis=0)}


class RandomPolicy:
    """Seeded random actions (see the module docstring); ``seed`` is ``mgdata serve random --seed``."""

    def __init__(self, seed: int, config: RandomConfig) -> None:
        self.seed, self.config = seed, config

    @property
    def metadata(self) -> dict[str, Any]:
        c = self.config
        return {"policy": "random", "seed": self.seed, "chunk": c.chunk, "joint_step": c.joint_step,
                "gripper_flip": c.gripper_flip, "mgdata": mgdata.__version__}

    def infer(self, obs: dict[str, Any]) -> dict[str, Any]:
        c = self.config
        cmd = _command(obs)
        episode_seed, step = int(_get(obs, "episode_seed")), int(_get(obs, "mgdata/step"))
        rng = np.random.default_rng([self.seed, episode_seed, step])
        arm = cmd[:7].astype(np.float64) + np.cumsum(rng.uniform(-c.joint_step, c.joint_step, (c.chunk, 7)),
                                                      axis=0)
        flips = np.cumsum(rng.random(c.chunk) < c.gripper_flip) % 2
        grip = np.where(flips == 1, 1.0 - round(float(cmd[7])), round(float(cmd[7])))
        return {"actions": np.concatenate([arm, grip[:, None]], axis=1).astype(np.float32)}


@dataclass(frozen=True)
class _Episode:
    index: int
    kept: bool
    actions: np.ndarray


class ReplayPolicy:
    """Serves recorded episodes of ``dataset`` (see the module docstring).

    With ``scenarios`` (a scenario set), a scenario is matched to the episodes of its family and task whose
    **first stored physics state equals the scenario's state bit for bit**, whatever their condition (a base
    demo also serves the target, language and environment variants of its task: their physics is the
    base's, bit for bit; a moved location has another state and no match). Without, a scenario is matched
    to the episodes of its family, task and condition. Kept episodes are preferred, then the lowest index.
    """

    def __init__(self, dataset: Path, *, chunk: int, scenarios: Path | None = None) -> None:
        from mgdata.record.reader import DatasetReader

        self.dataset, self.chunk = Path(dataset), chunk
        reader = DatasetReader(self.dataset)
        if reader.num_episodes == 0:
            raise DatasetError(f"{dataset}: the dataset has no episodes to replay")
        by_key: dict[tuple[str, int, str], list[tuple[_Episode, bytes]]] = {}
        for i in range(reader.num_episodes):
            ep = reader.episode(i)
            if ep.physics_state is None:
                raise DatasetError(f"{dataset}: stores no physics states (sim.physics_state); "
                                   "replay needs them")
            m = ep.meta
            first = np.ascontiguousarray(ep.physics_state[0], dtype="<f8").tobytes()
            by_key.setdefault((m.family, m.task_id, m.condition), []).append(
                (_Episode(i, m.kept, np.ascontiguousarray(ep.action, dtype=np.float32)), first))
        for eps in by_key.values():
            eps.sort(key=lambda e: (not e[0].kept, e[0].index))
        self._by_key = by_key
        self._matched: dict[str, _Episode] | None = None
        if scenarios is not None:
            self._matched = self._match(Path(scenarios))

    def _match(self, scenarios: Path) -> dict[str, _Episode]:
        from mgdata.scenarios.store import STATE, read_manifest

        matched = {}
        for entry in read_manifest(scenarios):
            state = np.load(scenarios / entry["path"] / STATE, allow_pickle=False)
            blob = np.ascontiguousarray(state, dtype="<f8").tobytes()
            candidates = sorted((pair for (family, task, _), eps in self._by_key.items() for pair in eps
                                 if family == entry["family"] and task == int(entry["task_id"])),
                                key=lambda pair: (not pair[0].kept, pair[0].index))
            hit = next((ep for ep, first in candidates if first == blob), None)
            if hit is not None:
                matched[entry["path"]] = hit
        if not matched:
            raise DatasetError(f"{self.dataset}: no episode starts from the state of any scenario in "
                               f"{scenarios}")
        return matched

    @property
    def scenarios(self) -> tuple[str, ...]:
        """The scenarios this policy can replay (with ``scenarios``; else empty)."""
        return tuple(self._matched or ())

    @property
    def metadata(self) -> dict[str, Any]:
        return {"policy": "replay", "dataset": str(self.dataset), "chunk": self.chunk,
                "scenarios": list(self.scenarios), "mgdata": mgdata.__version__}

    def episode_for(self, scenario: str) -> int:
        """The index of the episode served for ``scenario`` (``family/task_NNNN/condition``)."""
        return self._episode(scenario).index

    def _episode(self, scenario: str) -> _Episode:
        if self._matched is not None:
            if scenario not in self._matched:
                raise PolicyError(f"no episode of {self.dataset} starts from the state of scenario "
                                  f"{scenario}")
            return self._matched[scenario]
        try:
            family, task, condition = scenario.split("/")
            key = (family, int(task.removeprefix("task_")), condition)
        except ValueError:
            raise PolicyError(f"'mgdata/scenario' {scenario!r} is not family/task_NNNN/condition") from None
        if key not in self._by_key:
            raise PolicyError(f"{self.dataset} has no episode of scenario {scenario}")
        return self._by_key[key][0][0]

    def infer(self, obs: dict[str, Any]) -> dict[str, Any]:
        ep = self._episode(str(_get(obs, "mgdata/scenario")))
        step = int(_get(obs, "mgdata/step"))
        rows = np.minimum(np.arange(step, step + self.chunk), len(ep.actions) - 1)
        return {"actions": ep.actions[rows]}
