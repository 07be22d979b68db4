"""The raw leader stream of one teleoperated episode: every servo reading plus which reading (and which
operator events) each control step used, with the device calibration, so the episode can be re-simulated
exactly (``mgdata teleop replay``).

Stored next to the episode in the dataset as ``meta/teleop/episode_<index>.npz``, committed in the same
transaction as the episode (``DatasetWriter.append_staged(extra=...)``): a zip of ``.npy`` arrays with fixed
timestamps (the same stream gives the same bytes) and a ``header.json``.
"""

from __future__ import annotations

import io
import json
import zipfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from mgdata.errors import DatasetError

STREAM_DIR = "meta/teleop"
_EPOCH = (1980, 1, 1, 0, 0, 0)


def stream_rel(episode_index: int) -> str:
    """The stream file of episode ``episode_index``, relative to the dataset root."""
    return f"{STREAM_DIR}/episode_{episode_index:06d}.npz"


def stream_path(dataset: Path, episode_index: int) -> Path:
    return Path(dataset) / stream_rel(episode_index)


@dataclass(frozen=True)
class LeaderStream:
    """One episode's leader stream.

    Attributes:
        arm: ``gello`` or ``so101``; ``calibration``: the calibration file's JSON text.
        family, task_id, draw_index: which task and which of its teleoperated episodes.
        times: (N,) s since the reader started; ``ticks``: (N, n_motors) int64 readings.
        step_sample: (T,) index into ``ticks`` used at each control step.
        clutch, grip_toggle: (T,) bool operator events at each control step.
    """

    arm: str
    calibration: str
    family: str
    task_id: int
    draw_index: int
    times: np.ndarray
    ticks: np.ndarray
    step_sample: np.ndarray
    clutch: np.ndarray
    grip_toggle: np.ndarray

    def to_bytes(self) -> bytes:
        """The stream file's bytes (the same stream gives the same bytes)."""
        header = {"arm": self.arm, "calibration": self.calibration, "family": self.family,
                  "task_id": self.task_id, "draw_index": self.draw_index}
        out = io.BytesIO()
        with zipfile.ZipFile(out, "w", zipfile.ZIP_DEFLATED) as z:
            z.writestr(zipfile.ZipInfo("header.json", _EPOCH), json.dumps(header, sort_keys=True))
            for name in ("times", "ticks", "step_sample", "clutch", "grip_toggle"):
                buf = io.BytesIO()
                np.save(buf, np.ascontiguousarray(getattr(self, name)), allow_pickle=False)
                info = zipfile.ZipInfo(f"{name}.npy", _EPOCH)
                info.compress_type = zipfile.ZIP_DEFLATED
                z.writestr(info, buf.getvalue())
        return out.getvalue()

    @classmethod
    def load(cls, path: Path) -> LeaderStream:
        try:
            with zipfile.ZipFile(path) as z:
                header = json.loads(z.read("header.json"))
                arrays = {n: np.load(io.BytesIO(z.read(f"{n}.npy")), allow_pickle=False)
                          for n in ("times", "ticks", "step_sample", "clutch", "grip_toggle")}
        except (OSError, KeyError, ValueError, zipfile.BadZipFile) as err:
            raise DatasetError(f"{path}: not a leader stream file: {err}") from None
        return cls(header["arm"], header["calibration"], header["family"], int(header["task_id"]),
                   int(header["draw_index"]), **arrays)
