"""LTL_f to DFA by formula progression (exact; the result is minimised by :mod:`mgdata.ltl.minimize`).

The formula is put in negation normal form over ``true false p !p & | X WX U R`` and its nodes are interned.
Reading a letter *progresses* a node into a positive Boolean combination of two kinds of atoms about the
rest of the trace: ``next`` ("a next step exists") and ``weak(f)`` ("the next step, if any, satisfies f"),
with ``weak`` split over ``&``/``|`` (it distributes over both). A strong next is ``next & weak(f)``, and

    prog(X f) = next & weak(f)          prog(WX f) = weak(f)
    prog(f U g) = prog(g) | (prog(f) & next & weak(f U g))
    prog(f R g) = prog(g) & (prog(f) | weak(f R g))

A DFA state is such a combination kept in its unique canonical form (the antichain of minimal terms of a
monotone DNF), so the reachable state set is finite and explored exactly. A state accepts when the trace may
end there: some term does not need ``next`` (``weak`` atoms hold vacuously at the end). On the next letter,
``next`` becomes true and ``weak(f)`` becomes ``prog(f)``. The initial state is ``next & weak(formula)``, so
the empty trace is never accepted (LTL_f traces are non-empty).

Successors are computed once per assignment of the propositions the state actually reads now, and spread
over the full letter row with numpy.

Exploration is bounded (:data:`MAX_STATES`, :data:`MAX_WORK`): a formula whose automaton is too large to
build quickly is rejected with :class:`mgdata.errors.LtlLimitError` instead of running for minutes or
exhausting memory (``G(a -> X X … X b)`` with 18 ``X`` has 2^18 states). The bounds are measured in
``benchmarks/bench_ltl.py`` and documented in ``docs/ltl.md``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from mgdata.errors import LtlLimitError
from mgdata.ltl.parser import quoted
from mgdata.ltl.syntax import Binary, Const, Formula, Prop, Unary

Term = frozenset[int]  # atom 0: "a next step exists"; atom n + 1: "a next step, if any, satisfies node n"
Dnf = frozenset[Term]
_NEXT = 0
_NO_NEXT = 2  # the weak obligation on node 1 (false): "there is no next step"
_TRUE: Dnf = frozenset({frozenset()})
_FALSE: Dnf = frozenset()
_HAS_NEXT: Dnf = frozenset({frozenset({_NEXT})})

MAX_STATES = 4096
"""Most states the (unminimised) progression automaton of one constraint may have."""
MAX_WORK = 2_000_000
"""Most work units exploring one constraint may take: a successor computation costs ``1 + n (1 + m)``
for ``n`` candidate terms reduced to ``m`` (the quadratic canonicalisation), plus ``a b`` for each product
of an ``a``-term and a ``b``-term formula it forms."""


@dataclass(frozen=True)
class RawAutomaton:
    """A complete reachable DFA, not yet minimal: ``table[state, letter]``, ``accepting[state]``, start 0."""

    table: np.ndarray
    accepting: np.ndarray


class _Nodes:
    """Interned NNF nodes: tuples ``("T",) ("F",) ("L", bit, positive) ("&", ids) ("|", ids) ("X", id)
    ("N", id) ("U", a, b) ("R", a, b)``, with ``N`` the weak next."""

    def __init__(self, aps: tuple[str, ...]) -> None:
        self.bit = {ap: i for i, ap in enumerate(aps)}
        self.nodes: list[tuple] = []
        self.ids: dict[tuple, int] = {}
        self.now_mask: list[int] = []  # the proposition bits a node reads at the current step
        self.true = self.intern(("T",))
        self.false = self.intern(("F",))
        self._nnf: dict[tuple[Formula, bool], int] = {}

    def intern(self, node: tuple) -> int:
        found = self.ids.get(node)
        if found is not None:
            return found
        nid = len(self.nodes)
        self.nodes.append(node)
        self.ids[node] = nid
        kind = node[0]
        if kind == "L":
            mask = 1 << node[1]
        elif kind in ("&", "|"):
            mask = 0
            for child in node[1]:
                mask |= self.now_mask[child]
        elif kind in ("U", "R"):
            mask = self.now_mask[node[1]] | self.now_mask[node[2]]
        else:
            mask = 0
        self.now_mask.append(mask)
        return nid

    def junction(self, kind: str, children: list[int]) -> int:
        """``&`` or ``|`` of ``children``, flattened, deduplicated, with constants folded."""
        unit, zero = (self.true, self.false) if kind == "&" else (self.false, self.true)
        flat: set[int] = set()
        for child in children:
            node = self.nodes[child]
            if child == zero:
                return zero
            if node[0] == kind:
                flat.update(node[1])
            elif child != unit:
                flat.add(child)
        if not flat:
            return unit
        if len(flat) == 1:
            return next(iter(flat))
        return self.intern((kind, tuple(sorted(flat))))

    def nnf(self, f: Formula, positive: bool = True) -> int:
        """The interned negation normal form of ``f`` (of ``!f`` when ``positive`` is false)."""
        key = (f, positive)
        found = self._nnf.get(key)
        if found is None:
            found = self._nnf[key] = self._build(f, positive)
        return found

    def _build(self, f: Formula, pos: bool) -> int:
        if isinstance(f, Const):
            return self.true if f.value == pos else self.false
        if isinstance(f, Prop):
            return self.intern(("L", self.bit[f.name], pos))
        if isinstance(f, Unary):
            a = f.arg
            if f.op == "!":
                return self.nnf(a, not pos)
            if f.op in ("X", "WX"):
                strong = (f.op == "X") == pos
                return self.intern(("X" if strong else "N", self.nnf(a, pos)))
            if (f.op == "F") == pos:  # F a, or !G a = F !a
                return self.intern(("U", self.true, self.nnf(a, pos)))
            return self.intern(("R", self.false, self.nnf(a, pos)))  # G a, or !F a = G !a
        return self._binary(f, pos)

    def _binary(self, f: Binary, pos: bool) -> int:
        a, b, op = f.left, f.right, f.op
        if op in ("&", "|"):
            kind = op if pos else ("|" if op == "&" else "&")
            return self.junction(kind, [self.nnf(a, pos), self.nnf(b, pos)])
        if op == "->":
            if pos:
                return self.junction("|", [self.nnf(a, False), self.nnf(b, True)])
            return self.junction("&", [self.nnf(a, True), self.nnf(b, False)])
        if op == "<->":
            same = self.junction("&", [self.nnf(a, True), self.nnf(b, pos)])
            other = self.junction("&", [self.nnf(a, False), self.nnf(b, not pos)])
            return self.junction("|", [same, other])
        if op == "W":  # a W b = b R (a | b);  !(a W b) = !b U (!a & !b)
            either = self.junction("|" if pos else "&", [self.nnf(a, pos), self.nnf(b, pos)])
            return self.intern(("R" if pos else "U", self.nnf(b, pos), either))
        kind = op if pos else ("R" if op == "U" else "U")
        return self.intern((kind, self.nnf(a, pos), self.nnf(b, pos)))


def _absorb(terms: set[Term]) -> Dnf:
    """Canonical form: drop contradictory terms (next step both required and excluded) and every term
    that contains another term."""
    kept: list[Term] = []
    for term in sorted(terms, key=len):
        if _NEXT in term and _NO_NEXT in term:
            continue
        if not any(k <= term for k in kept):
            kept.append(term)
    return frozenset(kept)


def _or(a: Dnf, b: Dnf) -> Dnf:
    return _absorb(set(a) | set(b))


def _and(a: Dnf, b: Dnf) -> Dnf:
    if a == _TRUE:
        return b
    if b == _TRUE:
        return a
    return _absorb({x | y for x in a for y in b})


class _Progressor:
    """Memoised progression of interned nodes through letters, and successors of states."""

    def __init__(self, nodes: _Nodes) -> None:
        self.nodes = nodes
        self.work = 0
        self.memo: dict[tuple[int, int], Dnf] = {}
        self.obligations: dict[int, Dnf] = {}
        self.terms: dict[tuple[Term, int], Dnf] = {}

    def weak(self, nid: int) -> Dnf:
        """"If there is a next step, it satisfies node ``nid``", split over ``&``/``|`` into atoms."""
        found = self.obligations.get(nid)
        if found is None:
            node = self.nodes.nodes[nid]
            if node[0] == "T":
                found = _TRUE
            elif node[0] in ("&", "|"):
                combine, found = (_and, _TRUE) if node[0] == "&" else (_or, _FALSE)
                for child in node[1]:
                    found = combine(found, self.weak(child))
            else:
                found = frozenset({frozenset({nid + 1})})
            self.obligations[nid] = found
        return found

    def strong(self, nid: int) -> Dnf:
        """"There is a next step and it satisfies node ``nid``"."""
        return _and(_HAS_NEXT, self.weak(nid))

    def prog(self, nid: int, letter: int) -> Dnf:
        key = (nid, letter & self.nodes.now_mask[nid])
        found = self.memo.get(key)
        if found is None:
            found = self.memo[key] = self._prog(nid, key[1])
        return found

    def _prog(self, nid: int, letter: int) -> Dnf:
        node = self.nodes.nodes[nid]
        kind = node[0]
        if kind == "T":
            return _TRUE
        if kind == "F":
            return _FALSE
        if kind == "L":
            return _TRUE if bool(letter >> node[1] & 1) == node[2] else _FALSE
        if kind == "X":
            return self.strong(node[1])
        if kind == "N":
            return self.weak(node[1])
        if kind in ("&", "|"):
            combine, result = (_and, _TRUE) if kind == "&" else (_or, _FALSE)
            for child in node[1]:
                result = combine(result, self.prog(child, letter))
            return result
        left, right = self.prog(node[1], letter), self.prog(node[2], letter)
        if kind == "U":
            return _or(right, _and(left, self.strong(nid)))
        return _and(right, _or(left, self.weak(nid)))

    def step(self, state: Dnf, letter: int) -> Dnf:
        """The successor of ``state`` once the next step exists and reads ``letter``."""
        terms: set[Term] = set()
        for term in state:
            key = (term, letter)
            conj = self.terms.get(key)
            if conj is None:
                conj = _TRUE
                for atom in term:
                    if atom != _NEXT:
                        factor = self.prog(atom - 1, letter)
                        self.work += len(conj) * len(factor)
                        conj = _and(conj, factor)
                        if not conj:
                            break
                self.terms[key] = conj
            terms.update(conj)
        succ = _absorb(terms)
        self.work += 1 + len(terms) * (1 + len(succ))
        return succ


def _submasks(mask: int) -> list[int]:
    """All ``s`` with ``s & ~mask == 0``, ascending."""
    subs = []
    sub = mask
    while True:
        subs.append(sub)
        if sub == 0:
            return subs[::-1]
        sub = (sub - 1) & mask


def explore(formula: Formula, aps: tuple[str, ...], text: str = "") -> RawAutomaton:
    """Build the reachable progression DFA of ``formula`` over the letters of ``aps`` (bit i = ``aps[i]``).

    Raises:
        LtlLimitError: more than :data:`MAX_STATES` states or :data:`MAX_WORK` work units (``text``, the
            formula as written, names it in the message).
    """
    nodes = _Nodes(aps)
    root = nodes.nnf(formula)
    progressor = _Progressor(nodes)
    n_letters = 1 << len(aps)
    letters = np.arange(n_letters)
    initial = progressor.strong(root)
    states: list[Dnf] = [initial]
    index: dict[Dnf, int] = {initial: 0}
    rows: list[np.ndarray] = []
    lut = np.zeros(n_letters, dtype=np.int32)
    i = 0
    while i < len(states):
        state = states[i]
        mask = 0
        for term in state:
            for atom in term:
                if atom != _NEXT:
                    mask |= nodes.now_mask[atom - 1]
        for sub in _submasks(mask):
            succ = progressor.step(state, sub)
            if succ not in index:
                index[succ] = len(states)
                states.append(succ)
            lut[sub] = index[succ]
            if len(states) > MAX_STATES or progressor.work > MAX_WORK:
                what = (f"more than {MAX_STATES} automaton states" if len(states) > MAX_STATES else
                        f"more than {MAX_WORK:,} work units to build its automaton")
                shown = quoted(text or str(formula))
                raise LtlLimitError(f"LTL_f formula {shown} is too complex to monitor: it needs {what}; "
                                    "split it into several constraints or use fewer nested X/U/F/G operators")
        rows.append(lut[letters & mask])
        i += 1
    accepting = np.array([any(_NEXT not in term for term in s) for s in states], dtype=bool)
    return RawAutomaton(np.stack(rows).astype(np.int32), accepting)
