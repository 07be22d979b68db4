"""A complete, minimal DFA for one LTL_f formula, read as a runtime monitor.

Letters are integers: bit ``i`` is the truth of ``aps[i]`` (``aps`` sorted). The automaton starts in
``initial`` before any step, so a trace ``w0 … wn`` (non-empty) is accepted when the state reached after
reading all of it is accepting. A state is *violated* when no accepting state is reachable from it: the
rejecting sink, entered at the first bad prefix. It is *permanently satisfied* when every reachable state
accepts.

Example::

    >>> dfa = compile_ltlf("jar_on_support W jar_closed")
    >>> dfa.aps
    ('jar_closed', 'jar_on_support')
    >>> q = dfa.step(dfa.initial, 0b10)          # on support, not closed
    >>> dfa.accepting(q), dfa.is_violated(dfa.step(q, 0b00))
    (True, True)
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np

from mgdata.errors import MgdataError
from mgdata.ltl.guards import guard
from mgdata.ltl.status import ConstraintStatus


def _coreachable(table: np.ndarray, targets: np.ndarray) -> np.ndarray:
    """States from which some state in ``targets`` is reachable (in zero or more steps)."""
    reach = targets.copy()
    while True:
        grown = reach | reach[table].any(axis=1)
        if (grown == reach).all():
            return reach
        reach = grown


class DFA:
    """A complete minimal DFA over letters of ``aps`` with an explicit rejecting sink (when one exists).

    Attributes:
        formula: the source formula text.
        aps: proposition names, sorted; bit ``i`` of a letter is ``aps[i]``.
        initial: the start state (always 0; states are numbered breadth-first from it).
        n_states: number of states.
        table: read-only ``int32`` array ``(n_states, 2 ** len(aps))`` of successors.
    """

    def __init__(self, formula: str, aps: tuple[str, ...], table: np.ndarray, accepting: np.ndarray) -> None:
        self.formula = formula
        self.aps = tuple(aps)
        self.initial = 0
        self.table = np.array(table, dtype=np.int32)
        self.n_states = int(self.table.shape[0])
        self.accepting_mask = np.array(accepting, dtype=bool)
        self.violated_mask = ~_coreachable(self.table, self.accepting_mask)
        self.satisfied_mask = ~_coreachable(self.table, ~self.accepting_mask)
        for array in (self.table, self.accepting_mask, self.violated_mask, self.satisfied_mask):
            array.setflags(write=False)
        self._rows: list[list[int]] = self.table.tolist()
        self._absorbing = [all(s == q for s in row) for q, row in enumerate(self._rows)]
        self._bits = {ap: 1 << i for i, ap in enumerate(self.aps)}

    @property
    def n_letters(self) -> int:
        return int(self.table.shape[1])

    def step(self, state: int, letter: int) -> int:
        """The successor of ``state`` on ``letter``."""
        return self._rows[state][letter]

    def accepting(self, state: int) -> bool:
        """Whether a trace ending in ``state`` satisfies the formula."""
        return bool(self.accepting_mask[state])

    def is_violated(self, state: int) -> bool:
        """Whether ``state`` is a rejecting sink: no accepting state is reachable from it."""
        return bool(self.violated_mask[state])

    def is_satisfied(self, state: int) -> bool:
        """Whether every state reachable from ``state`` accepts (the formula can no longer fail)."""
        return bool(self.satisfied_mask[state])

    def status(self, state: int) -> ConstraintStatus:
        """The four-valued status of ``state``."""
        if self.violated_mask[state]:
            return ConstraintStatus.PERMANENTLY_VIOLATED
        if self.satisfied_mask[state]:
            return ConstraintStatus.PERMANENTLY_SATISFIED
        if self.accepting_mask[state]:
            return ConstraintStatus.CURRENTLY_SATISFIED
        return ConstraintStatus.CURRENTLY_VIOLATED

    def letter(self, valuation: Mapping[str, bool]) -> int:
        """Encode a truth assignment (extra keys ignored; every proposition of ``aps`` required)."""
        letter = 0
        for ap, bit in self._bits.items():
            try:
                value = valuation[ap]
            except KeyError:
                msg = f"no truth value for proposition {ap!r} of formula {self.formula!r}"
                raise MgdataError(msg) from None
            if value:
                letter |= bit
        return letter

    def accepts(self, trace: Sequence[Mapping[str, bool]]) -> bool:
        """Whether the non-empty ``trace`` (one truth assignment per step) satisfies the formula."""
        if len(trace) == 0:
            raise MgdataError("LTL_f traces are non-empty; got an empty trace")
        state = self.initial
        for valuation in trace:
            state = self._rows[state][self.letter(valuation)]
        return self.accepting(state)

    def run(self, letters: Sequence[int] | np.ndarray, state: int | None = None) -> np.ndarray:
        """States after each letter, starting from ``state`` (default: initial), as an ``int16`` array.

        A compact loop over the precomputed letters that stops early in an absorbing state.
        """
        rows, absorbing = self._rows, self._absorbing
        seq = letters.tolist() if isinstance(letters, np.ndarray) else list(letters)
        out = np.empty(len(seq), dtype=np.int16)
        q = self.initial if state is None else state
        trail: list[int] = []
        for t, letter in enumerate(seq):
            q = rows[q][letter]
            trail.append(q)
            if absorbing[q]:
                out[: t + 1] = trail
                out[t + 1:] = q
                return out
        out[:] = trail
        return out

    def __repr__(self) -> str:
        return f"DFA({self.formula!r}, aps={self.aps}, n_states={self.n_states})"

    def _kind(self, q: int) -> str:
        kinds = ["initial"] if q == self.initial else []
        if self.violated_mask[q]:
            kinds.append("VIOLATED (rejecting sink)")
        elif self.satisfied_mask[q]:
            kinds.append("accepting, satisfied forever")
        else:
            kinds.append("accepting" if self.accepting_mask[q] else "not accepting")
        return ", ".join(kinds)

    def edges(self) -> list[tuple[int, str, int]]:
        """``(state, guard, successor)`` for every pair of states joined by some letter."""
        result = []
        for q, row in enumerate(self._rows):
            by_succ: dict[int, list[int]] = {}
            for letter, succ in enumerate(row):
                by_succ.setdefault(succ, []).append(letter)
            result.extend((q, guard(ls, self.aps), succ) for succ, ls in sorted(by_succ.items()))
        return result

    def __str__(self) -> str:
        lines = [f"LTL_f  {self.formula}"]
        if self.aps:
            bits = ", ".join(f"bit {i} = {ap}" for i, ap in enumerate(self.aps))
            lines.append(f"letters: {self.n_letters} ({bits})")
        lines.append(f"states: {self.n_states}, initial {self.initial}")
        for q in range(self.n_states):
            lines.append(f"  {q}: {self._kind(q)}")
        lines.append("transitions:")
        width = max(len(g) for _, g, _ in self.edges())
        lines.extend(f"  {q} --[ {g:<{width}} ]--> {s}" for q, g, s in self.edges())
        if self.n_letters <= 16:
            lines.append("table (row: state, column: letter):")
            head = "".join(f"{x:>4}" for x in range(self.n_letters))
            lines.append(f"  {'':>5}{head}")
            lines.extend(f"  {q:>5}" + "".join(f"{s:>4}" for s in row) for q, row in enumerate(self._rows))
        return "\n".join(lines)

    def to_dot(self) -> str:
        """Graphviz DOT text: double circles accept, the violated sink is filled red."""
        def quote(text: str) -> str:
            return '"' + text.replace("\\", "\\\\").replace('"', '\\"') + '"'

        lines = ["digraph dfa {", "  rankdir=LR;", f"  label={quote(self.formula)};", "  labelloc=t;",
                 "  node [shape=circle];", "  start [shape=point];", f"  start -> {self.initial};"]
        for q in range(self.n_states):
            attrs = ["shape=doublecircle"] if self.accepting_mask[q] else []
            if self.violated_mask[q]:
                attrs += ['style=filled', 'fillcolor="#f4a6a6"', f'label="{q}\\nviolated"']
            elif self.satisfied_mask[q]:
                attrs += ['style=filled', 'fillcolor="#b6e3b6"']
            lines.append(f"  {q} [{', '.join(attrs)}];" if attrs else f"  {q};")
        lines.extend(f"  {q} -> {s} [label={quote(g)}];" for q, g, s in self.edges())
        lines.append("}")
        return "\n".join(lines)
