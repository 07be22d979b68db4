"""Typed safety specifications: constraints (LTL_f formulas) over named propositions.

A :class:`SafetySpec` is what a family recipe declares: each constraint is monitored by its own DFA, and each
proposition names the evaluator (``mgdata.sim.predicates``) that labels it from the simulation state.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from types import MappingProxyType
from typing import Any


@dataclass(frozen=True)
class Constraint:
    """One conjunct of a spec: ``id`` (identifier), an LTL_f ``formula`` and its plain-English ``description``."""

    id: str
    formula: str
    description: str = ""


@dataclass(frozen=True)
class Proposition:
    """An atomic proposition: ``evaluator`` (registry name) applied to ``subjects`` with ``params``.

    Example: ``Proposition("jar_upright", "upright", ("jar",), {"max_tilt_deg": 30.0})``.
    ``quantifier`` ("all" or "any") says how per-subject truths combine.
    """

    name: str
    evaluator: str
    subjects: tuple[str, ...] = ()
    params: Mapping[str, Any] = field(default_factory=lambda: MappingProxyType({}))
    quantifier: str = "all"


@dataclass(frozen=True)
class SafetySpec:
    """Constraints plus the propositions they mention; ``name`` is e.g. ``"jar"``."""

    name: str
    constraints: tuple[Constraint, ...]
    propositions: tuple[Proposition, ...]

    @property
    def proposition_names(self) -> tuple[str, ...]:
        return tuple(p.name for p in self.propositions)

    def constraint(self, cid: str) -> Constraint:
        for c in self.constraints:
            if c.id == cid:
                return c
        raise KeyError(cid)
