"""Video files: deterministic streaming encode, packet-copy concatenation and cutting, decoding."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from mgdata.errors import DatasetError
from mgdata.record.synthetic import synthetic_episode, synthetic_schema
from mgdata.record.video import VideoEncoder, VideoSettings, decode, probe, remux
from tests.helpers.record import SMALL, psnr


def _frames(n: int, seed: int = 1, schema=SMALL) -> np.ndarray:
    ep = synthetic_episode(schema, n, seed)
    return np.stack([ep.images(t)["front"] for t in range(n)])


def _encode(path: Path, frames: np.ndarray, settings: VideoSettings | None = None, fps: int = 20) -> Path:
    enc = VideoEncoder(path, frames.shape[2], frames.shape[1], fps, settings or VideoSettings())
    for f in frames:
        enc.add(f)
    assert enc.close() == len(frames)
    return path


@pytest.mark.parametrize("codec", ["h264", "av1"])
def test_encode_is_deterministic_and_faithful(tmp_path: Path, codec: str) -> None:
    frames = _frames(25, schema=synthetic_schema(size=256))  # default settings at the default size
    settings = VideoSettings(codec=codec)
    a = _encode(tmp_path / "a.mp4", frames, settings).read_bytes()
    b = _encode(tmp_path / "b.mp4", frames, settings).read_bytes()
    assert a == b
    assert b"Lavf" not in a  # bitexact: no muxer version string
    decoded = decode(tmp_path / "a.mp4", 0, 25, 20)
    assert decoded.shape == frames.shape
    assert min(psnr(d, f) for d, f in zip(decoded, frames, strict=True)) >= 30.0
    info = probe(tmp_path / "a.mp4", 20)
    assert info.frames == 25 and info.frame_indices.tolist() == list(range(25)) and info.keyframes[0]


def test_concatenate_and_cut_copy_packets_exactly(tmp_path: Path) -> None:
    first, second = _frames(17, seed=1), _frames(26, seed=2)
    a, b = _encode(tmp_path / "a.mp4", first), _encode(tmp_path / "b.mp4", second)
    remux([(a, 0, 17), (b, 0, 26)], tmp_path / "ab.mp4", 20)
    info = probe(tmp_path / "ab.mp4", 20)
    assert info.frame_indices.tolist() == list(range(43))
    assert info.keyframes[17]  # the second segment starts on its own keyframe
    np.testing.assert_array_equal(decode(tmp_path / "ab.mp4", 0, 17, 20), decode(a, 0, 17, 20))
    np.testing.assert_array_equal(decode(tmp_path / "ab.mp4", 17, 26, 20), decode(b, 0, 26, 20))
    remux([(tmp_path / "ab.mp4", 17, 26)], tmp_path / "cut.mp4", 20)
    np.testing.assert_array_equal(decode(tmp_path / "cut.mp4", 0, 26, 20), decode(b, 0, 26, 20))


def test_remux_refuses_bad_cuts_and_mixed_encodings(tmp_path: Path) -> None:
    a = _encode(tmp_path / "a.mp4", _frames(17))
    with pytest.raises(DatasetError, match="not a keyframe"):
        remux([(a, 3, 5)], tmp_path / "x.mp4", 20)
    with pytest.raises(DatasetError, match="expected 30 frames"):
        remux([(a, 0, 30)], tmp_path / "y.mp4", 20)
    big = _encode(tmp_path / "big.mp4", np.zeros((5, 32, 32, 3), np.uint8))
    with pytest.raises(DatasetError, match="different settings"):
        remux([(a, 0, 17), (big, 0, 5)], tmp_path / "z.mp4", 20)


def test_bad_settings_and_files(tmp_path: Path) -> None:
    with pytest.raises(DatasetError, match="codec"):
        VideoSettings(codec="mjpeg")
    with pytest.raises(DatasetError, match="crf"):
        VideoSettings(crf=99)
    junk = tmp_path / "junk.mp4"
    junk.write_bytes(b"\x00" * 1000)
    with pytest.raises(DatasetError, match=r"junk\.mp4"):
        probe(junk, 20)
    good = _encode(tmp_path / "g.mp4", _frames(12)).read_bytes()
    cut = tmp_path / "cut.mp4"
    cut.write_bytes(good[: len(good) // 2])
    with pytest.raises(DatasetError, match=r"cut\.mp4"):
        decode(cut, 0, 12, 20)
