"""Build a tiny, untrained LeRobot ACT policy checkpoint for the opt-in `-m lerobot` evaluation check.

Runs in a LeRobot environment (``scripts/check_lerobot_compat.sh`` builds one), never in mgdata's:

    LEROBOT_VENV/bin/python scripts/lerobot_tiny_policy.py OUT_DIR [IMAGE_SIZE]

The policy reads the SmolVLA-convention keys ``observation.images.top``, ``observation.images.wrist`` (3 ×
IMAGE_SIZE²) and ``observation.state`` (8) and predicts chunks of 8 actions (8); normalisation statistics are
zero mean and unit spread. Weights are seeded (torch seed 0), so the checkpoint is the same every time.
"""

from __future__ import annotations

import sys
from pathlib import Path

import torch
from lerobot.configs.types import FeatureType, PolicyFeature
from lerobot.policies.act.configuration_act import ACTConfig
from lerobot.policies.act.modeling_act import ACTPolicy
from lerobot.policies.factory import make_pre_post_processors


def main() -> None:
    out = Path(sys.argv[1])
    size = int(sys.argv[2]) if len(sys.argv) > 2 else 256
    image = PolicyFeature(type=FeatureType.VISUAL, shape=(3, size, size))
    config = ACTConfig(
        input_features={"observation.state": PolicyFeature(type=FeatureType.STATE, shape=(8,)),
                        "observation.images.top": image, "observation.images.wrist": image},
        output_features={"action": PolicyFeature(type=FeatureType.ACTION, shape=(8,))},
        chunk_size=8, n_action_steps=8, dim_model=64, n_heads=2, dim_feedforward=128, n_encoder_layers=1,
        n_decoder_layers=1, use_vae=False, pretrained_backbone_weights=None, device="cpu")
    torch.manual_seed(0)
    policy = ACTPolicy(config)
    stats = {"observation.state": {"mean": torch.zeros(8), "std": torch.ones(8)},
             "action": {"mean": torch.zeros(8), "std": torch.ones(8)}}
    for key in ("observation.images.top", "observation.images.wrist"):
        stats[key] = {"mean": torch.full((3, 1, 1), 0.5), "std": torch.full((3, 1, 1), 0.25)}
    pre, post = make_pre_post_processors(config, dataset_stats=stats)
    out.mkdir(parents=True, exist_ok=True)
    policy.save_pretrained(out)
    pre.save_pretrained(out)
    post.save_pretrained(out)
    print(out)


if __name__ == "__main__":
    main()
