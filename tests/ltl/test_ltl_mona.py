"""Differential tests against ltlf2dfa + MONA: exact language equality and equal state counts.

Language equality is decided exactly (breadth-first search of the product automaton over every letter),
not sampled. Both tools produce minimal DFAs, so the states reached by non-empty words must also be equal
in number; MONA's extra states are its dummy start and its empty-trace state.
"""

from __future__ import annotations

from collections.abc import Callable

import pytest
from hypothesis import HealthCheck, given, settings

from mgdata.ltl import compile_ltlf, parse
from mgdata.ltl.dfa import DFA
from mgdata.ltl.syntax import Formula
from tests.helpers.ltl_strategies import formulas
from tests.helpers.mona_oracle import MONA, MonaDfa, mona_dfa

pytest.importorskip("ltlf2dfa", reason="ltlf2dfa is a dev dependency (pip install -e .[dev])")
pytestmark = pytest.mark.skipif(MONA is None, reason="the MONA binary is missing: apt-get install mona")

FAMILY_FORMULAS = [  # the constraints of the seven family specs (recipes/specs/*.toml)
    "G !target_dropped", "G target_upright", "G !obstacles_dropped", "G obstacles_upright",
    "G !liquid_spilled", "G !container_dropped", "G container_upright",
    "container_on_support W lid_on_container", "jar_on_support W jar_closed", "G !jar_dropped",
    "G jar_upright", "G !food_touched", "G !food_dropped", "G (!stack_dropped & stack_upright)",
    "(jar_on_support W jar_closed) & G (!jar_dropped & jar_upright)",  # the monolithic jar conjunction
    "G (a -> X b)", "a U X WX b", "F G a <-> G F a", "X X X a", "(a R b) W (c U !d)",
]


def _check_against_mona(f: Formula) -> None:
    ours = compile_ltlf(str(f))
    theirs = mona_dfa(f, ours.aps)
    _assert_same_language(ours, theirs)
    assert _count_nonempty_reachable(ours.step, ours.initial, ours.n_letters) == _count_nonempty_reachable(
        lambda q, x: theirs.delta[q][x], theirs.start(), ours.n_letters), str(f)


def _assert_same_language(ours: DFA, theirs: MonaDfa) -> None:
    """Every non-empty word leads to states that agree on acceptance."""
    start = [(ours.step(ours.initial, x), theirs.delta[theirs.start()][x]) for x in range(ours.n_letters)]
    seen, todo = set(start), list(start)
    while todo:
        p, q = todo.pop()
        assert ours.accepting(p) == (q in theirs.accepting), f"{ours.formula}: differs from MONA"
        for x in range(ours.n_letters):
            nxt = (ours.step(p, x), theirs.delta[q][x])
            if nxt not in seen:
                seen.add(nxt)
                todo.append(nxt)


def _count_nonempty_reachable(step: Callable[[int, int], int], start: int, n_letters: int) -> int:
    frontier = {step(start, x) for x in range(n_letters)}
    seen = set(frontier)
    while frontier:
        frontier = {step(q, x) for q in frontier for x in range(n_letters)} - seen
        seen |= frontier
    return len(seen)


@pytest.mark.parametrize("text", FAMILY_FORMULAS)
def test_family_and_sample_formulas_match_mona(text: str) -> None:
    _check_against_mona(parse(text))


@settings(derandomize=True, max_examples=120, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(formulas(depth=4))
def test_random_formulas_match_mona(f: Formula) -> None:
    _check_against_mona(f)
