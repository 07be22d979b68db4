"""The DFA object: the jar example, stepping, errors, printing, caching, vectorised runs."""

from __future__ import annotations

import numpy as np
import pytest

from mgdata.errors import LtlSyntaxError, MgdataError
from mgdata.ltl import ConstraintStatus, compile_ltlf


def test_weak_until_jar_example() -> None:
    dfa = compile_ltlf("jar_on_support W jar_closed")
    assert dfa.aps == ("jar_closed", "jar_on_support")
    assert dfa.n_states == 4 and dfa.initial == 0 and dfa.table.shape == (4, 4)
    on, closed, lifted = {"jar_on_support": True, "jar_closed": False}, \
        {"jar_on_support": True, "jar_closed": True}, {"jar_on_support": False, "jar_closed": False}
    assert dfa.accepts([on, on, on])           # never closed, never lifted: W holds
    assert dfa.accepts([on, closed, lifted])   # lifted after closing
    assert not dfa.accepts([on, lifted, closed])
    q = dfa.step(dfa.initial, dfa.letter(on))
    assert dfa.status(q) is ConstraintStatus.CURRENTLY_SATISFIED
    assert dfa.status(dfa.step(q, dfa.letter(closed))) is ConstraintStatus.PERMANENTLY_SATISFIED
    sink = dfa.step(q, dfa.letter(lifted))
    assert dfa.is_violated(sink) and dfa.status(sink) is ConstraintStatus.PERMANENTLY_VIOLATED
    assert not dfa.accepting(dfa.initial)      # the empty trace is not a trace


def test_strong_and_weak_next_differ_only_at_the_end() -> None:
    strong, weak = compile_ltlf("X a"), compile_ltlf("WX a")
    assert not strong.accepts([{"a": True}]) and weak.accepts([{"a": False}])
    for dfa in (strong, weak):
        assert dfa.accepts([{"a": False}, {"a": True}]) and not dfa.accepts([{"a": True}, {"a": False}])


def test_unsatisfiable_formula_is_a_single_sink_and_valid_one_never_violates() -> None:
    assert compile_ltlf("a & !a").n_states == 1 and compile_ltlf("a & !a").is_violated(0)
    valid = compile_ltlf("G (a | !a)")
    assert not valid.violated_mask.any() and valid.accepts([{"a": False}])


def test_compile_is_cached_and_arrays_are_read_only() -> None:
    dfa = compile_ltlf("G !jar_dropped")
    assert compile_ltlf("G !jar_dropped") is dfa
    with pytest.raises(ValueError, match="read-only"):
        dfa.table[0, 0] = 1


def test_bad_traces_and_formulas_raise_clear_errors() -> None:
    dfa = compile_ltlf("a U b")
    with pytest.raises(MgdataError, match="non-empty"):
        dfa.accepts([])
    with pytest.raises(MgdataError, match="no truth value for proposition 'b' of formula 'a U b'"):
        dfa.accepts([{"a": True}])
    with pytest.raises(LtlSyntaxError, match="column 4: expected an operand"):
        compile_ltlf("a U")


def test_run_matches_python_steps_and_stops_early_in_sinks() -> None:
    dfa = compile_ltlf("G (a -> X b)")
    rng = np.random.default_rng(0)
    for _ in range(20):
        letters = rng.integers(0, dfa.n_letters, rng.integers(1, 40))
        expected, q = [], dfa.initial
        for x in letters:
            q = dfa.step(q, int(x))
            expected.append(q)
        got = dfa.run(letters)
        assert got.dtype == np.int16 and got.tolist() == expected


def test_text_and_dot_rendering() -> None:
    dfa = compile_ltlf("jar_on_support W jar_closed")
    text = str(dfa)
    assert "LTL_f  jar_on_support W jar_closed" in text
    assert "bit 0 = jar_closed, bit 1 = jar_on_support" in text
    assert "1: VIOLATED (rejecting sink)" in text
    assert "0 --[ !jar_closed & !jar_on_support ]--> 1" in text
    assert "table (row: state, column: letter)" in text
    dot = dfa.to_dot()
    assert dot.startswith("digraph dfa {") and dot.rstrip().endswith("}")
    assert 'label="1\\nviolated"' in dot and "start -> 0;" in dot
    assert '0 -> 2 [label="jar_closed"];' in dot
