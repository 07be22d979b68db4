"""``mgdata info``: what a dataset holds, read from its metadata only (no video decoding)."""

from __future__ import annotations

from collections import Counter
from dataclasses import dataclass
from pathlib import Path

from mgdata.record import layout
from mgdata.record.reader import DatasetReader


@dataclass(frozen=True)
class DatasetSummary:
    """Counts and sizes of a dataset.

    Attributes:
        by_family, by_condition: episodes per family / OOD condition (sorted by name).
        kept, negatives: episodes the gate accepted / labelled negatives kept on request.
        attempts: attempts recorded by the generator (``None`` if it recorded none); ``draws``: attempts
            implied by the draw indices (max draw index + 1 per family and task).
        size_bytes: bytes on disk (dataset files only).
        penetration: the deepest contact overlap over every episode's frames (m), its episode, frame and
            bodies (``None``: no episode records it); ``penetration_bound``: the gate's ``max_penetration``.
        recovery: ``info.json`` ``mgdata.recovery`` of a dataset of perturbed demonstrations (else ``None``).
        rollouts, succeeded: the episodes that are a policy's recorded rollouts (``mgdata eval --record``),
            and how many of them succeeded; a rollout is no attempt at a demonstration, so no yield counts it.
    """

    root: Path
    episodes: int
    frames: int
    fps: int
    cameras: tuple[str, ...]
    codec: str
    tasks: int
    by_family: dict[str, int]
    by_condition: dict[str, int]
    kept: int
    negatives: int
    unsafe: int
    attempts: int | None
    draws: int
    size_bytes: int
    penetration: tuple[float, int, int | None, str] | None = None
    penetration_bound: float | None = None
    recovery: dict | None = None
    rollouts: int = 0
    succeeded: int = 0

    @property
    def duration_s(self) -> float:
        return self.frames / self.fps if self.fps else 0.0

    @property
    def only_rollouts(self) -> bool:
        """Every episode is a policy's recorded rollout (no demonstration at all)."""
        return self.rollouts == self.episodes > 0

    @property
    def yield_(self) -> float | None:
        """Kept episodes per attempt (recorded attempts, else the draw count); ``None`` if unknown or the
        dataset is a policy's rollouts."""
        if self.only_rollouts:
            return None
        denom = self.attempts if self.attempts else self.draws
        return self.kept / denom if denom else None


def summarize(root: Path) -> DatasetSummary:
    reader = DatasetReader(Path(root))
    metas = [r.meta for r in reader.records()]
    last_draw: dict[tuple[str, int], int] = {}
    for m in metas:
        key = (m.family, m.task_id)
        last_draw[key] = max(last_draw.get(key, -1), m.draw_index)
    measured = [(m.max_penetration, i, m.penetration_step, m.penetration_bodies or "")
                for i, m in enumerate(metas) if m.max_penetration is not None]
    bound = (reader.info["mgdata"].get("physics_gate") or {}).get("max_penetration")
    size = sum(p.stat().st_size for p in Path(root).rglob("*")
               if p.is_file() and layout.WORK_DIR not in p.relative_to(root).parts)
    return DatasetSummary(
        root=Path(root), episodes=reader.num_episodes, frames=reader.num_frames, fps=reader.schema.fps,
        cameras=reader.schema.cameras, codec=reader.video.codec, tasks=len(reader.tasks),
        by_family=dict(sorted(Counter(m.family for m in metas).items())),
        by_condition=dict(sorted(Counter(m.condition for m in metas).items())),
        kept=sum(m.kept for m in metas), negatives=sum(not m.kept for m in metas),
        unsafe=sum(not m.verdict for m in metas), attempts=reader.info["mgdata"].get("attempts"),
        draws=sum(d + 1 for d in last_draw.values()), size_bytes=size,
        penetration=max(measured, key=lambda x: x[0]) if measured else None, penetration_bound=bound,
        recovery=reader.info["mgdata"].get("recovery"),
        rollouts=sum(m.source == "rollout" for m in metas),
        succeeded=sum(m.source == "rollout" and m.success for m in metas),
    )


def format_summary(s: DatasetSummary) -> list[str]:
    """Human-readable lines for ``mgdata info``."""
    def counts(d: dict[str, int]) -> str:
        return ", ".join(f"{k} {v}" for k, v in d.items()) or "none"

    if s.only_rollouts:
        yld = (f"none: {s.episodes} policy rollouts ({s.succeeded} succeeded), no demonstrations "
               "(mgdata corrections restarts the failed ones)")
    elif s.yield_ is None:
        yld = "unknown"
    elif s.attempts:
        yld = f"{s.yield_:.1%} ({s.kept} kept of {s.attempts} attempts)"
    else:
        yld = f"{s.yield_:.1%} ({s.kept} kept of {s.draws} draws, from the draw indices)"
    episodes = f"{s.kept} kept, {s.negatives} labelled negatives, {s.unsafe} unsafe"
    if s.only_rollouts:
        episodes = f"policy rollouts: {s.succeeded} succeeded, {s.unsafe} unsafe"
    recovery = [] if not s.recovery else [
        f"recovery    {s.recovery.get('mode')}, amplitude {s.recovery.get('amplitude')} rad "
        f"(action: the plan's targets; {layout.EXECUTED_ACTION}: what ran)"]
    return [
        f"dataset     {s.root}",
        f"episodes    {s.episodes} ({episodes})",
        f"frames      {s.frames} at {s.fps} Hz ({s.duration_s / 60:.1f} min)",
        f"cameras     {', '.join(s.cameras) or 'none'} ({s.codec})",
        f"tasks       {s.tasks} prompts",
        f"families    {counts(s.by_family)}",
        f"conditions  {counts(s.by_condition)}",
        f"yield       {yld}",
        f"contacts    {_contacts(s)}",
        *recovery,
        f"size        {s.size_bytes / 1e6:.1f} MB",
    ]


def _contacts(s: DatasetSummary) -> str:
    if s.penetration is None:
        return "not measured"
    depth, episode, frame, bodies = s.penetration
    bound = f"; kept demos may reach {s.penetration_bound * 1000:.2f} mm" if s.penetration_bound else ""
    return (f"deepest overlap {depth * 1000:.2f} mm (episode {episode}, frame {frame}, "
            f"{bodies or 'no overlap'}){bound}")
