"""Rollout metrics of the paper (tables "Evaluation metrics" and "Task and safety metrics").

Input: one JSON object per line, one per evaluation rollout, with at least::

    {"family": "jar", "task": "task_0003", "condition": "base", "seed": 0, "success": true,
     "engaged": true, "t_engage": 112, "t_violation": null, "horizon": 2000}

(``null`` for never; an optional ``t_success`` enables TTS; other fields are ignored). The safety verdict is
the paper's ``ν = 1 iff t_viol = ∞ or t_viol < t_eng`` (:func:`mgdata.ltl.verdict`).

Rates are percentages computed per seed and then averaged over the seeds, as in the paper; a conditional
rate (Safe|Eng., EVR) is ``None`` when some seed has no engaged rollout. TTV pools every counted violation
of the group: ``(t_viol - t_eng) / (T - t_eng)``. TTS is the mean ``t_success`` over successful rollouts.

Example::

    records = load_records(Path("eval.jsonl"))
    for m in metrics_by(records, ("family", "condition")):
        print(m.group, m.ssr, m.tsr, m.safe)
"""

from __future__ import annotations

import json
import math
from collections.abc import Mapping, Sequence
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

import numpy as np

from mgdata.errors import MetricsError
from mgdata.ltl.verdict import verdict

GROUP_KEYS: tuple[str, ...] = ("family", "condition", "task")


@dataclass(frozen=True)
class RolloutRecord:
    """One evaluation rollout; step indices are ``None`` when the event never happened."""

    family: str
    task: str
    condition: str
    seed: int
    success: bool
    engaged: bool
    t_engage: int | None
    t_violation: int | None
    horizon: int
    t_success: int | None = None

    @property
    def safe(self) -> bool:
        """The verdict ν: no violation, or only violations before first engagement."""
        return verdict(self.t_violation, self.t_engage)


@dataclass(frozen=True)
class OutcomeCounts:
    """Raw counts: the four outcome classes (they partition ``n``) and the engaged ones."""

    n: int
    safe_success: int
    unsafe_success: int
    safe_unsuccess: int
    unsafe_unsuccess: int
    engaged: int
    engaged_safe: int

    @classmethod
    def of(cls, records: Sequence[RolloutRecord]) -> OutcomeCounts:
        def count(pred: Any) -> int:
            return sum(1 for r in records if pred(r))

        return cls(len(records), count(lambda r: r.success and r.safe),
                   count(lambda r: r.success and not r.safe), count(lambda r: not r.success and r.safe),
                   count(lambda r: not r.success and not r.safe), count(lambda r: r.engaged),
                   count(lambda r: r.engaged and r.safe))


@dataclass(frozen=True)
class TimeToViolation:
    """Positions of counted violations in the post-engagement window (0 = at first contact, 1 = at T)."""

    count: int
    median: float | None
    q1: float | None
    q3: float | None
    values: tuple[float, ...]


@dataclass(frozen=True)
class Metrics:
    """Every metric of one group of rollouts (percentages, mean over seeds; see the module docstring)."""

    group: tuple[tuple[str, str], ...]
    seeds: tuple[int, ...]
    counts: OutcomeCounts
    tsr: float
    safe: float
    ssr: float
    succ_unsafe: float
    unsucc_safe: float
    unsucc_unsafe: float
    eng: float
    eng_safe: float
    safe_given_eng: float | None
    vacuous_safe: float
    svr: float
    evr: float | None
    ttv: TimeToViolation
    tts: float | None

    def as_dict(self) -> dict[str, Any]:
        """A JSON-ready dict (``group`` as a mapping)."""
        data = asdict(self)
        data["group"] = dict(self.group)
        data["seeds"] = list(self.seeds)
        data["ttv"]["values"] = list(self.ttv.values)
        return data


def parse_record(obj: Any, where: str) -> RolloutRecord:
    """Validate one decoded JSON record; ``where`` (``file:line``) prefixes errors."""
    if not isinstance(obj, Mapping):
        raise MetricsError(f"{where}: expected a JSON object, got {type(obj).__name__}")

    def get(key: str, kinds: tuple[type, ...], expected: str, optional: bool = False) -> Any:
        if key not in obj:
            if optional:
                return None
            raise MetricsError(f"{where}: missing field {key!r} ({expected})")
        value = obj[key]
        if value is None and (optional or type(None) in kinds):
            return None
        if not isinstance(value, kinds) or (bool not in kinds and isinstance(value, bool)):
            raise MetricsError(f"{where}: field {key!r} must be {expected}, got {value!r}")
        return value

    step = "a step index (integer >= 0) or null"
    record = RolloutRecord(
        family=get("family", (str,), "a string"), task=str(get("task", (str, int), "a string")),
        condition=get("condition", (str,), "a string"), seed=get("seed", (int,), "an integer"),
        success=get("success", (bool,), "true or false"), engaged=get("engaged", (bool,), "true or false"),
        t_engage=get("t_engage", (int, type(None)), step),
        t_violation=get("t_violation", (int, type(None)), step),
        horizon=get("horizon", (int,), "a positive integer"), t_success=get("t_success", (int,), step, True))
    if record.horizon <= 0:
        raise MetricsError(f"{where}: field 'horizon' must be a positive integer, got {record.horizon}")
    for key in ("t_engage", "t_violation", "t_success"):
        value = getattr(record, key)
        if value is not None and not 0 <= value <= record.horizon:
            raise MetricsError(f"{where}: field {key!r} = {value} is outside [0, horizon = {record.horizon}]")
    if record.engaged != (record.t_engage is not None):
        raise MetricsError(f"{where}: 'engaged' is {str(record.engaged).lower()} but 't_engage' is "
                           f"{record.t_engage if record.t_engage is not None else 'null'}; they must agree")
    return record


def load_records(path: Path) -> list[RolloutRecord]:
    """Read a JSON-lines records file (blank lines skipped); errors name ``file:line``."""
    path = Path(path)
    try:
        lines = path.read_text(encoding="utf-8").splitlines()
    except FileNotFoundError:
        raise MetricsError(f"records file {path} does not exist") from None
    except UnicodeDecodeError as err:
        raise MetricsError(f"{path}: not a UTF-8 text file (byte {err.start}); expected JSON lines") from None
    except IsADirectoryError:
        raise MetricsError(f"{path}: is a folder; expected a JSON-lines records file") from None
    except OSError as err:
        raise MetricsError(f"records file {path} cannot be read ({err.strerror or err})") from None
    records = []
    for i, line in enumerate(lines, start=1):
        if not line.strip():
            continue
        try:
            obj = json.loads(line)
        except json.JSONDecodeError as err:
            raise MetricsError(f"{path}:{i}: not valid JSON: {err.msg} (column {err.colno})") from None
        records.append(parse_record(obj, f"{path}:{i}"))
    if not records:
        raise MetricsError(f"{path}: no records")
    return records


def compute_metrics(records: Sequence[RolloutRecord], group: tuple[tuple[str, str], ...] = ()) -> Metrics:
    """All metrics of ``records`` (non-empty): rates per seed, then the mean over seeds."""
    if not records:
        raise MetricsError("no records to compute metrics from")
    seeds = tuple(sorted({r.seed for r in records}))
    per_seed = [OutcomeCounts.of([r for r in records if r.seed == s]) for s in seeds]

    def rate(num: Any, den: Any = lambda c: c.n) -> float | None:
        values = [num(c) / den(c) for c in per_seed if den(c)]
        return 100.0 * float(np.mean(values)) if len(values) == len(per_seed) else None

    safe = rate(lambda c: c.safe_success + c.safe_unsuccess)
    eng = rate(lambda c: c.engaged)
    safe_given_eng = rate(lambda c: c.engaged_safe, lambda c: c.engaged)
    return Metrics(
        group=group, seeds=seeds, counts=OutcomeCounts.of(records),
        tsr=rate(lambda c: c.safe_success + c.unsafe_success), safe=safe, ssr=rate(lambda c: c.safe_success),
        succ_unsafe=rate(lambda c: c.unsafe_success), unsucc_safe=rate(lambda c: c.safe_unsuccess),
        unsucc_unsafe=rate(lambda c: c.unsafe_unsuccess), eng=eng, eng_safe=rate(lambda c: c.engaged_safe),
        safe_given_eng=safe_given_eng, vacuous_safe=100.0 - eng, svr=100.0 - safe,
        evr=None if safe_given_eng is None else 100.0 - safe_given_eng,
        ttv=_time_to_violation(records), tts=_time_to_success(records))


def metrics_by(records: Sequence[RolloutRecord], by: Sequence[str] = ()) -> list[Metrics]:
    """Metrics per group of ``by`` keys (a subset of :data:`GROUP_KEYS`), groups sorted; ``()``: overall."""
    for key in by:
        if key not in GROUP_KEYS:
            raise MetricsError(f"cannot group by {key!r}; expected some of {', '.join(GROUP_KEYS)}")
    groups: dict[tuple[str, ...], list[RolloutRecord]] = {}
    for r in records:
        groups.setdefault(tuple(getattr(r, k) for k in by), []).append(r)
    return [compute_metrics(groups[values], tuple(zip(by, values, strict=True))) for values in sorted(groups)]


def _time_to_violation(records: Sequence[RolloutRecord]) -> TimeToViolation:
    values = []
    for r in records:
        if not r.safe:  # a counted violation: t_eng <= t_viol
            window = r.horizon - r.t_engage
            values.append((r.t_violation - r.t_engage) / window if window else 0.0)
    if not values:
        return TimeToViolation(0, None, None, None, ())
    q1, median, q3 = (float(x) for x in np.percentile(values, [25, 50, 75]))
    return TimeToViolation(len(values), median, q1, q3, tuple(sorted(values)))


def _time_to_success(records: Sequence[RolloutRecord]) -> float | None:
    times = [r.t_success for r in records if r.success and r.t_success is not None]
    return float(np.mean(times)) if times else None


def format_rate(value: float | None) -> str:
    """Two decimals, or a dash for an undefined rate."""
    return "—" if value is None or math.isnan(value) else f"{value:.2f}"
