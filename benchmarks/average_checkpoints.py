"""Average the weights of several saved LeRobot checkpoints of one training run into a new checkpoint.

A uniform average of the weights a constant-learning-rate run passes through late in training (Polyak
averaging, "stochastic weight averaging") sits nearer the centre of the loss valley than any one of them; a
closed-loop success rate that swings by tens of points from one checkpoint to the next (docs/train.md, ninth
run) is a symptom of that spread. Runs in the LeRobot environment (torch and safetensors)::

    /work/lerobot-venv/bin/python benchmarks/average_checkpoints.py OUT CKPT [CKPT ...]

Each CKPT is a ``pretrained_model`` folder; OUT becomes a copy of the last one (config, processors and their
normaliser statistics, which training never changes) with ``model.safetensors`` replaced by the mean.
"""

from __future__ import annotations

import argparse
import shutil
import sys
from pathlib import Path

WEIGHTS = "model.safetensors"


def average(checkpoints: list[Path], out: Path) -> None:
    """Write the element-wise mean of ``checkpoints``' weights (float64 accumulation) to ``out``."""
    import torch
    from safetensors.torch import load_file, save_file

    total: dict[str, torch.Tensor] = {}
    first: dict[str, torch.Tensor] = {}
    for ckpt in checkpoints:
        weights = load_file(ckpt / WEIGHTS)
        if not first:
            first = weights
        if weights.keys() != first.keys():
            raise SystemExit(f"error: {ckpt} holds other tensors than {checkpoints[0]} (another model?)")
        for name, w in weights.items():
            if w.shape != first[name].shape:
                raise SystemExit(f"error: {ckpt}: {name} is {tuple(w.shape)}, not {tuple(first[name].shape)}")
            acc = w.to(torch.float64) if w.is_floating_point() else w
            total[name] = acc if name not in total or not w.is_floating_point() else total[name] + acc
    mean = {name: (t / len(checkpoints)).to(first[name].dtype) if first[name].is_floating_point() else t
            for name, t in total.items()}
    tmp = out.with_name(out.name + ".partial")
    shutil.rmtree(tmp, ignore_errors=True)
    shutil.copytree(checkpoints[-1], tmp)
    save_file(mean, str(tmp / WEIGHTS), metadata={"format": "pt"})
    shutil.rmtree(out, ignore_errors=True)
    tmp.rename(out)


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("out", type=Path, help="the averaged checkpoint's folder (replaced)")
    p.add_argument("checkpoints", type=Path, nargs="+", help="pretrained_model folders of one run")
    args = p.parse_args()
    missing = [c for c in args.checkpoints if not (c / WEIGHTS).is_file()]
    if missing:
        sys.exit(f"error: {missing[0]} has no {WEIGHTS}")
    average(args.checkpoints, args.out)
    print(f"{args.out}: mean of {len(args.checkpoints)} checkpoints")


if __name__ == "__main__":
    main()
