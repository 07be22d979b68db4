"""Re-render benchmark: ``mgdata render`` throughput (issue 16: a 224² two-camera dataset from the stored
physics states) and the check that labels, states and actions are identical to the source.

The source is a generated jar dataset (``--source``, or ``--n`` demonstrations generated first with one
64² camera, which is cheap); the benchmark re-renders it at ``--size`` with ``--cameras`` and prints frames
per second of wall time and per CPU-second (user + system, LLVMpipe pinned to one thread as in
``bench_generate.py``), camera-frames per CPU-second, and whether every per-frame column but the pictures
is identical.

Run: ``.venv/bin/python benchmarks/bench_render.py [--source DATASET | --n 2] [--size 224]
[--cameras front,wrist]``
"""

from __future__ import annotations

import os

os.environ["LP_NUM_THREADS"] = "1"  # before mujoco: one llvmpipe thread

import argparse
import resource
import shutil
import tempfile
from pathlib import Path

import numpy as np

from mgdata.generate.run import GenerateJob, generate
from mgdata.paths import recipes_dir
from mgdata.record.reader import DatasetReader
from mgdata.record.rerender import RenderJob, rerender

COLUMNS = ("state", "action", "labels", "dfa_state", "violated", "engaged", "success", "physics_state")


def cpu_seconds() -> float:
    own = resource.getrusage(resource.RUSAGE_SELF)
    return own.ru_utime + own.ru_stime


def cheap_source(root: Path, n: int) -> Path:
    """``n`` jar demonstrations with one 64² camera (the source's pictures do not matter here)."""
    text = (recipes_dir() / "jar.toml").read_text()
    text = text.replace('spec = "specs/jar.toml"', f'spec = "{recipes_dir() / "specs" / "jar.toml"}"')
    text = text.replace('cameras = ["front", "left", "right", "shoulder", "wrist"]', 'cameras = ["front"]')
    text = text.replace("image_size = 256", "image_size = 64")
    (root / "recipe").mkdir()
    (root / "recipe" / "jar.toml").write_text(text)
    out = root / "source"
    generate(GenerateJob(family="jar", n=n, out=out, recipe=root / "recipe" / "jar.toml"))
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--source", type=Path, default=None)
    parser.add_argument("--n", type=int, default=2, help="demonstrations to generate without --source")
    parser.add_argument("--size", type=int, default=224)
    parser.add_argument("--cameras", default="front,wrist")
    args = parser.parse_args()
    root = Path(tempfile.mkdtemp(prefix="bench_render_"))
    try:
        source = args.source or cheap_source(root, args.n)
        cameras = tuple(c.strip() for c in args.cameras.split(","))
        cpu0 = cpu_seconds()
        summary = rerender(RenderJob(source, root / "out", size=args.size, cameras=cameras))
        cpu = cpu_seconds() - cpu0
        src, new = DatasetReader(source), DatasetReader(summary.out)
        same = all(np.array_equal(getattr(src.episode(e), c), getattr(new.episode(e), c))
                   for e in range(src.num_episodes) for c in COLUMNS) and \
            all(src.record(e).meta == new.record(e).meta for e in range(src.num_episodes))
        print(f"LP_NUM_THREADS={os.environ['LP_NUM_THREADS']} · re-rendered {summary.episodes} episodes, "
              f"{summary.frames} frames at {args.size}² with {len(cameras)} cameras ({', '.join(cameras)})")
        print(f"wall {summary.wall:.1f} s · CPU {cpu:.1f} s · {summary.frames / summary.wall:.1f} frames/s "
              "wall · "
              f"{summary.frames / cpu:.1f} frames per CPU-second · "
              f"{summary.frames * len(cameras) / cpu:.1f} camera-frames per CPU-second")
        print("labels, states, actions, safety columns, physics states and metadata identical to the "
              f"source: {'yes' if same else 'NO'}")
    finally:
        shutil.rmtree(root, ignore_errors=True)


if __name__ == "__main__":
    main()
