"""``mgdata render``: a dataset re-rendered from its stored physics states (other cameras, size, codec).

The source is recorded from real jar scenes through the real recorder and camera rig; the re-render reads
only the dataset (MJB scenes + physics states)."""

from __future__ import annotations

import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from mgdata.record import layout
from mgdata.record.reader import DatasetReader
from mgdata.record.recorder import Recorder, schema_for
from mgdata.record.rerender import RenderJob, partial_path, rerender
from mgdata.record.validate import validate_dataset
from mgdata.record.writer import DatasetWriter
from mgdata.sim import robot
from mgdata.sim.controller import JointController
from mgdata.sim.renderer import CameraRig
from mgdata.sim.scene import build_scene
from mgdata.tasks.base import draw_task
from mgdata.tasks.recipe import load_recipe
from tests.helpers.cli import mgdata_here
from tests.helpers.record import small_episodes, tree_digest, write_dataset

MGDATA = [str(Path(sys.executable).parent / "mgdata")]
SOURCE_CAMERAS, SIZE, STEPS, TASKS = ("front", "left", "wrist"), 64, 24, (0, 1, 0)


@pytest.fixture(scope="module")
def source(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """Three recorded jar episodes (tasks 0, 1, 0; three 64² cameras): the arm sways while the gripper
    closes half-way through."""
    root = tmp_path_factory.mktemp("rerender") / "src"
    writer = None
    recipe = load_recipe("jar")
    for k, task_id in enumerate(TASKS):
        scene = build_scene(draw_task(recipe, task_id))
        ctl, spec = JointController(scene), scene.task.safety
        with CameraRig(scene, cameras=SOURCE_CAMERAS, size=SIZE) as rig:
            writer = writer or DatasetWriter.create(root, schema_for(scene, spec, rig), spec=spec)
            scene.reset()
            rec = Recorder(scene, spec, writer, cameras=rig)
            rec.start()
            offset = np.array([0.3, -0.2, 0.2, -0.3, 0.1, 0.3, -0.4]) * (1 - 1.6 * k / len(TASKS))
            for t in range(STEPS):
                q = robot.HOME_Q + offset * np.sin(np.pi * t / STEPS)
                action = np.array([*q, float(t >= STEPS // 2)], dtype=np.float32)
                ctl.apply(action)
                ctl.step()
                rec.record(action)
            rec.finish(seed=k, draw_index=k, kept=False)
    assert writer is not None
    writer.record_attempts(5)
    writer.close()
    return root


def test_same_settings_reproduce_the_source_byte_for_byte(source: Path, tmp_path: Path) -> None:
    """Rendering from the stored states draws what the live scene drew: with the source's cameras, size
    and codec the new dataset is the source, file for file (only info.json and the card, README.md, say that
    it was rendered)."""
    out = rerender(RenderJob(source, tmp_path / "same")).out
    ours, theirs = tree_digest(out), tree_digest(source)
    told = (layout.INFO_PATH, layout.CARD_PATH)
    assert {k: v for k, v in ours.items() if k not in told} == \
        {k: v for k, v in theirs.items() if k not in told}
    assert DatasetReader(out).info["mgdata"]["rendered_from"]["source"] == str(source.resolve())
    card = (out / layout.CARD_PATH).read_text(encoding="utf-8")
    assert "Re-rendered by `mgdata render` from the stored physics states" in card
    assert str(source.resolve()) not in card  # a card is the same wherever the dataset lives


def test_224_with_two_cameras_carries_everything_but_the_pictures(source: Path, tmp_path: Path) -> None:
    out = tmp_path / "jar_224"
    proc = subprocess.run([*MGDATA, "render", str(source), "--out", str(out), "--size", "224", "--cameras",
                           "wrist,front"], capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    assert "frames/s" in proc.stdout and not partial_path(out).exists()
    src, new = DatasetReader(source), DatasetReader(out)
    assert new.schema.cameras == ("wrist", "front") and new.schema.image_height == 224
    assert new.num_episodes == src.num_episodes and new.tasks == src.tasks
    assert new.info["mgdata"]["attempts"] == 5 and new.spec == src.spec
    for e in range(src.num_episodes):
        a, b = src.episode(e), new.episode(e)
        for name in ("state", "action", "labels", "dfa_state", "violated", "engaged", "success",
                     "timestamp", "frame_index", "global_index", "physics_state"):
            assert np.array_equal(getattr(a, name), getattr(b, name)), (e, name)
        assert a.meta == b.meta
        assert new.scene_mjb(e) == src.scene_mjb(e)
        big = new.frames(e, "front")
        assert big.shape == (STEPS + 1, 224, 224, 3)
        # the same picture as the source's 64² front camera, at a higher resolution
        small = src.frames(e, "front").astype(np.float64)
        assert np.abs(_pool(big, SIZE) - small).mean() < 12.0, e
    report = validate_dataset(out)
    assert report.ok, report.problems
    check = subprocess.run([*MGDATA, "validate", str(out)], capture_output=True, text=True, timeout=300)
    assert check.returncode == 0, check.stdout + check.stderr


def _pool(images: np.ndarray, size: int) -> np.ndarray:
    import cv2

    return np.stack([cv2.resize(im, (size, size), interpolation=cv2.INTER_AREA) for im in images]).astype(
        np.float64)


def test_an_interrupted_render_continues_to_the_same_bytes(source: Path, tmp_path: Path) -> None:
    whole = rerender(RenderJob(source, tmp_path / "whole", size=32, cameras=("wrist",))).out

    def stop_after_one(done: int, total: int) -> None:
        if done == 1:
            raise KeyboardInterrupt

    out = tmp_path / "cut"
    with pytest.raises(KeyboardInterrupt):
        rerender(RenderJob(source, out, size=32, cameras=("wrist",)), on_episode=stop_after_one)
    assert not out.exists() and DatasetReader(partial_path(out)).num_episodes == 1
    summary = rerender(RenderJob(source, out, size=32, cameras=("wrist",)))
    assert summary.episodes == 2 and summary.total_episodes == 3
    info = layout.INFO_PATH
    assert {k: v for k, v in tree_digest(out).items() if k != info} == \
        {k: v for k, v in tree_digest(whole).items() if k != info}


_ENCODE_LOOP = """
import hashlib, sys
from pathlib import Path
import numpy as np
from mgdata.record.reader import DatasetReader
from mgdata.record.video import VideoEncoder, VideoSettings, decode
reader, out = DatasetReader(Path(sys.argv[1])), Path(sys.argv[2])
frames = np.ascontiguousarray(reader.frames(0, "wrist")[:, 16:48, 16:48])
video = next(Path(sys.argv[1]).glob("videos/observation.images.wrist/*/*.mp4"))
for _ in range(12):
    decode(video, 0, 5, reader.schema.fps)
    enc = VideoEncoder(out, 32, 32, reader.schema.fps, VideoSettings())
    for frame in frames:
        enc.add(frame)
    enc.close()
    print(hashlib.sha256(out.read_bytes()).hexdigest())
"""


def test_the_same_frames_encode_to_the_same_bytes_in_every_process(source: Path, tmp_path: Path) -> None:
    """The cause of the flaky interrupted render: with its AVX-512 code, x264 chose other QPs for the same
    32² wrist frames in some processes and some encodes (5 of 6 processes gave a second digest). Four
    processes, twelve encodes each (after a decode, as a resumed render does), must agree."""
    digests: set[str] = set()
    for k in range(4):
        proc = subprocess.run([sys.executable, "-c", _ENCODE_LOOP, str(source), str(tmp_path / f"{k}.mp4")],
                              capture_output=True, text=True, timeout=300)
        assert proc.returncode == 0, proc.stderr
        digests.update(proc.stdout.split())
    assert len(digests) == 1, digests


def _render(*args: str) -> subprocess.CompletedProcess:
    """``mgdata render ARGS`` refused up front, through the real entry point in this process (the real
    ``mgdata render`` process runs in the tests above)."""
    return mgdata_here("render", *args)


def test_bad_input_is_one_line(source: Path, tmp_path: Path) -> None:
    cases = [
        ((str(tmp_path / "nosuch"), "--out", str(tmp_path / "a")), "no such dataset folder"),
        ((str(source), "--out", str(tmp_path / "b"), "--cameras", "front,ceiling"),
         "unknown camera(s) ceiling; the dataset's scenes have cameras front, left, right, shoulder, wrist"),
        ((str(source), "--out", str(source)), "already exists"),
        ((str(source), "--out", str(tmp_path / "c"), "--size", "4"), "--size 4"),
        ((str(source), "--out", str(tmp_path / "d"), "--codec", "mpeg2"), "mpeg2"),
    ]
    synthetic = write_dataset(tmp_path / "synthetic", small_episodes((5,)))
    cases.append(((str(synthetic), "--out", str(tmp_path / "e")), "stores no physics states"))
    corrupt = shutil.copytree(source, tmp_path / "corrupt")
    (corrupt / layout.INFO_PATH).write_text("{")
    cases.append(((str(corrupt), "--out", str(tmp_path / "f")), "unreadable JSON"))
    for args, message in cases:
        proc = _render(*args)
        assert proc.returncode == 2, (args, proc.stdout, proc.stderr)
        lines = proc.stderr.strip().splitlines()
        assert len(lines) == 1 and lines[0].startswith("error: ") and message in lines[0], (args, proc.stderr)
    for name in "abcdef":
        assert not (tmp_path / name).exists() and not partial_path(tmp_path / name).exists(), name
