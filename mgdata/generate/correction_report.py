"""The corrections report (``meta/mgdata_corrections.json``): every failed rollout a corrections run tried,
and, for a ``--shard i/N`` run, which shard of which run the dataset is.

``rollouts`` lists one entry per corrected rollout, in the order they were committed (the rollouts
dataset's order): its name, parent, failure and every try. A shard's report also holds ``shard``: its
index and count, the rollouts dataset it read (the SHA-256 of its ``info.json``, which records every
file's checksum), the ``--tasks`` selection, the settings and the episodes of the failed rollouts that fall
in it, so a resume with other settings is refused and ``mgdata merge`` can tell that the shards are of one
run and complete. An unsharded run's report has no ``shard`` (its bytes are those a merge of shards writes).

Example::

    report = CorrectionReport.load(out / REPORT_FILE)
    report.save(out / REPORT_FILE)
"""

from __future__ import annotations

import hashlib
import json
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

from mgdata.atomic import write_text_atomic
from mgdata.errors import DatasetError
from mgdata.record import layout

REPORT_FILE = layout.CORRECTIONS_PATH


@dataclass(frozen=True)
class ShardRecord:
    """Which shard of which corrections run a dataset holds.

    Attributes:
        index, count: ``--shard index/count``.
        rollouts: SHA-256 of the rollouts dataset's ``info.json`` (:func:`rollouts_digest`).
        tasks: the ``--tasks`` selection (``None``: all).
        settings: ``back``, ``candidates``, ``tries``, ``per_failure``.
        episodes: the rollouts-dataset episodes of the failed rollouts in this shard, in order.
    """

    index: int
    count: int
    rollouts: str
    tasks: tuple[int, ...] | None
    settings: dict[str, int]
    episodes: tuple[int, ...]

    @property
    def name(self) -> str:
        return f"{self.index}/{self.count}"

    def differences(self, other: ShardRecord) -> list[str]:
        """The fields (other than ``index`` and ``episodes``) in which ``other`` differs, as ``name mine vs
        theirs`` phrases; empty if both are shards of one run."""
        found = []
        for name in ("count", "rollouts", "tasks", "settings"):
            mine, theirs = getattr(self, name), getattr(other, name)
            if mine != theirs:
                if name == "rollouts":  # digests: their start is enough to tell them apart
                    mine, theirs = f"{mine[:12]}…", f"{theirs[:12]}…"
                found.append(f"{name} {mine} vs {theirs}")
        return found

    @classmethod
    def from_json(cls, raw: dict[str, Any]) -> ShardRecord:
        tasks = raw["tasks"]
        return cls(int(raw["index"]), int(raw["count"]), str(raw["rollouts"]),
                   None if tasks is None else tuple(int(t) for t in tasks),
                   {str(k): int(v) for k, v in raw["settings"].items()},
                   tuple(int(e) for e in raw["episodes"]))

    def to_json(self) -> dict[str, Any]:
        raw = asdict(self)
        raw["tasks"] = None if self.tasks is None else list(self.tasks)
        raw["episodes"] = list(self.episodes)
        return raw


@dataclass
class CorrectionReport:
    """The report's contents.

    Attributes:
        rollouts: one entry per corrected rollout (``rollout``, ``parent``, ``failure``, ``failure_step``,
            ``corrections``, ``tries``), in commit order.
        shard: the shard this dataset is (``None``: an unsharded run).
    """

    rollouts: list[dict[str, Any]] = field(default_factory=list)
    shard: ShardRecord | None = None

    @property
    def episodes(self) -> list[int]:
        """The rollouts-dataset episode of each entry, in order."""
        return [int(entry["parent"]["episode"]) for entry in self.rollouts]

    @classmethod
    def load(cls, path: Path) -> CorrectionReport:
        """The report at ``path`` (an empty one if there is none)."""
        if not path.exists():
            return cls()
        try:
            data = json.loads(path.read_text(encoding="utf-8"))
            assert isinstance(data["rollouts"], list)
            shard = data.get("shard")
            return cls(data["rollouts"], None if shard is None else ShardRecord.from_json(shard))
        except (ValueError, KeyError, TypeError, AttributeError, AssertionError) as err:
            raise DatasetError(f"{path}: unreadable corrections report ({err!r}); it lists the rollouts "
                               "already corrected: restore it, or use a new --out") from None

    def dump(self) -> str:
        """The file's text (an unsharded report: ``rollouts`` only)."""
        data: dict[str, Any] = {} if self.shard is None else {"shard": self.shard.to_json()}
        data["rollouts"] = self.rollouts
        return json.dumps(data, indent=2) + "\n"

    def save(self, path: Path) -> None:
        """Write atomically (a reader never sees half a report)."""
        write_text_atomic(path, self.dump())


def rollouts_digest(root: Path) -> str:
    """SHA-256 of a rollouts dataset's ``info.json``: its identity (the file records every data file's
    checksum), what the shards of one corrections run must share."""
    return hashlib.sha256((Path(root) / layout.INFO_PATH).read_bytes()).hexdigest()
