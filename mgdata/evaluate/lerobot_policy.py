"""A LeRobot policy checkpoint on disk, served over the same protocol as the reference policies.

The checkpoint is a ``save_pretrained`` folder of LeRobot 0.4 (``config.json``, ``model.safetensors`` and the
``policy_preprocessor*`` / ``policy_postprocessor*`` pipelines with their normalisation statistics). It is
loaded with LeRobot's own code (``get_policy_class(type).from_pretrained``, ``make_pre_post_processors``),
and answers observations in every convention ``mgdata eval`` sends (:func:`policy_frame`): each
``observation.images.<key>`` the policy declares (HWC uint8 → CHW float in [0, 1], resized to the policy's
image size if the request's differs), ``observation.state``, ``observation.environment_state`` if the policy
reads it, and ``task``. The metadata frame lists the policy's ``inputs``, so ``mgdata eval`` sends the
environment state whenever the policy reads it (``--convention state``: no camera is rendered). A query
returns the policy's whole action chunk (``predict_action_chunk``, un-normalised by the
post-processor); torch is seeded from ``(episode_seed, mgdata/step)`` first, so sampling policies give the
same chunk for the same request. Queries are answered one at a time (LeRobot's pre- and post-processors are
not thread-safe: with two ``mgdata eval`` workers on one server their observations crossed).

A policy that reads a history of observations (``n_obs_steps`` > 1: diffusion) gets it as LeRobot's own
``select_action`` builds it: the metadata says ``observation_history: n``, ``mgdata eval`` then sends every
step's observation (those between queries flagged ``mgdata/observe_only``: recorded, answered with no
actions), and the server keeps the policy's observation queues per rollout (``mgdata/scenario``,
``episode_seed``; a step that does not follow the last one starts them afresh).

This module imports only numpy, torch, lerobot, websockets, msgpack and mgdata modules that need nothing
else (errors, the observation keys), so it runs in a LeRobot environment kept apart from mgdata's
(``scripts/check_lerobot_compat.sh`` builds one)::

    LEROBOT_VENV/bin/python -m mgdata.evaluate.lerobot_policy --checkpoint ckpt/ --port 8000

or, with the ``lerobot`` extra installed in mgdata's environment, ``mgdata serve lerobot --checkpoint ckpt/``.
"""

from __future__ import annotations

import argparse
import threading
from collections import OrderedDict
from pathlib import Path
from typing import Any

import numpy as np

import mgdata
from mgdata.errors import PolicyError
from mgdata.evaluate.conventions import ENVIRONMENT_STATE, OBSERVE_ONLY

IMAGE_PREFIX = "observation.images."
STATE = "observation.state"
WRIST = "wrist"
ROLLOUTS_KEPT = 64
"""Rollouts whose observation queues a history policy's server keeps (the least recently seen go first)."""


def _request_images(obs: dict[str, Any]) -> dict[str, np.ndarray]:
    """Camera name -> (H, W, 3) uint8 image of a request in any convention (pi0's overview is ``image``,
    SmolVLA's ``top``, GR00T's ``video.<camera>`` arrays (1, H, W, 3))."""
    out: dict[str, np.ndarray] = {}
    for key, value in obs.items():
        if key.startswith(IMAGE_PREFIX):
            out[key[len(IMAGE_PREFIX):]] = np.asarray(value)
        elif key.startswith("video."):
            out[key[len("video."):]] = np.asarray(value)[0]
        elif key == "observation/image":
            out["image"] = np.asarray(value)
        elif key == "observation/wrist_image":
            out[WRIST] = np.asarray(value)
    return out


def _request_state(obs: dict[str, Any]) -> np.ndarray | None:
    if STATE in obs:
        return np.asarray(obs[STATE], np.float32)
    if "observation/state" in obs:
        return np.asarray(obs["observation/state"], np.float32)
    if "state.single_arm" in obs and "state.gripper" in obs:
        return np.concatenate([np.asarray(obs["state.single_arm"], np.float32)[0],
                               np.asarray(obs["state.gripper"], np.float32)[0]])
    return None


def match_cameras(wanted: tuple[str, ...], given: tuple[str, ...]) -> dict[str, str]:
    """Policy camera -> request camera: by name, else the wrist to the wrist and the other cameras to the
    request's overview cameras in order (a policy trained on ``front,wrist`` served ``top,wrist``)."""
    out = {w: w for w in wanted if w in given}
    free = [g for g in given if g not in out.values() and g != WRIST]
    for w in wanted:
        if w in out:
            continue
        if w == WRIST or (WRIST in w and WRIST in given):
            if WRIST in given:
                out[w] = WRIST
        elif free:
            out[w] = free.pop(0)
    return out


class LeRobotPolicy:
    """See the module docstring; ``device``: a torch device name (``cpu``, ``cuda``)."""

    def __init__(self, checkpoint: Path, device: str = "cpu") -> None:
        try:
            import torch
            from lerobot.configs.policies import PreTrainedConfig
            from lerobot.policies.factory import get_policy_class, make_pre_post_processors
        except ImportError as err:
            raise PolicyError(f"serving a LeRobot checkpoint needs the lerobot package ({err}); install "
                              "mgdata[lerobot] or run this module in a LeRobot environment") from None
        self.checkpoint = Path(checkpoint)
        if not (self.checkpoint / "config.json").is_file():
            raise PolicyError(f"{checkpoint}: not a LeRobot checkpoint folder (no config.json)")
        self._torch = torch
        config = PreTrainedConfig.from_pretrained(str(self.checkpoint))
        self.type = config.type
        self.policy = get_policy_class(config.type).from_pretrained(str(self.checkpoint)).to(device).eval()
        self.pre, self.post = make_pre_post_processors(
            self.policy.config, pretrained_path=str(self.checkpoint),
            preprocessor_overrides={"device_processor": {"device": device}})
        features = self.policy.config.input_features
        self.inputs = tuple(features)
        self.image_keys = tuple(k for k in features if k.startswith(IMAGE_PREFIX))
        self._sizes = {k: tuple(features[k].shape[-2:]) for k in self.image_keys}
        self.history = int(getattr(self.policy.config, "n_obs_steps", 1) or 1)
        self._rollouts: OrderedDict[tuple[str, int], tuple[int, dict[str, Any]]] = OrderedDict()
        self._lock = threading.Lock()
        """One query at a time: the server answers each connection in its own thread, and LeRobot's processor
        steps keep the transition they work on in the step object (``_current_transition``), so two
        rollouts queried at once crossed their observations (and a history policy's queues are swapped
        per rollout)."""

    @property
    def metadata(self) -> dict[str, Any]:
        convention = "smolvla" if self.image_keys else "state"
        return {"policy": "lerobot", "type": self.type, "checkpoint": str(self.checkpoint),
                "images": list(self.image_keys), "inputs": list(self.inputs), "convention": convention,
                "observation_history": self.history, "mgdata": mgdata.__version__}

    def _image(self, key: str, image: np.ndarray) -> Any:
        torch = self._torch
        out = torch.from_numpy(np.ascontiguousarray(image.transpose(2, 0, 1))).float() / 255.0
        if tuple(out.shape[-2:]) != self._sizes[key]:
            out = torch.nn.functional.interpolate(out[None], size=self._sizes[key], mode="area")[0]
        return out

    def policy_frame(self, obs: dict[str, Any]) -> dict[str, Any]:
        """The policy's input frame of a request in any ``mgdata eval`` convention (see the module
        docstring), before the pre-processor.

        Raises:
            PolicyError: the request lacks an input the policy reads.
        """
        torch = self._torch
        frame: dict[str, Any] = {}
        images = _request_images(obs)
        wanted = tuple(k[len(IMAGE_PREFIX):] for k in self.image_keys)
        cams = match_cameras(wanted, tuple(images))
        for cam in wanted:
            if cam not in cams:
                raise PolicyError(f"the request has no image for the policy's camera {cam!r} (it sent "
                                  f"{', '.join(images) or 'none'}); use mgdata eval --convention smolvla")
            frame[IMAGE_PREFIX + cam] = self._image(IMAGE_PREFIX + cam, images[cams[cam]])
        state = _request_state(obs)
        if state is None:
            raise PolicyError("the request has no observation.state")
        frame[STATE] = torch.from_numpy(state.copy())
        if ENVIRONMENT_STATE in self.inputs:
            if ENVIRONMENT_STATE not in obs:
                raise PolicyError("the policy reads observation.environment_state and the request has none; "
                                  "use mgdata eval --convention state")
            frame[ENVIRONMENT_STATE] = torch.from_numpy(np.asarray(obs[ENVIRONMENT_STATE], np.float32).copy())
        prompt = obs.get("task", obs.get("prompt", obs.get("annotation.human.task_description", "")))
        frame["task"] = str(prompt[0] if isinstance(prompt, list | tuple) else prompt)
        return frame

    def infer(self, obs: dict[str, Any]) -> dict[str, Any]:
        torch = self._torch
        frame = self.policy_frame(obs)
        seed = (int(obs.get("episode_seed", 0)) * 1_000_003 + int(obs.get("mgdata/step", 0))) % 2**63
        with self._lock, torch.inference_mode():
            torch.manual_seed(seed)
            batch = self.pre(frame)
            if self.history > 1:
                batch = self._observe(obs, batch)
                if obs.get(OBSERVE_ONLY):
                    return {"actions": np.zeros((0, self.policy.config.output_features["action"].shape[0]),
                                                np.float32)}
            chunk = self.policy.predict_action_chunk(batch)
            actions = self.post(chunk)
        out = np.asarray(actions.detach().cpu().numpy(), dtype=np.float32)
        return {"actions": out.reshape(-1, out.shape[-1])}

    def _observe(self, obs: dict[str, Any], batch: dict[str, Any]) -> dict[str, Any]:
        """Append ``batch`` to its rollout's observation queues and make them the policy's (what LeRobot's
        ``select_action`` does at every step before ``predict_action_chunk`` reads them); ``batch`` as
        ``predict_action_chunk`` then takes it (without the pre-processor's empty ``action``)."""
        from lerobot.policies.utils import populate_queues

        key = (str(obs.get("mgdata/scenario", "")), int(obs.get("episode_seed", 0)))
        step = int(obs.get("mgdata/step", 0))
        last = self._rollouts.pop(key, None)
        if last is None or step != last[0] + 1:
            self.policy.reset()
            queues = self.policy._queues
        else:
            queues = last[1]
        batch = {k: v for k, v in batch.items() if k != "action"}
        if self.policy.config.image_features:
            batch["observation.images"] = self._torch.stack(
                [batch[k] for k in self.policy.config.image_features], dim=-4)
        self.policy._queues = populate_queues(queues, batch)
        self._rollouts[key] = (step, self.policy._queues)
        while len(self._rollouts) > ROLLOUTS_KEPT:
            self._rollouts.popitem(last=False)
        return batch


def main() -> None:
    """``python -m mgdata.evaluate.lerobot_policy --checkpoint DIR [--host H] [--port P] [--device D]``."""
    from mgdata.evaluate.server import PolicyServer

    parser = argparse.ArgumentParser(description="Serve a LeRobot checkpoint (openpi websocket protocol).")
    parser.add_argument("--checkpoint", type=Path, required=True)
    parser.add_argument("--host", default="127.0.0.1")
    parser.add_argument("--port", type=int, default=8000)
    parser.add_argument("--device", default="cpu")
    args = parser.parse_args()
    server = PolicyServer(LeRobotPolicy(args.checkpoint, args.device), args.host, args.port)
    print(f"serving lerobot on {server.url} (health: GET /healthz)", flush=True)
    try:
        server.serve_forever()
    except KeyboardInterrupt:
        server.shutdown()


if __name__ == "__main__":
    main()
