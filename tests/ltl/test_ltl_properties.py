"""Property tests: compiled DFAs against the direct recursive LTL_f semantics, sink exactness, minimality."""

from __future__ import annotations

from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from mgdata.ltl import compile_ltlf, holds, parse
from mgdata.ltl.status import ConstraintStatus
from mgdata.ltl.syntax import Formula
from tests.helpers.ltl_strategies import distinguishable_pairs, formulas, random_traces, reachable

FIXED = settings(derandomize=True, deadline=None, suppress_health_check=[HealthCheck.too_slow])


@settings(FIXED, max_examples=2500)
@given(formulas(), st.integers(0, 2**32 - 1))
def test_dfa_accepts_exactly_the_traces_that_satisfy_the_formula(f: Formula, seed: int) -> None:
    text = str(f)
    assert parse(text) == f  # the printer and the parser agree
    dfa = compile_ltlf(text)
    for trace in random_traces(seed, 25):
        assert dfa.accepts(trace) == holds(f, trace), (text, trace)


@settings(FIXED, max_examples=600)
@given(formulas())
def test_violated_states_are_exactly_those_with_no_reachable_accepting_state(f: Formula) -> None:
    dfa = compile_ltlf(str(f))
    for q in range(dfa.n_states):
        ahead = reachable(dfa, q)
        assert dfa.is_violated(q) == (not any(dfa.accepting(s) for s in ahead))
        assert dfa.is_satisfied(q) == all(dfa.accepting(s) for s in ahead)
        status = dfa.status(q)
        if dfa.is_violated(q):
            assert status is ConstraintStatus.PERMANENTLY_VIOLATED
            assert all(dfa.step(q, letter) == q for letter in range(dfa.n_letters))  # a true sink
        elif not dfa.is_satisfied(q):
            expected = ConstraintStatus.CURRENTLY_SATISFIED if dfa.accepting(q) else \
                ConstraintStatus.CURRENTLY_VIOLATED
            assert status is expected
    assert int(dfa.violated_mask.sum()) <= 1  # minimal: at most one rejecting sink


@settings(FIXED, max_examples=600)
@given(formulas())
def test_dfa_is_minimal_by_myhill_nerode(f: Formula) -> None:
    """Every state reachable, every pair of states distinguishable (an independent table-filling check)."""
    dfa = compile_ltlf(str(f))
    assert reachable(dfa, dfa.initial) == set(range(dfa.n_states))
    if dfa.n_states <= 40:  # the quadratic check stays cheap
        n = dfa.n_states
        assert len(distinguishable_pairs(dfa)) == n * (n - 1) // 2


@settings(FIXED, max_examples=300)
@given(formulas(depth=3), formulas(depth=3))
def test_equivalent_formulas_get_identical_canonical_tables(f: Formula, g: Formula) -> None:
    """States are numbered canonically, so language-equal formulas compile to the same table."""
    from mgdata.ltl.syntax import Binary, Unary

    pairs = [(Binary("W", f, g), Binary("|", Binary("U", f, g), Unary("G", f))),
             (Binary("R", f, g), Unary("!", Binary("U", Unary("!", f), Unary("!", g)))),
             (Unary("G", f), Binary("R", parse("false"), f)),
             (Unary("WX", f), Unary("!", Unary("X", Unary("!", f))))]
    for left, right in pairs:
        a, b = compile_ltlf(str(left)), compile_ltlf(str(right))
        if a.aps == b.aps:
            assert (a.table == b.table).all() and (a.accepting_mask == b.accepting_mask).all(), (left, right)
