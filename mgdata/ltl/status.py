"""The four-valued status of a monitored constraint (runtime-verification verdicts for finite traces)."""

from __future__ import annotations

from enum import StrEnum


class ConstraintStatus(StrEnum):
    """Where a constraint's automaton stands after the trace seen so far.

    - ``PERMANENTLY_VIOLATED``: the rejecting sink; no continuation can satisfy the constraint.
    - ``PERMANENTLY_SATISFIED``: every continuation satisfies it.
    - ``CURRENTLY_SATISFIED``: the trace so far satisfies it, but a continuation may not.
    - ``CURRENTLY_VIOLATED``: the trace so far does not satisfy it, but a continuation may.
    """

    PERMANENTLY_VIOLATED = "permanently_violated"
    PERMANENTLY_SATISFIED = "permanently_satisfied"
    CURRENTLY_SATISFIED = "currently_satisfied"
    CURRENTLY_VIOLATED = "currently_violated"
