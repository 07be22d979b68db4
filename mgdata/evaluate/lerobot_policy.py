"""A LeRobot policy checkpoint on disk, served over the same protocol as the reference policies.

The checkpoint is a ``save_pretrained`` folder of LeRobot 0.4 (``config.json``, ``model.safetensors`` and the
``policy_preprocessor*`` / ``policy_postprocessor*`` pipelines with their normalisation statistics). It is
loaded with LeRobot's own code (``get_policy_class(type).from_pretrained``, ``make_pre_post_processors``),
and answers observations in the ``smolvla`` convention (``mgdata eval --convention smolvla``): each
``observation.images.<key>`` the policy declares (HWC uint8 → CHW float in [0, 1]), ``observation.state`` and
``task``. A query returns the policy's whole action chunk (``predict_action_chunk``, un-normalised by the
post-processor); torch is seeded from ``(episode_seed, mgdata/step)`` first, so sampling policies give the
same chunk for the same request.

This module imports only numpy, torch, lerobot, websockets and msgpack, so it runs in a LeRobot
environment kept apart from mgdata's (``scripts/check_lerobot_compat.sh`` builds one)::

    LEROBOT_VENV/bin/python -m mgdata.evaluate.lerobot_policy --checkpoint ckpt/ --port 8000

or, with the ``lerobot`` extra installed in mgdata's environment, ``mgdata serve lerobot --checkpoint ckpt/``.
"""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

import numpy as np

import mgdata
from mgdata.errors import PolicyError

IMAGE_PREFIX = "observation.images."


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
        self.image_keys = tuple(k for k in self.policy.config.input_features if k.startswith(IMAGE_PREFIX))

    @property
    def metadata(self) -> dict[str, Any]:
        return {"policy": "lerobot", "type": self.type, "checkpoint": str(self.checkpoint),
                "images": list(self.image_keys), "mgdata": mgdata.__version__}

    def infer(self, obs: dict[str, Any]) -> dict[str, Any]:
        torch = self._torch
        frame: dict[str, Any] = {}
        for key in (*self.image_keys, "observation.state"):
            if key not in obs:
                reads = ", ".join(self.image_keys)
                raise PolicyError(f"the request has no {key!r}; the policy reads {reads} and "
                                  "observation.state (mgdata eval --convention smolvla)")
        for key in self.image_keys:
            image = np.asarray(obs[key])
            frame[key] = torch.from_numpy(np.ascontiguousarray(image.transpose(2, 0, 1))).float() / 255.0
        frame["observation.state"] = torch.from_numpy(np.asarray(obs["observation.state"], np.float32).copy())
        frame["task"] = str(obs.get("task", ""))
        seed = (int(obs.get("episode_seed", 0)) * 1_000_003 + int(obs.get("mgdata/step", 0))) % 2**63
        torch.manual_seed(seed)
        with torch.inference_mode():
            chunk = self.policy.predict_action_chunk(self.pre(frame))
            actions = self.post(chunk)
        out = np.asarray(actions.detach().cpu().numpy(), dtype=np.float32)
        return {"actions": out.reshape(-1, out.shape[-1])}


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
