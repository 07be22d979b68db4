"""The independent safety audit: does every episode keep what the gate promised?

Nothing recorded is trusted. The spec is rebuilt from the formulas stored with the dataset and the monitor
replays the stored proposition labels; the stored DFA states and violation flags must equal the replay.
The episode's metadata (``t_violation`` per constraint, ``t_engage``, verdict, ``success``) must agree with
the per-step columns (``safety.violated``, ``safety.engaged``, ``safety.success``). On top of that:

* a **successful** episode ends with the goal held: ``safety.success`` is true on its last ``hold_steps``
  frames (``info.json`` ``mgdata.hold_steps``; the last frame alone when the dataset does not record it);
* a **kept** episode is successful and shows **no violation on any frame** (stronger than ν = 1, which
  excuses violations before engagement: a training demonstration must never show one);
* a dataset that promises only kept episodes (``mgdata.kept_only``, a ``generate`` output) holds no other.

Every problem is one line naming the episode and, where there is one, the frame.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from mgdata.errors import MgdataError
from mgdata.ltl import Monitor, verdict
from mgdata.record import layout
from mgdata.record.reader import EpisodeData
from mgdata.spec import Constraint, Proposition, SafetySpec


def _first(flags: np.ndarray) -> int | None:
    return int(np.argmax(flags)) if flags.any() else None


def _frames(idx: np.ndarray) -> str:
    shown = ", ".join(str(int(i)) for i in idx[:5])
    return f"frame{'s' if len(idx) > 1 else ''} {shown}{' …' if len(idx) > 5 else ''}"


class SafetyAuditor:
    """Audits episodes against a spec (from ``info.json``; else from each episode's stored formulas).

    Args:
        propositions: the label column order.
        spec: the dataset's spec, if stored.
        hold_steps: the gate's success window (``None``: not recorded; the last frame is checked).
        kept_only: the dataset promises that every episode passed the gate.
    """

    def __init__(self, propositions: tuple[str, ...], spec: SafetySpec | None, *,
                 hold_steps: int | None = None, kept_only: bool = False) -> None:
        self.propositions = propositions
        self.spec = spec
        self.hold_steps = hold_steps
        self.kept_only = kept_only
        self._monitors: dict[tuple, Monitor] = {}

    def _monitor(self, name: str, formulas: Mapping[str, str]) -> Monitor:
        key = (name, tuple(formulas.items()))
        if key not in self._monitors:
            if self.spec is not None:
                spec = self.spec
            else:  # no stored spec: monitoring needs only the formulas and the label order
                spec = SafetySpec(name, tuple(Constraint(cid, f) for cid, f in formulas.items()),
                                  tuple(Proposition(p, "unknown") for p in self.propositions))
            self._monitors[key] = Monitor(spec)
        return self._monitors[key]

    def audit(self, ep: EpisodeData) -> list[str]:
        """Problems with episode ``ep`` (none if its record is consistent and keeps the gate's promise)."""
        where = f"episode {ep.index}"
        meta = ep.meta
        problems: list[str] = []
        if self.spec is not None:
            stored = {c.id: c.formula for c in self.spec.constraints}
            if dict(meta.formulas) != stored:
                problems.append(f"{where}: formulas {dict(meta.formulas)} differ from the dataset spec "
                                f"{stored}")
        if not self.propositions:  # a training view (export --format state) keeps no labels to replay
            return [*problems, *self._metadata(ep, (), replayed=False), *self._promise(ep, ())]
        try:
            mon = self._monitor(meta.spec_name, meta.formulas)
            ids = mon.constraint_ids
            problems += self._replay(ep, mon)
        except MgdataError as err:
            return [*problems, f"{where}: cannot re-run the monitor ({err})"]
        problems += self._metadata(ep, ids)
        problems += self._promise(ep, ids)
        return problems

    def _replay(self, ep: EpisodeData, mon: Monitor) -> list[str]:
        """The stored DFA states and violation flags against the monitor re-run on the stored labels."""
        where, problems = f"episode {ep.index}", []
        dfa_state, violated = mon.run(ep.labels)
        for c, cid in enumerate(mon.constraint_ids):
            bad = np.flatnonzero(dfa_state[:, c] != ep.dfa_state[:, c])
            if bad.size:
                t = int(bad[0])
                problems.append(f"{where}: stored DFA state of {cid!r} at frame {t} is "
                                f"{int(ep.dfa_state[t, c])}, the monitor re-run from {layout.LABELS} gives "
                                f"{int(dfa_state[t, c])}")
            bad = np.flatnonzero(violated[:, c] != ep.violated[:, c])
            if bad.size:
                t = int(bad[0])
                problems.append(f"{where}: stored violation flag of {cid!r} at frame {t} is "
                                f"{bool(ep.violated[t, c])}, the monitor re-run from {layout.LABELS} gives "
                                f"{bool(violated[t, c])}")
        return problems

    def _metadata(self, ep: EpisodeData, ids: tuple[str, ...], replayed: bool = True) -> list[str]:
        """The episode's metadata against its per-step columns (``replayed``: the violation flags are stored,
        so the verdict can be recomputed)."""
        where, meta, problems = f"episode {ep.index}", ep.meta, []
        first = {cid: _first(ep.violated[:, c]) for c, cid in enumerate(ids)}
        for cid in ids:
            if meta.t_violation.get(cid) != first[cid]:
                seen = f"first sets at frame {first[cid]}" if first[cid] is not None else "is never set"
                problems.append(f"{where}: t_violation[{cid!r}] is {meta.t_violation.get(cid)}, "
                                f"{layout.VIOLATED} of {cid!r} {seen}")
        turned_off = np.flatnonzero(np.diff(ep.engaged.astype(np.int8)) < 0)
        if turned_off.size:
            problems.append(f"{where}: {layout.ENGAGED} is not latched (it turns off again at frame "
                            f"{int(turned_off[0]) + 1})")
        t_engage = _first(ep.engaged)
        if meta.t_engage != t_engage:
            problems.append(f"{where}: t_engage is {meta.t_engage}, {layout.ENGAGED} first rises at frame "
                            f"{t_engage}")
        t_viol = min((t for t in first.values() if t is not None), default=None)
        nu = verdict(t_viol, t_engage)
        if replayed and meta.verdict != nu:
            problems.append(f"{where}: stored verdict {meta.verdict}, the columns give {nu} (first violation "
                            f"at frame {t_viol}, engagement at frame {t_engage})")
        if meta.success:
            window = min(self.hold_steps or 1, ep.length)
            tail = ep.length - window
            off = tail + np.flatnonzero(~ep.success[tail:])
            if off.size:
                problems.append(f"{where}: marked successful but {layout.SUCCESS} is false at {_frames(off)} "
                                f"(a successful episode ends with the goal held on its last {window} frames)")
        return problems

    def _promise(self, ep: EpisodeData, ids: tuple[str, ...]) -> list[str]:
        """What a kept episode and a kept-only dataset promise."""
        where, meta, problems = f"episode {ep.index}", ep.meta, []
        if self.kept_only and not meta.kept:
            stage = f" (failure stage {meta.failure_stage!r})" if meta.failure_stage else ""
            problems.append(f"{where} is not kept{stage}, but this dataset holds only kept episodes "
                            "(info.json mgdata.kept_only)")
        if not meta.kept:
            return problems
        for c, cid in enumerate(ids):
            t = _first(ep.violated[:, c])
            if t is not None:
                problems.append(f"{where} (kept) shows a violation: {cid!r} is violated from frame {t} "
                                f"(engaged at frame {_first(ep.engaged)}); a kept demonstration never "
                                "violates")
        if not meta.success:
            problems.append(f"{where} (kept) is unsuccessful")
        return problems
