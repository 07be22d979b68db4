"""The real-LeRobot oracle, in two halves run by ``scripts/check_lerobot_compat.sh``:

``generate WORK`` (mgdata's venv): writes a v3.0 dataset with mgdata's writer (5 cameras at 256², moving
shapes, labelled negatives included), its smolvla view and v2.1 / pi0 exports, and ground-truth frames; and a
real jar dataset with ``mgdata generate`` (2 kept demos, with labelled negatives) plus frames decoded by
mgdata's own reader.

``check WORK`` (the lerobot venv, offline): loads them with ``LeRobotDataset(..., video_backend="pyav")`` and
checks shapes, dtypes, decoded frames against the recorded ones (PSNR >= 30 dB), ``delta_timestamps``, a
``DataLoader`` epoch, normalisation with ``meta.stats`` through LeRobot's own ``NormalizerProcessorStep``,
the v2.1 exports through LeRobot's ``convert_dataset_v21_to_v30``; and the generated jar dataset: every
frame count, the safety columns, the per-frame MuJoCo state ``sim.physics_state`` (exact float64 in
LeRobot's table, float32 tensors in its items, not a policy input feature), frames identical to mgdata's
reader, a ``DataLoader`` epoch, and its smolvla view (which drops the simulator state). Prints one line per
check; exit 1 if any fails.
"""

from __future__ import annotations

import json
import sys
import time
import warnings
from pathlib import Path

import numpy as np

EPISODES = 6
LENGTH = 60
TRUTH_EVERY = 7  # ground-truth frames kept: every 7th step of every episode and camera
JAR_TRUTH_EVERY = 25  # the generated jar dataset: every 25th frame, decoded by mgdata's reader


def generate(work: Path) -> None:
    from mgdata.record.export import export_dataset
    from mgdata.record.synthetic import SYNTHETIC_SPEC, synthetic_episode, synthetic_schema
    from mgdata.record.writer import DatasetWriter

    schema = synthetic_schema()
    truth: dict[str, np.ndarray] = {}
    with DatasetWriter.create(work / "v30", schema, spec=SYNTHETIC_SPEC) as writer:
        for k in range(EPISODES):
            negative = k % 3 == 2
            ep = synthetic_episode(schema, LENGTH + 7 * k, seed=k, draw_index=k,
                                   violate_at=40 if negative else None)
            for t, frame in enumerate(ep.frames()):
                writer.add_frame(frame)
                if t % TRUTH_EVERY == 0:
                    for cam, img in frame.images.items():
                        truth[f"{k}/{t}/{cam}"] = img
            writer.end_episode(ep.meta)
    np.savez_compressed(work / "truth.npz", **truth)
    export_dataset(work / "v30", work / "smolvla", "smolvla", overview="front")
    export_dataset(work / "v30", work / "v21" / "mgdata_v21", "v2.1")
    export_dataset(work / "v30", work / "v21" / "mgdata_pi0", "pi0", overview="left")

    generate_jar(work / "jar")
    print(f"generated datasets in {work}")


def generate_jar(out: Path) -> None:
    """A real ``mgdata generate`` dataset, and frames of it decoded by mgdata's reader to compare against."""
    from mgdata.generate.run import GenerateJob
    from mgdata.generate.run import generate as run
    from mgdata.record.export import export_dataset
    from mgdata.record.reader import DatasetReader

    summary = run(GenerateJob(family="jar", n=2, out=out, tasks=(0, 1), workers=1, keep_failed=True))
    if summary.total_kept < 2:
        sys.exit(f"mgdata generate kept {summary.total_kept} of 2 jar demos: {summary.stopped}")
    reader = DatasetReader(out)
    truth = {f"{i}/{cam}": reader.frames(i, cam)[::JAR_TRUTH_EVERY]
             for i in range(reader.num_episodes) for cam in reader.schema.cameras}
    truth |= {f"{i}/physics": reader.episode(i).physics_state for i in range(reader.num_episodes)}
    np.savez_compressed(out.with_name("jar_truth.npz"), **truth)
    export_dataset(out, out.with_name("jar_smolvla"), "smolvla")


class Checks:
    def __init__(self) -> None:
        self.failed = 0

    def __call__(self, name: str, ok: bool, detail: str = "") -> None:
        self.failed += not ok
        print(f"{'PASS' if ok else 'FAIL'}  {name}{': ' + detail if detail else ''}", flush=True)


def _psnr(a: np.ndarray, b: np.ndarray) -> float:
    mse = np.mean((a.astype(np.float64) - b.astype(np.float64)) ** 2)
    return float("inf") if mse == 0 else float(10 * np.log10(255.0**2 / mse))


def check(work: Path) -> int:
    import lerobot
    import torch
    from lerobot.configs.types import FeatureType, NormalizationMode
    from lerobot.datasets.lerobot_dataset import LeRobotDataset
    from lerobot.datasets.utils import dataset_to_policy_features
    from lerobot.datasets.v30.convert_dataset_v21_to_v30 import convert_dataset
    from lerobot.processor.converters import batch_to_transition, transition_to_batch
    from lerobot.processor.normalize_processor import NormalizerProcessorStep

    warnings.filterwarnings("ignore", message=".*video decoding and encoding capabilities of torchvision.*")
    ok = Checks()
    print(f"lerobot {lerobot.__version__}, torch {torch.__version__}")
    root = work / "v30"
    info = json.loads((root / "meta/info.json").read_text())
    t0 = time.perf_counter()
    ds = LeRobotDataset("mgdata/compat", root=root, video_backend="pyav")
    ok("load v3.0 dataset", len(ds) == info["total_frames"] and ds.num_episodes == EPISODES,
       f"{len(ds)} frames, {ds.num_episodes} episodes in {time.perf_counter() - t0:.1f} s")

    item = ds[LENGTH + 3]
    expect = {
        "observation.images.front": (torch.float32, (3, 256, 256)),
        "observation.state": (torch.float32, (8,)), "action": (torch.float32, (8,)),
        "safety.labels": (torch.bool, (4,)),
        "safety.dfa_state": (torch.int64, (2,)), "safety.violated": (torch.bool, (2,)),
        "safety.engaged": (torch.bool, ()), "safety.success": (torch.bool, ()),
        "timestamp": (torch.float32, ()), "task_index": (torch.int64, ()),
    }
    wrong = {k: (item[k].dtype, tuple(item[k].shape)) if k in item else "missing"
             for k, (dt, sh) in expect.items()
             if k not in item or item[k].dtype != dt or tuple(item[k].shape) != sh}
    safety = ", ".join(f"{k} {dt}" for k, (dt, _) in list(expect.items())[3:6])
    ok("item shapes and dtypes", not wrong, str(wrong) if wrong else safety)
    task = item["task"]
    ok("task string", isinstance(task, str) and task.startswith("close the jar"), task)

    truth = np.load(work / "truth.npz")
    starts = ds.meta.episodes["dataset_from_index"]
    worst = 99.0
    for key in truth.files:
        k, t, cam = key.split("/")
        frame = ds[int(starts[int(k)]) + int(t)][f"observation.images.{cam}"]
        decoded = (frame.permute(1, 2, 0).numpy() * 255.0).round().astype(np.uint8)
        worst = min(worst, _psnr(decoded, truth[key]))
    ok("decoded frames vs recorded (PSNR >= 30 dB)", worst >= 30.0,
       f"min {worst:.1f} dB over {len(truth.files)} frames")

    horizon = [i / ds.fps for i in range(16)]
    dts = {"observation.images.front": [-0.1, 0.0], "observation.state": [-0.05, 0.0], "action": horizon}
    dsd = LeRobotDataset("mgdata/compat", root=root, video_backend="pyav", delta_timestamps=dts)
    last = dsd[int(starts[1]) - 1]  # last frame of episode 0: the action horizon runs past the end
    ok("delta_timestamps", tuple(last["observation.images.front"].shape) == (2, 3, 256, 256)
       and tuple(last["action"].shape) == (16, 8) and bool(last["action_is_pad"][1:].all())
       and not bool(last["action_is_pad"][0]), "images (2,3,256,256), action (16,8), padding past the end")

    loader = torch.utils.data.DataLoader(
        LeRobotDataset("mgdata/compat", root=root, video_backend="pyav", delta_timestamps=dts),
        batch_size=32, shuffle=True, num_workers=2)
    t0 = time.perf_counter()
    seen, batch = 0, None
    for batch in loader:
        seen += batch["action"].shape[0]
    ok("DataLoader epoch (2 workers)", seen == len(ds), f"{seen} samples in {time.perf_counter() - t0:.1f} s")

    feats = dataset_to_policy_features(ds.meta.features)
    modes = {FeatureType.VISUAL: NormalizationMode.MEAN_STD, FeatureType.STATE: NormalizationMode.QUANTILES,
             FeatureType.ACTION: NormalizationMode.MEAN_STD}
    norm = NormalizerProcessorStep.from_lerobot_dataset(ds, feats, modes)
    out = transition_to_batch(norm(batch_to_transition({k: v for k, v in batch.items() if k in feats})))
    finite = all(torch.isfinite(out[k]).all() for k in feats)
    img_stats = ds.meta.stats["observation.images.front"]["mean"].shape
    ok("meta.stats normalisation (LeRobot NormalizerProcessorStep)", finite and img_stats == (3, 1, 1),
       f"{len(feats)} policy features, image stats {img_stats}, state q01..q99 -> "
       f"[{out['observation.state'].min():.2f}, {out['observation.state'].max():.2f}]")

    view = LeRobotDataset("mgdata/compat-smolvla", root=work / "smolvla", video_backend="pyav")
    top = view[5]["observation.images.top"]
    ok("smolvla view loads", torch.equal(top, ds[5]["observation.images.front"]) and
       "observation.images.wrist" in view[5], "observation.images.top == source front, wrist present")

    for name, key in (("mgdata_v21", "observation.images.front"), ("mgdata_pi0", "image")):
        try:
            convert_dataset(repo_id=name, root=str(work / "v21"), push_to_hub=False)
            conv = LeRobotDataset(name, root=work / "v21" / name, video_backend="pyav")
            src_key = "observation.images.front" if key != "image" else "observation.images.left"
            same = torch.equal(conv[70][key], ds[70][src_key])
            ok(f"v2.1 export {name} via LeRobot's v2.1->v3.0 converter", len(conv) == len(ds) and same,
               f"{len(conv)} frames, frames identical to the source")
        except Exception as err:  # report and continue: this is a test harness
            ok(f"v2.1 export {name} via LeRobot's v2.1->v3.0 converter", False, repr(err))

    check_jar(work, ok)
    print(f"{ok.failed} check(s) failed" if ok.failed else "all checks passed")
    return 1 if ok.failed else 0


def check_jar(work: Path, ok: Checks) -> None:
    """The dataset ``mgdata generate`` wrote: loads, safety columns, frames as mgdata decodes them."""
    import torch
    from lerobot.datasets.lerobot_dataset import LeRobotDataset
    from lerobot.datasets.utils import dataset_to_policy_features

    root = work / "jar"
    info = json.loads((root / "meta/info.json").read_text())
    ds = LeRobotDataset("mgdata/jar", root=root, video_backend="pyav")
    n_props = len(info["features"]["safety.labels"]["names"])
    item = ds[0]
    ok("generated jar dataset loads", len(ds) == info["total_frames"] and ds.num_episodes == 2
       and tuple(item["safety.labels"].shape) == (n_props,) and item["task"].startswith("Close the lid"),
       f"{len(ds)} frames, {ds.num_episodes} episodes, {n_props} propositions, task {item['task']!r}")
    truth = np.load(work / "jar_truth.npz")
    starts = ds.meta.episodes["dataset_from_index"]
    worst, compared = float("inf"), 0
    # LeRobot 0.4.4 hands float64 features out as float32 tensors; its underlying datasets table keeps the
    # exact float64 values (what restoring a frame needs)
    physics = {key: truth[key] for key in truth.files if key.endswith("/physics")}
    width = info["features"]["sim.physics_state"]["shape"][0]
    raw = ds.hf_dataset.with_format(None)
    same = []
    for key, state in physics.items():
        for t in (0, 17):
            i = int(starts[int(key.split("/")[0])]) + t
            same.append(torch.equal(ds[i]["sim.physics_state"], torch.from_numpy(state[t]).float())
                        and np.array_equal(np.asarray(raw[i]["sim.physics_state"], np.float64), state[t]))
    policy = dataset_to_policy_features(ds.meta.features)
    state = item["sim.physics_state"]
    ok("generated jar sim.physics_state", state.dtype == torch.float32 and tuple(state.shape) == (width,)
       and all(same) and "sim.physics_state" not in policy,
       f"({width},) as float32 tensors, exact float64 in hf_dataset (== mgdata's reader), not among the "
       f"{len(policy)} policy features")
    for key in truth.files:
        if key in physics:
            continue
        ep, cam = key.split("/")
        for j, expected in enumerate(truth[key]):
            frame = ds[int(starts[int(ep)]) + j * JAR_TRUTH_EVERY][f"observation.images.{cam}"]
            decoded = (frame.permute(1, 2, 0).numpy() * 255.0).round().astype(np.uint8)
            worst = min(worst, _psnr(decoded, expected))
            compared += 1
    ok("generated jar frames == mgdata reader's (same timestamps)", worst >= 50.0,
       f"{'identical' if worst == float('inf') else f'min {worst:.1f} dB'} over {compared} frames")
    loader = torch.utils.data.DataLoader(ds, batch_size=64, num_workers=2)
    seen = sum(batch["action"].shape[0] for batch in loader)
    ok("generated jar DataLoader epoch", seen == len(ds), f"{seen} samples")
    view = LeRobotDataset("mgdata/jar-smolvla", root=work / "jar_smolvla", video_backend="pyav")
    ok("generated jar smolvla view loads without the simulator state", len(view) == len(ds)
       and "sim.physics_state" not in view[0] and "observation.images.top" in view[0], f"{len(view)} frames")


if __name__ == "__main__":
    if len(sys.argv) != 3 or sys.argv[1] not in ("generate", "check"):
        sys.exit("usage: lerobot_compat.py generate|check WORK_DIR")
    if sys.argv[1] == "generate":
        generate(Path(sys.argv[2]))
    else:
        sys.exit(check(Path(sys.argv[2])))
