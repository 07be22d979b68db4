"""Moore minimisation and canonical numbering of complete DFAs given as numpy transition tables.

After :func:`minimize`, states are numbered in breadth-first order from the initial state (state 0),
scanning letters in increasing order, so two formulas with the same language get identical tables.
"""

from __future__ import annotations

import numpy as np


def minimize(table: np.ndarray, accepting: np.ndarray, initial: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """The minimal DFA of the reachable part of ``(table, accepting, initial)``, canonically numbered.

    Returns ``(table, accepting)`` with the initial state 0.
    """
    table = np.asarray(table)
    reach = _bfs_order(table, initial)
    keep = np.full(len(table), -1, dtype=np.int64)
    keep[reach] = np.arange(len(reach))
    table = keep[table[reach]]
    accepting = np.asarray(accepting, dtype=bool)[reach]

    classes = accepting.astype(np.int64)
    n_classes = len(np.unique(classes))
    while True:  # refine until stable: at most n rounds
        signature = np.column_stack([classes, classes[table]])
        _, refined = np.unique(signature, axis=0, return_inverse=True)
        refined = refined.reshape(-1)
        n_refined = int(refined.max()) + 1
        if n_refined == n_classes:
            break
        classes, n_classes = refined, n_refined

    quotient = np.empty((n_classes, table.shape[1]), dtype=np.int64)
    quotient[classes] = classes[table]
    q_accepting = np.empty(n_classes, dtype=bool)
    q_accepting[classes] = accepting

    order = _bfs_order(quotient, int(classes[0]))
    rank = np.empty(n_classes, dtype=np.int64)
    rank[order] = np.arange(n_classes)
    return rank[quotient[order]].astype(np.int32), q_accepting[order]


def _bfs_order(table: np.ndarray, initial: int) -> np.ndarray:
    """States reachable from ``initial`` in breadth-first order (letters scanned in increasing order)."""
    rows = table.tolist()
    seen = {initial}
    order = [initial]
    i = 0
    while i < len(order):
        for succ in rows[order[i]]:
            if succ not in seen:
                seen.add(succ)
                order.append(succ)
        i += 1
    return np.array(order, dtype=np.int64)
