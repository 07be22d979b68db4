"""Observation and action keys per model family, as the dataset exports name them (``mgdata export``).

A policy server receives one observation dict per query and answers with an action chunk:

* ``pi0`` (openpi, LIBERO-style): ``observation/image`` (overview), ``observation/wrist_image``,
  ``observation/state`` (8,), ``prompt``; reply ``actions`` (H, 8).
* ``smolvla`` (LeRobot): ``observation.images.top``, ``observation.images.wrist``, ``observation.state``,
  ``task``; reply ``actions`` (H, 8).
* ``state`` (LeRobot, state-only policies): ``observation.state``, ``observation.environment_state``
  (:mod:`mgdata.sim.environment_state`, as ``mgdata export --format state`` writes it), ``task``; no camera
  is rendered; reply ``actions`` (H, 8).
* ``groot`` (GR00T N1.5 modality names): ``video.<camera>`` (1, H, W, 3) per camera,
  ``state.single_arm`` (1, 7), ``state.gripper`` (1, 1), ``annotation.human.task_description`` [prompt];
  reply ``action.single_arm`` (H, 7) + ``action.gripper`` (H, 1), or ``actions`` (H, 8).

Every observation also carries ``episode_seed`` (the per-rollout seed, as the reference's servers read it)
and three ``mgdata/`` keys a model ignores and the reference policies read: ``mgdata/step`` (control step
index), ``mgdata/scenario`` (the scenario's path in the set, e.g. ``jar/task_0000/base``) and
``mgdata/command`` (8,) (the joint command in force: arm targets + gripper command). A server whose metadata
says ``observation_history`` > 1 (a policy reading several past observations: diffusion) also gets the
observations of the steps between queries, flagged ``mgdata/observe_only`` (it records them and answers no
actions).
Images are uint8 RGB (H, W, 3); state is float32 (7 measured joints, rad + gripper opening, m); actions are
7 joint targets (rad) + gripper command (1 close, 0 open).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from mgdata.errors import PolicyError, RecipeError

CONVENTIONS = ("pi0", "smolvla", "groot", "state")
ENVIRONMENT_STATE = "observation.environment_state"
OBSERVE_ONLY = "mgdata/observe_only"


@dataclass(frozen=True)
class Observation:
    """What the client measured at one control step (before the policy's action)."""

    images: Mapping[str, np.ndarray]
    state: np.ndarray
    command: np.ndarray
    prompt: str
    episode_seed: int
    step: int
    scenario: str
    environment_state: np.ndarray | None = None


def default_cameras(convention: str, available: Sequence[str]) -> tuple[str, ...]:
    """The cameras a convention sends when ``--cameras`` is not given: the first overview camera and the
    wrist camera (pi0 and SmolVLA take exactly these two; GR00T takes the same two by default); none for
    ``state``."""
    if convention == "state":
        return ()
    others = [c for c in available if c != "wrist"]
    if not others or "wrist" not in available:
        raise RecipeError(f"the scenario cameras ({', '.join(available)}) need an overview and 'wrist'")
    return (others[0], "wrist")


def check_cameras(convention: str, cameras: Sequence[str], available: Sequence[str]) -> None:
    """Refuse cameras the scenarios do not have, or a camera count the convention cannot carry."""
    if convention not in CONVENTIONS:
        raise RecipeError(f"--convention {convention!r}: expected one of {', '.join(CONVENTIONS)}")
    if convention == "state":
        if cameras:
            raise RecipeError("--cameras: the state convention sends no camera; leave --cameras out")
        return
    unknown = [c for c in cameras if c not in available]
    if unknown:
        raise RecipeError(f"--cameras {unknown[0]!r} is not a scenario camera ({', '.join(available)})")
    if convention != "groot" and (len(cameras) != 2 or cameras[1] != "wrist" or cameras[0] == "wrist"):
        raise RecipeError(f"--cameras for {convention}: give two, an overview and then 'wrist' "
                          f"(e.g. {available[0]},wrist), got {','.join(cameras)}")


def encode(convention: str, cameras: Sequence[str], obs: Observation) -> dict[str, Any]:
    """The request dict of ``obs`` under ``convention``; ``obs.environment_state``, when measured, travels
    as ``observation.environment_state`` in every convention (a policy that does not read it ignores it)."""
    out: dict[str, Any]
    if convention == "state":
        out = {"observation.state": obs.state, "task": obs.prompt}
    elif convention == "pi0":
        out = {"observation/image": obs.images[cameras[0]], "observation/wrist_image": obs.images[cameras[1]],
               "observation/state": obs.state, "prompt": obs.prompt}
    elif convention == "smolvla":
        out = {"observation.images.top": obs.images[cameras[0]],
               "observation.images.wrist": obs.images[cameras[1]], "observation.state": obs.state,
               "task": obs.prompt}
    else:
        out = {f"video.{c}": obs.images[c][None] for c in cameras}
        out |= {"state.single_arm": obs.state[None, :7], "state.gripper": obs.state[None, 7:],
                "annotation.human.task_description": [obs.prompt]}
    if obs.environment_state is not None:
        out[ENVIRONMENT_STATE] = obs.environment_state
    out |= {"episode_seed": obs.episode_seed, "mgdata/step": obs.step, "mgdata/scenario": obs.scenario,
            "mgdata/command": obs.command}
    return out


def decode_actions(reply: Any) -> np.ndarray:
    """The (H, 8) float32 action chunk of a reply (``actions``, or GR00T's ``action.single_arm`` +
    ``action.gripper``); a single (8,) action is a chunk of one.

    Raises:
        PolicyError: the reply holds no action chunk of that shape.
    """
    if not isinstance(reply, Mapping):
        raise PolicyError(f"the policy replied with {type(reply).__name__}; expected a dict with 'actions'")
    if "actions" in reply:
        actions = np.asarray(reply["actions"])
    elif "action.single_arm" in reply and "action.gripper" in reply:
        arm, grip = np.asarray(reply["action.single_arm"]), np.asarray(reply["action.gripper"])
        if arm.ndim != 2 or grip.ndim != 2 or arm.shape[0] != grip.shape[0]:
            raise PolicyError(f"the policy replied action.single_arm {arm.shape} and action.gripper "
                              f"{grip.shape}; expected (H, 7) and (H, 1)")
        actions = np.concatenate([arm, grip], axis=1)
    else:
        raise PolicyError(f"the policy's reply has no 'actions' (keys: {', '.join(map(str, reply))})")
    if actions.ndim == 1:
        actions = actions[None]
    if actions.ndim != 2 or actions.shape[1] != 8 or actions.shape[0] < 1 or actions.dtype.kind not in "fiu":
        raise PolicyError(f"the policy replied actions of shape {actions.shape} ({actions.dtype}); "
                          "expected (H, 8) numbers: 7 joint targets + gripper command")
    return actions.astype(np.float32)
