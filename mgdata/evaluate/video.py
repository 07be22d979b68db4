"""Rollout videos: the cameras the policy saw, side by side, with ``mgdata preview``'s safety panel.

One mp4 per rollout (``<out>/videos/<family>_task_NNNN_<condition>_seed<S>.mp4``), 20 fps, frame ``t``
showing the observation after ``t`` actions and the monitor's reading of it.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from mgdata.generate.preview import safety_panel
from mgdata.record.episode import Frame
from mgdata.record.video import VideoEncoder, VideoSettings
from mgdata.sim.scene import Scene


def write_rollout_video(path: Path, images: Sequence[Mapping[str, np.ndarray]], frames: Sequence[Frame],
                        scene: Scene, meta: Mapping[str, Any], fps: int = 20) -> Path:
    """Encode ``images[t]`` (camera → RGB) next to frame ``t``'s safety panel, for each recorded step."""
    spec = scene.task.safety
    propositions = spec.proposition_names
    constraints = tuple(c.id for c in spec.constraints)
    n = min(len(images), len(frames))
    if n == 0:
        return path
    size = next(iter(images[0].values())).shape[0]
    cells = len(images[0]) + 1
    path.parent.mkdir(parents=True, exist_ok=True)
    encoder = VideoEncoder(path, cells * size, size, fps, VideoSettings(gop=fps))
    try:
        for t in range(n):
            f = frames[t]
            header = [f"{meta['family']} task {meta['task_id']} {meta['condition']}", f"step {t}/{n - 1}"]
            panel = safety_panel(size, header, f.engaged, f.success, f.labels, f.violated, propositions,
                                 constraints)
            encoder.add(np.ascontiguousarray(np.concatenate([*images[t].values(), panel], axis=1)))
        encoder.close()
    except BaseException:
        encoder.abort()
        raise
    return path
