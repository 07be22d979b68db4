"""Append benchmark: the commit time of one episode as the dataset grows (target of issue 16: the commit at
episode 1,000 within 1.2× of the one at episode 1).

Synthetic episodes go through the real writer: a few distinct episodes (jar-like length, five cameras, a
physics-state column as wide as the jar scene's) are staged once (encoded), then appended over and over
with ``DatasetWriter.append_staged`` (the exact call ``mgdata generate`` commits with; each append copies the
staged folder first, outside the timing). A commit rewrites the current data and episodes files, which
start afresh every ``EPISODES_PER_FILE`` episodes (``mgdata.record.layout``), so its cost is a sawtooth of
that period: the benchmark prints the mean commit time over the first period (episodes 1-20) and over the
last one (episodes 981-1,000 of ``--episodes 1000``), their ratio, and the slowest commit of each.

Run: ``.venv/bin/python benchmarks/bench_append.py [--episodes 1000] [--length 650]``
"""

from __future__ import annotations

import argparse
import shutil
import tempfile
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

from mgdata.record.layout import EPISODES_PER_FILE
from mgdata.record.staging import EpisodeStager
from mgdata.record.synthetic import SYNTHETIC_SPEC, synthetic_episode, synthetic_schema
from mgdata.record.writer import DatasetWriter

PHYSICS_WIDTH = 78
"""The jar scene's ``sim.physics_state`` width."""
DISTINCT = 4


def stage(root: Path, length: int, size: int) -> list[Path]:
    """``DISTINCT`` staged episodes (encoded once)."""
    schema = replace(synthetic_schema(size=size), physics_state_size=PHYSICS_WIDTH)
    out = []
    for k in range(DISTINCT):
        ep = synthetic_episode(synthetic_schema(size=size), length, seed=k, draw_index=k)
        rng = np.random.default_rng(k)
        physics = rng.normal(size=(length, PHYSICS_WIDTH))
        images = [ep.images(t) for t in range(8)]
        stager = EpisodeStager(root / f"staged-{k}", schema)
        stager.set_scene(bytes(rng.integers(0, 255, 4096, dtype=np.uint8)))
        for t, frame in enumerate(ep.frames(images)):
            stager.add_frame(replace(frame, physics_state=physics[t]))
        stager.end_episode(ep.meta)
        out.append(stager.path)
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--episodes", type=int, default=1000)
    parser.add_argument("--length", type=int, default=650, help="frames per episode (jar: ~600-700)")
    parser.add_argument("--size", type=int, default=64, help="image side (the videos' size matters little)")
    args = parser.parse_args()
    root = Path(tempfile.mkdtemp(prefix="bench_append_"))
    try:
        staged = stage(root, args.length, args.size)
        schema = replace(synthetic_schema(size=args.size), physics_state_size=PHYSICS_WIDTH)
        times: list[float] = []
        with DatasetWriter.create(root / "ds", schema, spec=SYNTHETIC_SPEC) as writer:
            for e in range(args.episodes):
                copy = shutil.copytree(staged[e % DISTINCT], root / "copy")
                t0 = time.perf_counter()
                writer.append_staged(copy)
                times.append(time.perf_counter() - t0)
                if (e + 1) % 100 == 0:
                    print(f"  {e + 1} episodes, last commit {times[-1] * 1000:.0f} ms", flush=True)
        k = EPISODES_PER_FILE
        first, last = np.array(times[:k]), np.array(times[-k:])
        print(f"mean commit, episodes 1-{k}: {first.mean() * 1000:.1f} ms "
              f"(slowest {first.max() * 1000:.0f} ms)")
        print(f"mean commit, episodes {args.episodes - k + 1}-{args.episodes}: {last.mean() * 1000:.1f} ms "
              f"(slowest {last.max() * 1000:.0f} ms)")
        size = sum(f.stat().st_size for f in (root / "ds").rglob("*") if f.is_file())
        print(f"episodes {args.episodes - k + 1}-{args.episodes} / episodes 1-{k}: "
              f"{last.mean() / first.mean():.2f}× (target <= 1.2×); dataset {size / 1e6:.0f} MB, "
              f"{len(times)} commits")
    finally:
        shutil.rmtree(root, ignore_errors=True)


if __name__ == "__main__":
    main()
