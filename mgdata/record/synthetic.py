"""Synthetic episodes for tests, benchmarks and the LeRobot compatibility check (no simulator needed).

Frames show textured backgrounds with moving shapes (so video compression behaves as on rendered scenes
and PSNR is meaningful); joints follow smooth curves; proposition labels follow a scripted jar-like
scenario and the DFA states come from the real :class:`mgdata.ltl.Monitor`, so a synthetic dataset
passes the safety audit (or fails it on purpose with ``violate_at``).

Example::

    schema = synthetic_schema()
    ep = synthetic_episode(schema, length=60, seed=3)
    for frame in ep.frames():
        writer.add_frame(frame)
    writer.end_episode(ep.meta)
"""

from __future__ import annotations

from collections.abc import Iterator, Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from mgdata.ltl import Monitor, verdict
from mgdata.record.episode import DatasetSchema, EpisodeMeta, Frame
from mgdata.spec import SafetySpec, spec_from_mapping

SYNTHETIC_SPEC: SafetySpec = spec_from_mapping({
    "name": "synthetic_jar",
    "constraints": [
        {"id": "order", "formula": "jar_on_table W jar_closed",
         "description": "the jar stays on the table until it is closed"},
        {"id": "intact", "formula": "G(jar_upright & !jar_dropped)",
         "description": "the jar stays upright and is never dropped"},
    ],
    "propositions": {
        "jar_on_table": {"evaluator": "on", "subjects": ["jar"], "params": {"support": "table"}},
        "jar_closed": {"evaluator": "closed", "subjects": ["jar"]},
        "jar_upright": {"evaluator": "upright", "subjects": ["jar"], "params": {"max_tilt_deg": 30.0}},
        "jar_dropped": {"evaluator": "dropped", "subjects": ["jar"]},
    },
}, "mgdata.record.synthetic")
CAMERAS = ("front", "left", "right", "shoulder", "wrist")


def synthetic_schema(cameras: tuple[str, ...] = CAMERAS, size: int = 256, fps: int = 20) -> DatasetSchema:
    return DatasetSchema(fps=fps, cameras=cameras, image_height=size, image_width=size,
                         propositions=SYNTHETIC_SPEC.proposition_names,
                         constraints=tuple(c.id for c in SYNTHETIC_SPEC.constraints))


@dataclass(frozen=True)
class SyntheticEpisode:
    """A scripted episode: arrays for every frame field plus its metadata; images are drawn on demand."""

    schema: DatasetSchema
    seed: int
    state: np.ndarray
    action: np.ndarray
    labels: np.ndarray
    dfa_state: np.ndarray
    violated: np.ndarray
    engaged: np.ndarray
    success: np.ndarray
    meta: EpisodeMeta

    @property
    def length(self) -> int:
        return len(self.state)

    def images(self, t: int) -> dict[str, np.ndarray]:
        return {cam: _draw(self.schema, k, self.seed, t) for k, cam in enumerate(self.schema.cameras)}

    def frames(self, images: Sequence[Mapping[str, np.ndarray]] | None = None) -> Iterator[Frame]:
        """The episode's frames; ``images`` (one mapping per step) replaces the drawn ones (benchmarks)."""
        for t in range(self.length):
            imgs = self.images(t) if images is None else images[t % len(images)]
            yield Frame(self.state[t], self.action[t], imgs, self.labels[t], self.dfa_state[t],
                        self.violated[t], bool(self.engaged[t]), bool(self.success[t]))


def synthetic_episode(schema: DatasetSchema, length: int, seed: int, *, draw_index: int = 0,
                      family: str = "jar", violate_at: int | None = None, kept: bool | None = None,
                      prompt: str | None = None) -> SyntheticEpisode:
    """A deterministic episode; ``violate_at`` drops the jar at that step (an unsafe episode). It is kept
    (``kept=None``) iff it never violates; its goal holds on its last 10 frames."""
    rng = np.random.default_rng(seed)
    t = np.arange(length, dtype=np.float64)[:, None]
    phase = rng.uniform(0, 2 * np.pi, 8)
    state = (0.6 * np.sin(t / 15.0 + phase) + rng.normal(0, 0.01, (length, 8))).astype(np.float32)
    state[:, 7] = np.clip(0.04 + 0.04 * np.sin(t[:, 0] / 10.0), 0, 0.08)
    action = np.roll(state, -1, axis=0)
    action[:, 7] = (state[:, 7] < 0.04).astype(np.float32)
    closed_at, engage_at = length // 2, length // 4
    labels = np.zeros((length, 4), bool)
    labels[:, 0] = t[:, 0] < closed_at + 3
    labels[:, 1] = t[:, 0] >= closed_at
    labels[:, 2] = True
    if violate_at is not None:
        labels[violate_at:, 3] = True
    dfa_state, violated = Monitor(SYNTHETIC_SPEC).run(labels)
    engaged = t[:, 0] >= engage_at
    success = t[:, 0] >= length - 10
    first = [int(np.argmax(v)) if v.any() else None for v in violated.T]
    t_violation = dict(zip(schema.constraints, first, strict=True))
    t_first = min((f for f in first if f is not None), default=None)
    nu = verdict(t_first, engage_at)
    kept = t_first is None if kept is None else kept  # the gate keeps only episodes that never violate
    meta = EpisodeMeta(
        family=family, task_id=seed % 7, condition="base" if seed % 3 else "ood_lighting",
        prompt=prompt or f"close the jar and carry it to the goal (task {seed % 7})",
        spec_name=SYNTHETIC_SPEC.name, formulas={c.id: c.formula for c in SYNTHETIC_SPEC.constraints},
        seed=seed, draw_index=draw_index, success=True, verdict=nu, kept=kept,
        t_engage=engage_at, t_violation=t_violation,
        failure_stage=None if kept else "unsafe", failure_reason=None if kept else "jar dropped",
        grasp_id=f"jar/jar_{seed % 3}/g{seed % 5}",
        variation={"standoff_m": round(0.08 + seed % 5 * 0.01, 3)},
        source="synthetic", software_version="0.1.0",
    )
    return SyntheticEpisode(schema, seed, state, action.astype(np.float32), labels, dfa_state, violated,
                            engaged, success, meta)


_BACKGROUNDS: dict[tuple[int, int, int], np.ndarray] = {}


def _background(h: int, w: int, cam: int) -> np.ndarray:
    """A smooth textured backdrop per camera: lit gradient, a checker floor, low-frequency texture."""
    key = (h, w, cam)
    if key not in _BACKGROUNDS:
        rng = np.random.default_rng(1000 + cam)
        yy, xx = np.mgrid[0:h, 0:w].astype(np.float32)
        base = rng.uniform(60, 180, 3).astype(np.float32)
        light = 0.6 + 0.4 * (1 - yy / h)
        coarse = rng.uniform(-20, 20, (h // 16 + 1, w // 16 + 1, 3)).astype(np.float32)
        texture = np.kron(coarse, np.ones((16, 16, 1), np.float32))[:h, :w]
        checker = (((yy // 24) + (xx // 24)) % 2)[..., None] * 25 * (yy > h * 0.55)[..., None]
        img = base * light[..., None] + texture + checker
        _BACKGROUNDS[key] = np.clip(img, 0, 255).astype(np.uint8)
    return _BACKGROUNDS[key]


def _draw(schema: DatasetSchema, cam: int, seed: int, t: int) -> np.ndarray:
    h, w = schema.image_height, schema.image_width
    img = _background(h, w, cam).copy()
    s = t / schema.fps
    cx = int(w * (0.5 + 0.3 * np.sin(0.9 * s + cam + seed)))
    cy = int(h * (0.55 + 0.15 * np.cos(1.3 * s + cam)))
    r = max(3, h // 10)
    y0, y1, x0, x1 = max(cy - r, 0), min(cy + r, h), max(cx - r, 0), min(cx + r, w)
    yy, xx = np.mgrid[y0:y1, x0:x1]
    disk = (yy - cy) ** 2 + (xx - cx) ** 2 <= r * r
    shade = (200 - 60 * (yy - cy) / r).clip(0, 255).astype(np.uint8)
    patch = img[y0:y1, x0:x1]
    patch[disk] = np.stack([shade, np.full_like(shade, 40 + 30 * cam), np.full_like(shade, 50)], -1)[disk]
    bx = int(w * (0.3 + 0.2 * np.cos(0.7 * s + seed)))
    by = int(h * 0.3)
    img[by:by + h // 8, max(bx, 0):max(bx + w // 6, 0)] = (40, 60 + 20 * cam % 200, 190)
    return img
