"""Dataset writer and validator benchmark (prints figures; targets from issue 5).

- writer throughput in five-camera frames/s at 256² on one core (target >= 250/s with H.264), split into
  recording (encode + histograms, while frames arrive) and commit (the per-episode append);
- how the per-episode commit grows with the current file sizes (files are rewritten per episode);
- ``validate`` time for a 40-episode dataset (target <= 30 s), default and ``--decode-all``;
- ``--sweep``: x264 preset / GOP choices (encode only) with size and PSNR, to justify the defaults;
- the storage cost of self-contained datasets (issue 8) on a real ``mgdata generate`` jar dataset
  (``--jar-demos``, 0 to skip): ``sim.physics_state`` bytes per frame as stored (parquet-compressed) and the
  compiled scenes (``meta/scenes/``), each as a share of the dataset.

Run: ``.venv/bin/python benchmarks/bench_export.py [--episodes 40 --length 250 --codec h264 --sweep
--jar-demos 4]``
"""

from __future__ import annotations

import argparse
import os
import shutil
import tempfile
import time
from pathlib import Path

import numpy as np
import pyarrow.parquet as pq

from mgdata.record.synthetic import SYNTHETIC_SPEC, synthetic_episode, synthetic_schema
from mgdata.record.validate import validate_dataset
from mgdata.record.video import VideoEncoder, VideoSettings, decode
from mgdata.record.writer import DatasetWriter


def _psnr(a: np.ndarray, b: np.ndarray) -> float:
    return float(10 * np.log10(255.0**2 / max(np.mean((a.astype(np.float64) - b) ** 2), 1e-12)))


def bench_writer(root: Path, episodes: int, length: int, codec: str) -> None:
    schema = synthetic_schema()  # 5 cameras, 256x256, 20 Hz
    eps = [synthetic_episode(schema, length, seed=k, draw_index=k) for k in range(episodes)]
    # pre-render one episode's images so the benchmark times the writer, not the frame generator
    images = [eps[0].images(t) for t in range(length)]
    record_s = commit_s = 0.0
    commits = []
    cpu0 = time.process_time()
    with DatasetWriter.create(root, schema, spec=SYNTHETIC_SPEC, codec=codec) as writer:
        for ep in eps:
            t0 = time.perf_counter()
            for frame in ep.frames(images):
                writer.add_frame(frame)
            t1 = time.perf_counter()
            writer.end_episode(ep.meta)
            t2 = time.perf_counter()
            record_s += t1 - t0
            commit_s += t2 - t1
            commits.append(t2 - t1)
    cpu = time.process_time() - cpu0
    frames = episodes * length
    size = sum(p.stat().st_size for p in root.rglob("*") if p.is_file())
    print(f"writer ({codec}, 5 cameras 256x256, {episodes} episodes x {length} frames, one core)")
    print(f"  recording (encode + stats)  {frames / record_s:7.0f} five-camera frames/s")
    print(f"  end to end (incl. commits)  {frames / (record_s + commit_s):7.0f} five-camera frames/s "
          f"(CPU {frames / cpu:.0f}/CPU-s)")
    print(f"  commit per episode          first {commits[0] * 1e3:.0f} ms, last {commits[-1] * 1e3:.0f} ms "
          f"(mean {np.mean(commits) * 1e3:.0f} ms; grows with the current file sizes)")
    per_frame = size / frames / 5 / 1e3
    print(f"  dataset size                {size / 1e6:.1f} MB ({per_frame:.2f} KB per camera frame)")
    reader_frames = decode(root / "videos/observation.images.front/chunk-000/file-000.mp4", 0, length, 20)
    worst = min(_psnr(reader_frames[t], images[t]["front"]) for t in range(length))
    print(f"  decoded PSNR (episode 0)    min {worst:.1f} dB")


def bench_validate(root: Path) -> None:
    for decode_all in (False, True):
        t0 = time.perf_counter()
        report = validate_dataset(root, decode_all=decode_all)
        dt = time.perf_counter() - t0
        flag = " --decode-all" if decode_all else ""
        print(f"validate{flag:13s} {dt:6.2f} s for {report.episodes} episodes / {report.frames} frames "
              f"({'ok' if report.ok else f'{len(report.problems)} problems'})")


def _column_bytes(root: Path, key: str) -> int:
    """Stored (compressed) bytes of one feature over every data file."""
    total = 0
    for path in root.glob("data/*/*.parquet"):
        meta = pq.ParquetFile(path).metadata
        for g in range(meta.num_row_groups):
            for c in range(meta.num_columns):
                col = meta.row_group(g).column(c)
                if col.path_in_schema.split(".list.")[0] == key:
                    total += col.total_compressed_size
    return total


def bench_physics(work: Path, demos: int) -> None:
    """The overhead of the physics state and scenes in a real generated jar dataset."""
    from mgdata.generate.run import GenerateJob, generate
    from mgdata.record import layout
    from mgdata.record.reader import DatasetReader
    from mgdata.record.scenes import Scenes

    out = work / "jar"
    summary = generate(GenerateJob(family="jar", n=demos, out=out, tasks=tuple(range(demos)), workers=1))
    reader = DatasetReader(out)
    frames, width = reader.num_frames, reader.schema.physics_state_size
    size = sum(p.stat().st_size for p in out.rglob("*") if p.is_file())
    state = _column_bytes(out, layout.PHYSICS_STATE)
    scenes = Scenes.read(out)
    scenes_file = sum((out / f).stat().st_size for f in scenes.files)
    rows = scenes.rows
    first = next(r.size for r in rows if r.base is None)
    print(f"self-contained jar dataset ({summary.total_kept} kept demos of {len(rows)} tasks, {frames} "
          f"frames, 5 cameras {reader.schema.image_width}², {size / 1e6:.2f} MB)")
    print(f"  sim.physics_state             {width} float64 = {8 * width} B raw, {state / frames:.0f} B per "
          f"frame stored ({100 * state / size:.1f} % of the dataset)")
    whole = sum(1 for r in rows if r.base is None)
    print(f"  scenes (meta/scenes/, {len(scenes.files)} files)  {scenes_file / 1e6:.2f} MB for {len(rows)} "
          f"tasks, {whole} whole + {len(rows) - whole} XOR deltas (MJB {first / 1e6:.1f} MB per task raw; "
          f"{100 * scenes_file / size:.1f} % of the dataset)")
    t0 = time.perf_counter()
    report = validate_dataset(out)
    print(f"  validate (scenes decoded and loaded) {time.perf_counter() - t0:.2f} s "
          f"({'ok' if report.ok else report.problems})")


def sweep(length: int) -> None:
    schema = synthetic_schema(cameras=("front",))
    ep = synthetic_episode(schema, length, seed=0)
    frames = [ep.images(t)["front"] for t in range(length)]
    print("x264 choices, one stream, encode only (CPU frames/s | bytes/frame | min PSNR)")
    tmp = Path(tempfile.mkdtemp())
    for preset in ("medium", "veryfast", "superfast", "ultrafast"):
        for gop in (2, 10, 20):
            settings = VideoSettings(preset=preset, gop=gop)
            path = tmp / f"{preset}-{gop}.mp4"
            c0 = time.process_time()
            enc = VideoEncoder(path, 256, 256, 20, settings)
            for f in frames:
                enc.add(f)
            enc.close()
            cpu = time.process_time() - c0
            dec = decode(path, 0, length, 20)
            worst = min(_psnr(d, f) for d, f in zip(dec, frames, strict=True))
            size = path.stat().st_size / length
            label = f"preset {preset:9s} g {gop:2d}"
            print(f"  {label}: {length / cpu:6.0f} fps | {size:5.0f} B | {worst:.1f} dB")
    shutil.rmtree(tmp)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--episodes", type=int, default=40)
    parser.add_argument("--length", type=int, default=250)
    parser.add_argument("--codec", default="h264", choices=["h264", "av1"])
    parser.add_argument("--sweep", action="store_true")
    parser.add_argument("--core", type=int, default=0, help="CPU core to pin to")
    parser.add_argument("--jar-demos", type=int, default=4, help="kept jar demos for the self-contained "
                        "storage figures (0: skip)")
    args = parser.parse_args()
    os.sched_setaffinity(0, {args.core})
    root = Path(tempfile.mkdtemp()) / "bench"
    try:
        bench_writer(root, args.episodes, args.length, args.codec)
        bench_validate(root)
        if args.sweep:
            sweep(args.length)
        if args.jar_demos:
            bench_physics(root.parent, args.jar_demos)
    finally:
        shutil.rmtree(root.parent)


if __name__ == "__main__":
    main()
