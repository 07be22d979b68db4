"""Append benchmark: the commit time of one episode as the dataset grows (target of issue 16: the commit at
episode 1,000 within 1.2× of the one at episode 1).

Synthetic episodes go through the real writer: a few distinct episodes (jar-like length, five cameras, a
physics-state column as wide as the jar scene's) are staged once (encoded), then appended over and over
with ``DatasetWriter.append_staged`` (the exact call ``mgdata generate`` commits with; each append copies the
staged folder first, outside the timing). A commit rewrites the current data and episodes files, which
start afresh every ``EPISODES_PER_FILE`` episodes (``mgdata.record.layout``), so its cost is a sawtooth of
that period: the benchmark prints the mean commit time over the first period (episodes 1-20) and over the
last one (episodes 981-1,000 of ``--episodes 1000``), their ratio, and the slowest commit of each.

``--scenes N``: every episode brings a new compiled scene (a real 5.8 MB jar MJB of a layout of its own, as
a dataset with one layout per episode has), so each commit also adds a scene: the benchmark prints the
scene's part of the commit (coding the delta and rewriting the last scenes file, which starts afresh every
``SCENES_PER_FILE`` scenes) at scene 1 and over the first and the last file period, the whole commit's mean
over the same periods, and the writer process's resident memory (after scene 1, half-way and at the end,
and its peak). The MJBs are built in a helper process, so the figures are the writer's own.

Run: ``.venv/bin/python benchmarks/bench_append.py [--episodes 1000] [--length 650]``
     ``MUJOCO_GL=egl .venv/bin/python benchmarks/bench_append.py --scenes 500 --length 100``
"""

from __future__ import annotations

import argparse
import multiprocessing
import shutil
import tempfile
import time
from collections.abc import Callable
from dataclasses import replace
from pathlib import Path

import numpy as np

from mgdata.record.layout import EPISODES_PER_FILE, SCENES_PER_FILE
from mgdata.record.scenes import SceneAppender
from mgdata.record.staging import SCENE_MJB, EpisodeStager
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


def jar_scene(k: int) -> bytes:
    """The ``k``-th distinct jar layout's compiled scene (MJB): task ``k mod count``, a draw of its own (the
    next one where the placer rejects it); run in the helper process."""
    from mgdata.record.physics import model_bytes
    from mgdata.sim.scene import build_scene
    from mgdata.tasks.base import draw_task
    from mgdata.tasks.placer import LayoutRejected
    from mgdata.tasks.recipe import load_recipe

    recipe = load_recipe("jar")
    task, draw = k % recipe.tasks.count, k // recipe.tasks.count
    while True:
        try:
            return model_bytes(build_scene(draw_task(recipe, task, draw)).model)
        except LayoutRejected:
            draw += 100_000  # far past the draws of other k


def _memory(key: str) -> float:
    """``VmRSS`` or ``VmHWM`` (peak) of this process, MB."""
    for line in Path("/proc/self/status").read_text().splitlines():
        if line.startswith(key + ":"):
            return int(line.split()[1]) / 1024
    return float("nan")


def _timed(method: Callable, into: list[float]) -> Callable:
    def wrapper(*args: object) -> object:
        t0 = time.perf_counter()
        try:
            return method(*args)
        finally:
            into.append(time.perf_counter() - t0)
    return wrapper


def bench_scenes(root: Path, staged: list[Path], n: int, size: int) -> None:
    """``n`` commits, each adding a new jar scene (module docstring)."""
    schema = replace(synthetic_schema(size=size), physics_state_size=PHYSICS_WIDTH)
    parts: list[float] = []  # this commit's SceneAppender.with_scene + write (the scene's part)
    SceneAppender.with_scene = _timed(SceneAppender.with_scene, parts)  # type: ignore[method-assign]
    SceneAppender.write = _timed(SceneAppender.write, parts)  # type: ignore[method-assign]
    commits, scene_part, rss = [], [], []
    with multiprocessing.get_context("spawn").Pool(1) as helper, \
            DatasetWriter.create(root / "ds", schema, spec=SYNTHETIC_SPEC) as writer:
        for e in range(n):
            mjb = helper.apply(jar_scene, (e,))
            copy = shutil.copytree(staged[e % DISTINCT], root / "copy")
            (copy / SCENE_MJB).write_bytes(mjb)
            del mjb
            parts.clear()
            t0 = time.perf_counter()
            writer.append_staged(copy)
            commits.append(time.perf_counter() - t0)
            scene_part.append(sum(parts))
            rss.append(_memory("VmRSS"))
            if (e + 1) % 50 == 0:
                print(f"  {e + 1} scenes, last commit {commits[-1] * 1000:.0f} ms (scene part "
                      f"{scene_part[-1] * 1000:.0f} ms), writer RSS {rss[-1]:.0f} MB", flush=True)
    files = sorted((root / "ds/meta/scenes").rglob("*.parquet"))
    k = min(SCENES_PER_FILE, n)
    first, last = slice(0, k), slice(n - k, n)

    def ms(xs: list[float]) -> str:
        return f"{np.mean(xs) * 1000:.0f} ms"

    print(f"{n} commits, each with a new jar scene; {len(files)} scenes files, "
          f"{sum(f.stat().st_size for f in files) / 1e6:.1f} MB")
    print(f"  the new scene's part of the commit (delta + rewrite of the last scenes file): scene 1 "
          f"{scene_part[0] * 1000:.0f} ms (a whole scene); scenes 2-{k} {ms(scene_part[1:k])} "
          f"(slowest {max(scene_part[1:k]) * 1000:.0f} ms); scenes {n - k + 1}-{n} {ms(scene_part[last])} "
          f"(slowest {max(scene_part[last]) * 1000:.0f} ms)")
    print(f"  whole commit: scenes 1-{k} {ms(commits[first])}, scenes {n - k + 1}-{n} {ms(commits[last])}")
    print(f"  writer RSS: after scene 1 {rss[0]:.0f} MB, scene {n // 2} {rss[n // 2 - 1]:.0f} MB, scene {n} "
          f"{rss[-1]:.0f} MB; peak (VmHWM, staging included) {_memory('VmHWM'):.0f} MB")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--episodes", type=int, default=1000)
    parser.add_argument("--length", type=int, default=650, help="frames per episode (jar: ~600-700)")
    parser.add_argument("--size", type=int, default=64, help="image side (the videos' size matters little)")
    parser.add_argument("--scenes", type=int, default=0, help="instead: this many commits, each with a new "
                        "jar scene")
    args = parser.parse_args()
    root = Path(tempfile.mkdtemp(prefix="bench_append_"))
    try:
        staged = stage(root, args.length, args.size)
        if args.scenes:
            bench_scenes(root, staged, args.scenes, args.size)
            return
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
