"""Runtime monitor of a safety spec: one minimal DFA per constraint, stepped on label vectors.

The monitor never builds the product of a spec's constraints: each constraint's DFA reads only its own
propositions, picked out of the spec-wide label vector by a precomputed projection, so a step is one table
lookup per constraint. Violations are bad prefixes: a constraint is violated from the first step its DFA
enters the rejecting sink (absorbing, so the flag is latched).

Example::

    mon = Monitor(family_spec("jar"))          # labels follow mon.propositions
    mon.reset()
    st = mon.step(labels_s0)                   # t = 0: L(s0)
    st = mon.step(labels_s1)                   # t = 1
    st.violated, st.t_violation, mon.status()

    states, violated = mon.run(labels)         # offline replay of a (T, n_props) bool array
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Protocol

import numpy as np

from mgdata.errors import LtlSyntaxError, SpecError
from mgdata.ltl.compile import compile_ltlf
from mgdata.ltl.dfa import DFA
from mgdata.ltl.status import ConstraintStatus


class _Constraint(Protocol):
    @property
    def id(self) -> str: ...
    @property
    def formula(self) -> str: ...


class SafetySpec(Protocol):
    """What a :class:`Monitor` reads of a spec (:class:`mgdata.spec.SafetySpec` is one; the spec layer sits
    above this one)."""

    @property
    def name(self) -> str: ...
    @property
    def proposition_names(self) -> Sequence[str]: ...
    @property
    def constraints(self) -> Sequence[_Constraint]: ...

#: episodes at or above this batch size are stepped by numpy gathers across the batch
_BATCH_GATHER_MIN = 16


@dataclass(frozen=True, eq=False)
class MonitorState:
    """The monitor after one step.

    Attributes:
        t: index of the step just taken (0 for ``L(s0)``).
        dfa_state: ``int16`` ``(n_constraints,)``: each constraint's DFA state after this step.
        violated: ``bool`` ``(n_constraints,)``: latched at the first entry into the rejecting sink.
        first_violation: per constraint, the step of its first violation (``None``: not violated).
        t_violation: the earliest of ``first_violation`` (``None``: no constraint violated).
    """

    t: int
    dfa_state: np.ndarray
    violated: np.ndarray
    first_violation: tuple[int | None, ...]
    t_violation: int | None


class Monitor:
    """Monitors every constraint of a :class:`~mgdata.spec.SafetySpec` with its own DFA.

    Attributes:
        spec: the monitored spec.
        propositions: the label-vector order (``spec.proposition_names``).
        constraint_ids: constraint ids in spec order.
        dfas: one compiled DFA per constraint.
    """

    def __init__(self, spec: SafetySpec) -> None:
        self.spec = spec
        self.propositions: tuple[str, ...] = tuple(spec.proposition_names)
        self.constraint_ids: tuple[str, ...] = tuple(c.id for c in spec.constraints)
        index = {name: i for i, name in enumerate(self.propositions)}
        dfas: list[DFA] = []
        projections: list[tuple[int, ...]] = []
        for c in spec.constraints:
            try:
                dfa = compile_ltlf(c.formula)
            except LtlSyntaxError as err:
                raise SpecError(f"spec {spec.name!r}: constraint {c.id!r}: {err}") from None
            missing = [ap for ap in dfa.aps if ap not in index]
            if missing:
                raise SpecError(f"spec {spec.name!r}: constraint {c.id!r} uses undeclared proposition(s) "
                                f"{', '.join(missing)}; declared: {', '.join(self.propositions) or 'none'}")
            dfas.append(dfa)
            projections.append(tuple(index[ap] for ap in dfa.aps))
        self.dfas: tuple[DFA, ...] = tuple(dfas)
        self._projections = tuple(projections)
        self._bits = tuple(tuple((j, 1 << b) for b, j in enumerate(p)) for p in projections)
        self._rows = tuple(d.table.tolist() for d in dfas)
        self._sinks = tuple(d.violated_mask.tolist() for d in dfas)
        self.reset()

    def reset(self) -> None:
        """Forget the trace: the next :meth:`step` reads ``L(s0)``."""
        self._t = -1
        self._q = [d.initial for d in self.dfas]
        self._first: list[int | None] = [None] * len(self.dfas)
        self._t_violation: int | None = None

    def step(self, labels: np.ndarray) -> MonitorState:
        """Advance every constraint on one label vector (``bool``, ordered as :attr:`propositions`)."""
        values = labels.tolist() if isinstance(labels, np.ndarray) else list(labels)
        if len(values) != len(self.propositions):
            raise SpecError(f"spec {self.spec.name!r}: label vector has {len(values)} entries, expected "
                            f"{len(self.propositions)} ({', '.join(self.propositions)})")
        t = self._t = self._t + 1
        q, first = self._q, self._first
        for c, bits in enumerate(self._bits):
            letter = 0
            for j, bit in bits:
                if values[j]:
                    letter |= bit
            state = q[c] = self._rows[c][q[c]][letter]
            if first[c] is None and self._sinks[c][state]:
                first[c] = t
                if self._t_violation is None:
                    self._t_violation = t
        violated = np.array([f is not None for f in first], dtype=bool)
        return MonitorState(t, np.array(q, dtype=np.int16), violated, tuple(first), self._t_violation)

    def status(self) -> tuple[ConstraintStatus, ...]:
        """The four-valued status of each constraint after the steps taken since :meth:`reset`."""
        return tuple(d.status(q) for d, q in zip(self.dfas, self._q, strict=True))

    def letters(self, labels: np.ndarray) -> list[np.ndarray]:
        """Per constraint, the letter of each label vector of ``labels`` (``(..., n_props)`` bool)."""
        labels = np.asarray(labels, dtype=bool)
        if labels.ndim < 1 or labels.shape[-1] != len(self.propositions):
            raise SpecError(f"spec {self.spec.name!r}: labels have shape {labels.shape}, expected (..., "
                            f"{len(self.propositions)}) ordered as {', '.join(self.propositions)}")
        return [labels[..., list(p)].astype(np.int64) @ (1 << np.arange(len(p), dtype=np.int64))
                for p in self._projections]

    def run(self: Monitor | SafetySpec, labels: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Offline replay of whole episodes, leaving the online state untouched.

        ``labels`` is ``(T, n_props)`` bool (or ``(B, T, n_props)`` for a batch of equal-length episodes);
        returns ``(dfa_state, violated)`` shaped ``(T, C)`` (or ``(B, T, C)``), ``int16`` and ``bool``.
        Also callable as ``Monitor.run(spec, labels)``.
        """
        mon = self if isinstance(self, Monitor) else Monitor(self)
        labels = np.asarray(labels, dtype=bool)
        if labels.ndim not in (2, 3):
            raise SpecError(f"spec {mon.spec.name!r}: labels have shape {labels.shape}, expected (T, "
                            f"{len(mon.propositions)}) or (B, T, {len(mon.propositions)})")
        letters = mon.letters(labels)
        n_ep = labels.shape[0] if labels.ndim == 3 else 1
        n_t = labels.shape[-2]
        states = np.empty((n_ep, n_t, len(mon.dfas)), dtype=np.int16)
        for c, dfa in enumerate(mon.dfas):
            lc = letters[c].reshape(n_ep, n_t)
            if n_ep >= _BATCH_GATHER_MIN:
                q = np.full(n_ep, dfa.initial, dtype=np.int32)
                for t in range(n_t):
                    q = dfa.table[q, lc[:, t]]
                    states[:, t, c] = q
            else:
                for e in range(n_ep):
                    states[e, :, c] = dfa.run(lc[e])
        violated = np.empty(states.shape, dtype=bool)
        for c, dfa in enumerate(mon.dfas):
            violated[..., c] = dfa.violated_mask[states[..., c]]
        shape = (*labels.shape[:-1], len(mon.dfas))
        return states.reshape(shape), violated.reshape(shape)
