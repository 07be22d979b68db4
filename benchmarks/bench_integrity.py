"""Cost of "resume checks what it appends to": ``DatasetWriter.open`` of a 1,000-episode dataset with and
without the checksum check (``mgdata.record.integrity.check_intact``), and the check's throughput.

Synthetic episodes (``mgdata.record.synthetic``, a physics-state column as wide as the jar scene's, five
cameras) are staged once and appended ``--episodes`` times with ``DatasetWriter.append_staged``; then the
dataset is opened ``--repeats`` times each way (the page cache warm, as on a resume right after a run) and
once more after dropping this dataset's pages from the cache (``posix_fadvise DONTNEED``: a resume after a
reboot reads every byte from disk). The check reads every byte once, so its cost is the dataset's size over
the hash throughput; the benchmark prints both, and the cost for a jar-sized dataset of the same episode
count at the measured rate.

Run: ``.venv/bin/python benchmarks/bench_integrity.py [--episodes 1000] [--length 100] [--size 64]``
"""

from __future__ import annotations

import argparse
import os
import shutil
import statistics
import tempfile
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

from mgdata.record import integrity
from mgdata.record import writer as writer_module
from mgdata.record.metafiles import read_info
from mgdata.record.staging import EpisodeStager
from mgdata.record.synthetic import SYNTHETIC_SPEC, synthetic_episode, synthetic_schema
from mgdata.record.writer import DatasetWriter

PHYSICS_WIDTH = 78
JAR_MB_PER_EPISODE = 1.5
"""A kept jar episode with five 256² cameras: ~60 MB per 40 episodes (README)."""


def stage(root: Path, length: int, size: int, distinct: int = 4) -> list[Path]:
    schema = replace(synthetic_schema(size=size), physics_state_size=PHYSICS_WIDTH)
    out = []
    for k in range(distinct):
        ep = synthetic_episode(synthetic_schema(size=size), length, seed=k, draw_index=k)
        rng = np.random.default_rng(k)
        physics = rng.normal(size=(length, PHYSICS_WIDTH))
        stager = EpisodeStager(root / f"staged-{k}", schema)
        stager.set_scene(bytes(rng.integers(0, 255, 4096, dtype=np.uint8)))
        for t, frame in enumerate(ep.frames()):
            stager.add_frame(replace(frame, physics_state=physics[t]))
        stager.end_episode(ep.meta)
        out.append(stager.path)
    return out


def drop_cache(root: Path) -> None:
    for path in root.rglob("*"):
        if path.is_file():
            fd = os.open(path, os.O_RDONLY)
            try:
                os.fsync(fd)
                os.posix_fadvise(fd, 0, 0, os.POSIX_FADV_DONTNEED)
            finally:
                os.close(fd)


def timed_open(root: Path, check: bool) -> float:
    original = writer_module.check_intact
    if not check:
        writer_module.check_intact = lambda root, doing="": None  # type: ignore[assignment]
    try:
        t0 = time.perf_counter()
        DatasetWriter.open(root).close()
        return time.perf_counter() - t0
    finally:
        writer_module.check_intact = original


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--episodes", type=int, default=1000)
    parser.add_argument("--length", type=int, default=100, help="frames per episode")
    parser.add_argument("--size", type=int, default=64, help="image side")
    parser.add_argument("--repeats", type=int, default=3)
    args = parser.parse_args()
    tmp = Path(tempfile.mkdtemp(prefix="bench_integrity_"))
    try:
        staged = stage(tmp / "staged", args.length, args.size)
        schema = replace(synthetic_schema(size=args.size), physics_state_size=PHYSICS_WIDTH)
        root = tmp / "ds"
        t0 = time.perf_counter()
        with DatasetWriter.create(root, schema, spec=SYNTHETIC_SPEC) as w:
            for e in range(args.episodes):
                copy = tmp / "copy"
                shutil.copytree(staged[e % len(staged)], copy)
                w.append_staged(copy)
        build = time.perf_counter() - t0
        size_mb = sum(p.stat().st_size for p in root.rglob("*") if p.is_file()) / 1e6
        files = len(read_info(root / "meta/info.json")["mgdata"]["sha256"])
        print(f"dataset: {args.episodes} episodes x {args.length} frames, 5 cameras at {args.size}², "
              f"{size_mb:.0f} MB in {files} checksummed files (built in {build:.0f} s)")
        plain = [timed_open(root, check=False) for _ in range(args.repeats)]
        checked = [timed_open(root, check=True) for _ in range(args.repeats)]
        t0 = time.perf_counter()
        integrity.check_intact(root)
        check_only = time.perf_counter() - t0
        drop_cache(root)
        t0 = time.perf_counter()
        integrity.check_intact(root)
        cold = time.perf_counter() - t0
        rate = size_mb / check_only
        print(f"DatasetWriter.open without the check: {statistics.median(plain):.2f} s (median of "
              f"{args.repeats})")
        print(f"DatasetWriter.open with the check:    {statistics.median(checked):.2f} s (median of "
              f"{args.repeats})")
        print(f"the check alone: {check_only:.2f} s warm cache ({rate:.0f} MB/s), {cold:.2f} s after "
              "dropping "
              "the page cache")
        jar_mb = args.episodes * JAR_MB_PER_EPISODE
        print(f"a jar dataset of {args.episodes} episodes (~{jar_mb:.0f} MB, five 256² cameras): "
              f"~{jar_mb / rate:.1f} s at the warm rate")
    finally:
        shutil.rmtree(tmp, ignore_errors=True)


if __name__ == "__main__":
    main()
