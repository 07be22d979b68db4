"""Shared helpers for the LTL tests: random formulas/traces and independent brute-force DFA checks."""

from __future__ import annotations

import random

from hypothesis import strategies as st

from mgdata.ltl.dfa import DFA
from mgdata.ltl.syntax import BINARY_OPS, UNARY_OPS, Binary, Const, Formula, Prop, Unary

APS = ("a", "b", "c", "d")


@st.composite
def formulas(draw: st.DrawFn, depth: int = 5, aps: tuple[str, ...] = APS) -> Formula:
    """Random formulas over ``aps`` with every operator, nesting depth at most ``depth``."""
    if depth == 0 or draw(st.integers(0, 5)) == 0:
        if draw(st.integers(0, 9)) == 0:
            return Const(draw(st.booleans()))
        return Prop(draw(st.sampled_from(aps)))
    if draw(st.booleans()):
        return Unary(draw(st.sampled_from(UNARY_OPS)), draw(formulas(depth - 1, aps)))
    op = draw(st.sampled_from(BINARY_OPS))
    return Binary(op, draw(formulas(depth - 1, aps)), draw(formulas(depth - 1, aps)))


def random_traces(seed: int, count: int, aps: tuple[str, ...] = APS, max_len: int = 10) -> list[list[dict]]:
    """``count`` traces of length 1..``max_len`` with a per-trace bias, so long runs of a value occur."""
    rnd = random.Random(seed)
    traces = []
    for _ in range(count):
        p = rnd.choice((0.1, 0.5, 0.9))
        traces.append([{ap: rnd.random() < p for ap in aps} for _ in range(rnd.randint(1, max_len))])
    return traces


def reachable(dfa: DFA, start: int) -> set[int]:
    """States reachable from ``start`` in zero or more steps (plain BFS)."""
    seen, todo = {start}, [start]
    while todo:
        q = todo.pop()
        for letter in range(dfa.n_letters):
            s = dfa.step(q, letter)
            if s not in seen:
                seen.add(s)
                todo.append(s)
    return seen


def distinguishable_pairs(dfa: DFA) -> set[tuple[int, int]]:
    """Table-filling (Myhill–Nerode): pairs ``p < q`` told apart by some word."""
    n = dfa.n_states
    marked = {(p, q) for p in range(n) for q in range(p + 1, n) if dfa.accepting(p) != dfa.accepting(q)}
    changed = True
    while changed:
        changed = False
        for p in range(n):
            for q in range(p + 1, n):
                if (p, q) in marked:
                    continue
                for letter in range(dfa.n_letters):
                    x, y = sorted((dfa.step(p, letter), dfa.step(q, letter)))
                    if x != y and (x, y) in marked:
                        marked.add((p, q))
                        changed = True
                        break
    return marked
