"""Video files: streaming encode, packet-level concatenation (no re-encode), probing and decoding (PyAV).

Every episode segment is encoded on its own, starting with a keyframe and with no B-frames (``dts ==
pts``), so segments with the same settings can be concatenated into one mp4 by copying packets. Files are
written with ``fflags=+bitexact`` and a single encoder thread, so the same frames give the same bytes.

On a CPU with AVX-512, x264 is kept to its AVX2 code (``asm=…``): with its AVX-512 code the same frames and
settings gave different bytes from encode to encode (the first frame's QP chosen by the macroblock tree
varied, e.g. 22 or 11, for 32² wrist frames; never with AVX2 or with ``mbtree=0``; docs/scale.md).
"""

from __future__ import annotations

import contextlib
import os
from collections.abc import Iterator, Sequence
from dataclasses import dataclass
from fractions import Fraction
from pathlib import Path

import av
import av.error
import numpy as np

from mgdata.cpu import has_avx512
from mgdata.errors import DatasetError

_ENCODERS = {"h264": "libx264", "av1": "libsvtav1"}
_DEFAULT_CRF = {"h264": 23, "av1": 30}
_DEFAULT_PRESET = {"h264": "veryfast", "av1": "12"}
_MUX_OPTIONS = {"fflags": "+bitexact"}
_X264_AVX2 = "MMX2,SSE2Fast,SSSE3,SSE4.2,AVX,FMA3,BMI2,AVX2"
"""x264's instruction sets without AVX-512 (every AVX-512 CPU has these); x264 asm is otherwise bit-exact
across instruction sets, so this changes speed (~10 % slower encode at 256²), not the bytes."""


@dataclass(frozen=True)
class VideoSettings:
    """Encoder settings, fixed per dataset (segments must match to be concatenated).

    Attributes:
        codec: ``"h264"`` (libx264, default: fast to decode for training) or ``"av1"`` (libsvtav1).
        crf: constant rate factor; ``None`` → 23 for H.264, 30 for AV1 (resolved on construction).
        preset: encoder preset; ``None`` → ``"veryfast"`` (x264) or ``"12"`` (SVT-AV1).
        gop: keyframe interval in frames (random access in a training loader decodes up to ``gop`` frames).
        pix_fmt: stored pixel format.

    Example: ``VideoSettings(codec="av1", crf=32)``.
    """

    codec: str = "h264"
    crf: int | None = None
    preset: str | None = None
    gop: int = 10
    pix_fmt: str = "yuv420p"

    def __post_init__(self) -> None:
        if self.codec not in _ENCODERS:
            raise DatasetError(f"video codec {self.codec!r} is not supported; expected one of "
                               f"{sorted(_ENCODERS)}")
        if self.crf is not None and not 0 <= self.crf <= 63:
            raise DatasetError(f"video crf {self.crf} is out of range; expected 0..63")
        if self.gop < 1:
            raise DatasetError(f"video gop {self.gop} must be >= 1")
        # resolve codec defaults so equal settings compare equal
        object.__setattr__(self, "crf", _DEFAULT_CRF[self.codec] if self.crf is None else int(self.crf))
        preset = _DEFAULT_PRESET[self.codec] if self.preset is None else str(self.preset)
        object.__setattr__(self, "preset", preset)

    @property
    def encoder(self) -> str:
        return _ENCODERS[self.codec]

    def options(self) -> dict[str, str]:
        """libav encoder options: deterministic (one thread) and concatenable (no B-frames)."""
        opts = {"crf": str(self.crf), "preset": self.preset, "g": str(self.gop)}
        if self.codec == "h264":
            # no B-frames (dts == pts: segments concatenate); diamond search + subme 1: ~15 % faster than
            # plain veryfast for ~10 % more bytes (benchmarks/bench_export.py --sweep)
            # asm: x264's AVX-512 path is not deterministic (module docstring)
            params = "me=dia:subme=1" + (f":asm={_X264_AVX2}" if has_avx512() else "")
            opts.update({"bf": "0", "threads": "1", "x264-params": params})
        else:
            opts["svtav1-params"] = "lp=1"
        return opts

    def info(self, fps: int, height: int, width: int) -> dict:
        """The ``info`` block of a video feature in ``meta/info.json``."""
        return {
            "video.height": height,
            "video.width": width,
            "video.codec": self.codec,
            "video.pix_fmt": self.pix_fmt,
            "video.is_depth_map": False,
            "video.fps": fps,
            "video.channels": 3,
            "has_audio": False,
            "video.g": self.gop,
            "video.crf": self.crf,
            "video.preset": self.preset,
        }

    @classmethod
    def from_info(cls, info: dict) -> VideoSettings:
        return cls(codec=info["video.codec"], crf=int(info["video.crf"]), preset=str(info["video.preset"]),
                   gop=int(info["video.g"]), pix_fmt=info["video.pix_fmt"])


class VideoEncoder:
    """Encodes RGB frames into one mp4 as they arrive (memory stays bounded on long episodes)."""

    def __init__(self, path: Path, width: int, height: int, fps: int, settings: VideoSettings) -> None:
        if settings.codec == "av1":
            os.environ.setdefault("SVT_LOG", "1")  # SVT-AV1 prints its banner to stderr otherwise
        self.path = path
        self.frames = 0
        self._shape = (height, width, 3)
        self._container = av.open(str(path), "w", format="mp4", options=_MUX_OPTIONS)
        self._stream = self._container.add_stream(settings.encoder, rate=fps)
        self._stream.width, self._stream.height = width, height
        self._stream.pix_fmt = settings.pix_fmt
        self._stream.options = settings.options()
        self._stream.codec_context.thread_count = 1

    def add(self, rgb: np.ndarray) -> None:
        """Encode one (H, W, 3) uint8 RGB frame."""
        frame = av.VideoFrame.from_ndarray(rgb, format="rgb24")
        frame.pts = self.frames
        for packet in self._stream.encode(frame):
            self._container.mux(packet)
        self.frames += 1

    def close(self) -> int:
        """Flush the encoder and finish the file; returns the number of frames."""
        for packet in self._stream.encode(None):
            self._container.mux(packet)
        self._container.close()
        return self.frames

    def abort(self) -> None:
        """Close without caring about the result and delete the file."""
        with contextlib.suppress(av.error.FFmpegError, ValueError):
            self._container.close()
        self.path.unlink(missing_ok=True)


@dataclass(frozen=True)
class VideoProbe:
    """What demuxing a file (without decoding) tells: size, codec, and each packet's frame index."""

    width: int
    height: int
    codec: str
    frame_indices: np.ndarray
    keyframes: np.ndarray

    @property
    def frames(self) -> int:
        return len(self.frame_indices)


def _open(path: Path) -> av.container.InputContainer:
    try:
        container = av.open(str(path))
    except (av.error.FFmpegError, OSError) as err:
        raise DatasetError(f"{path}: cannot open video ({err})") from err
    if not container.streams.video:
        container.close()
        raise DatasetError(f"{path}: no video stream")
    return container


class _FrameClock:
    """Frame index of a timestamp in a stream's time base, in integer arithmetic (per packet: hot)."""

    def __init__(self, time_base: Fraction, fps: int) -> None:
        self._num = time_base.numerator * fps
        self._den = time_base.denominator

    def __call__(self, pts: int) -> int:
        return (2 * pts * self._num + self._den) // (2 * self._den)  # round half up


def probe(path: Path, fps: int) -> VideoProbe:
    """Demux every packet of ``path``; corrupt or truncated files raise :class:`DatasetError`."""
    with _open(path) as container:
        stream = container.streams.video[0]
        clock = _FrameClock(stream.time_base, fps)
        idx, key = [], []
        try:
            for packet in container.demux(stream):
                if packet.pts is None:
                    continue
                idx.append(clock(packet.pts))
                key.append(packet.is_keyframe)
        except av.error.FFmpegError as err:
            raise DatasetError(f"{path}: corrupt video ({err})") from err
        return VideoProbe(stream.width, stream.height, stream.codec_context.name,
                          np.asarray(idx, dtype=np.int64), np.asarray(key, dtype=bool))


def _decoded(path: Path, start: int, count: int, fps: int) -> Iterator[av.VideoFrame]:
    """Frames ``start .. start+count-1`` in order; anything missing or out of order raises."""
    with _open(path) as container:
        stream = container.streams.video[0]
        clock = _FrameClock(stream.time_base, fps)
        seen = 0
        try:
            if start > 0:
                container.seek(int(Fraction(start, fps) / stream.time_base), stream=stream, backward=True,
                               any_frame=False)
            for frame in container.decode(stream):
                index = clock(frame.pts)
                if index < start:
                    continue
                if index != start + seen:
                    raise DatasetError(f"{path}: expected frame {start + seen}, decoded frame {index}")
                yield frame
                seen += 1
                if seen == count:
                    break
        except av.error.FFmpegError as err:
            raise DatasetError(f"{path}: corrupt video ({err})") from err
    if seen != count:
        raise DatasetError(f"{path}: expected {count} frames from frame {start}, decoded {seen}")


def decode(path: Path, start: int, count: int, fps: int) -> np.ndarray:
    """Decode frames ``start .. start+count-1`` of ``path`` as (count, H, W, 3) uint8 RGB."""
    frames = [f.to_ndarray(format="rgb24") for f in _decoded(path, start, count, fps)]
    return np.stack(frames) if frames else np.zeros((0, 0, 0, 3), np.uint8)


def check_decodes(path: Path, count: int, fps: int) -> None:
    """Decode all ``count`` frames of ``path`` (without converting them), raising on any failure."""
    for _ in _decoded(path, 0, count, fps):
        pass


def remux(parts: Sequence[tuple[Path, int, int]], out: Path, fps: int) -> None:
    """Concatenate frame ranges ``(path, start, count)`` of encoded files into ``out`` without re-encoding.

    Each range must start at a keyframe and all inputs must share the encoder settings (same codec
    extradata); output frames are renumbered 0, 1, 2, … at ``fps``.
    """
    container = av.open(str(out), "w", format="mp4", options=_MUX_OPTIONS)
    try:
        stream = None
        extradata: bytes | None = None
        offset = 0
        for path, start, count in parts:
            with _open(path) as source:
                src = source.streams.video[0]
                if stream is None:
                    # opaque: reuse the source's codec object (the AV1 decoder libdav1d has no encoder twin)
                    stream = container.add_stream_from_template(src, opaque=True)
                    stream.time_base = Fraction(1, fps)
                    extradata = src.codec_context.extradata
                elif src.codec_context.extradata != extradata:
                    raise DatasetError(f"{path}: encoded with different settings than the file it is "
                                       "appended to")
                copied = _copy_range(source, src, container, stream, start, count, offset, fps, path)
            if copied != count:
                raise DatasetError(f"{path}: expected {count} frames from frame {start}, found {copied}")
            offset += count
    finally:
        container.close()


def _copy_range(source: av.container.InputContainer, src: av.VideoStream,
                container: av.container.OutputContainer, stream: av.VideoStream,
                start: int, count: int, offset: int, fps: int, path: Path) -> int:
    clock = _FrameClock(src.time_base, fps)
    unit = Fraction(1, fps)
    copied = 0
    try:
        if start > 0:
            source.seek(int(Fraction(start, fps) / src.time_base), stream=src, backward=True, any_frame=False)
        for packet in source.demux(src):
            if packet.pts is None:
                continue
            index = clock(packet.pts)
            if index < start:
                continue
            if index >= start + count:
                break
            if index != start + copied:
                raise DatasetError(f"{path}: frame {start + copied} missing (found frame {index})")
            if copied == 0 and not packet.is_keyframe:
                raise DatasetError(f"{path}: frame {start} is not a keyframe; cannot cut there")
            packet.stream = stream
            packet.time_base = unit
            packet.pts = packet.dts = offset + copied
            packet.duration = 1
            container.mux(packet)
            copied += 1
    except av.error.FFmpegError as err:
        raise DatasetError(f"{path}: corrupt video ({err})") from err
    return copied
