"""The independent safety audit: re-run the LTL_f monitor on an episode's stored labels and compare.

Nothing recorded is trusted: the spec is rebuilt from the formulas stored with the dataset, the monitor
replays the stored proposition labels, and the stored DFA states, violation flags, first-violation and
first-engagement steps, verdict and kept flag are checked against what the replay says.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from mgdata.errors import MgdataError
from mgdata.ltl import Monitor, verdict
from mgdata.record.reader import EpisodeData
from mgdata.spec import Constraint, Proposition, SafetySpec


def _first(flags: np.ndarray) -> int | None:
    return int(np.argmax(flags)) if flags.any() else None


class SafetyAuditor:
    """Audits episodes against a spec (from ``info.json``; else from each episode's stored formulas)."""

    def __init__(self, propositions: tuple[str, ...], spec: SafetySpec | None) -> None:
        self.propositions = propositions
        self.spec = spec
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
        """Problems with episode ``ep`` (empty if its safety record is consistent and, if kept, safe)."""
        where = f"episode {ep.index}"
        meta = ep.meta
        problems: list[str] = []
        if self.spec is not None:
            stored = {c.id: c.formula for c in self.spec.constraints}
            if dict(meta.formulas) != stored:
                problems.append(f"{where}: formulas {dict(meta.formulas)} differ from the dataset spec "
                                f"{stored}")
        try:
            mon = self._monitor(meta.spec_name, meta.formulas)
            dfa_state, violated = mon.run(ep.labels)
        except MgdataError as err:
            return [*problems, f"{where}: cannot re-run the monitor ({err})"]
        ids = mon.constraint_ids
        for c, cid in enumerate(ids):
            bad = np.flatnonzero(dfa_state[:, c] != ep.dfa_state[:, c])
            if bad.size:
                t = int(bad[0])
                problems.append(f"{where}: stored DFA state of {cid!r} at step {t} is "
                                f"{int(ep.dfa_state[t, c])}, the monitor replay gives {int(dfa_state[t, c])}")
            bad = np.flatnonzero(violated[:, c] != ep.violated[:, c])
            if bad.size:
                problems.append(f"{where}: stored violation flag of {cid!r} differs from the replay from "
                                f"step {int(bad[0])}")
        first = {cid: _first(violated[:, c]) for c, cid in enumerate(ids)}
        for cid in ids:
            if meta.t_violation.get(cid) != first[cid]:
                problems.append(f"{where}: t_violation[{cid!r}] is {meta.t_violation.get(cid)}, the replay "
                                f"gives {first[cid]}")
        if np.any(np.diff(ep.engaged.astype(np.int8)) < 0):
            problems.append(f"{where}: the engaged flag is not latched (it turns off again)")
        t_engage = _first(ep.engaged)
        if meta.t_engage != t_engage:
            problems.append(f"{where}: t_engage is {meta.t_engage}, the engaged flag first rises at "
                            f"{t_engage}")
        t_viol = min((t for t in first.values() if t is not None), default=None)
        nu = verdict(t_viol, t_engage)
        if meta.verdict != nu:
            problems.append(f"{where}: stored verdict {meta.verdict}, the replay gives {nu}")
        if meta.success and not ep.success.any():
            problems.append(f"{where}: marked successful but the success flag is never set")
        if meta.kept and not nu:
            culprit = next(cid for cid in ids if first[cid] == t_viol)
            problems.append(f"{where} (kept) is unsafe: {culprit!r} violated at step {t_viol}, "
                            f"engaged at step {t_engage}")
        if meta.kept and not meta.success:
            problems.append(f"{where} (kept) is unsuccessful")
        return problems
