"""Temporal ensembling of action chunks (ACT, Zhao et al. 2023), done by the evaluation client.

With ensembling the policy is queried at every step. Each reply is a chunk of predictions for the next
steps; the action executed at step ``t`` is the weighted mean of every prediction made for ``t`` so far,
the ``k``-th oldest weighted ``exp(-coeff * k)`` (ACT's scheme: ``coeff`` 0.01 weights them almost
equally, a larger one favours the oldest). It smooths a chunking policy's switch between chunks, and any
server that returns chunks can use it: the policy itself is unchanged.

Example::

    ensemble = ChunkEnsemble(0.01)
    ensemble.add(0, chunk0)           # (H, 8) predictions for steps 0 .. H-1
    action = ensemble.action(0)       # chunk0[0]
    ensemble.add(1, chunk1)
    action = ensemble.action(1)       # (chunk0[1] + exp(-0.01) * chunk1[0]) / (1 + exp(-0.01))
"""

from __future__ import annotations

import numpy as np


class ChunkEnsemble:
    """The chunks received so far, keyed by the step they were predicted at."""

    def __init__(self, coeff: float) -> None:
        if not np.isfinite(coeff) or coeff < 0:
            raise ValueError(f"the ensembling coefficient must be finite and >= 0, got {coeff}")
        self.coeff = coeff
        self._chunks: list[tuple[int, np.ndarray]] = []

    def add(self, step: int, chunk: np.ndarray) -> None:
        """The chunk predicted at ``step`` (row ``i`` is the action for step ``step + i``)."""
        self._chunks.append((step, np.asarray(chunk, dtype=np.float64)))

    def action(self, step: int) -> np.ndarray:
        """The ensembled action for ``step``; chunks that no longer reach it are forgotten.

        Raises:
            ValueError: no chunk predicts ``step``.
        """
        self._chunks = [(t, c) for t, c in self._chunks if t + len(c) > step]
        live = [c[step - t] for t, c in self._chunks if t <= step]
        if not live:
            raise ValueError(f"no chunk predicts step {step}")
        weights = np.exp(-self.coeff * np.arange(len(live)))
        return (weights[:, None] * np.stack(live)).sum(axis=0) / weights.sum()
