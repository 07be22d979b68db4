"""The documented LTL_f limits (docs/ltl.md): refused with one clear error, never a RecursionError, a
compile that runs for minutes or one that exhausts memory; formulas at the limits still compile."""

from __future__ import annotations

import subprocess
import sys
import time

import pytest

from mgdata.errors import LtlLimitError, LtlSyntaxError, SpecError
from mgdata.ltl import Monitor, compile_ltlf, parse
from mgdata.ltl.parser import MAX_DEPTH, MAX_LENGTH, MAX_PROPOSITIONS
from mgdata.spec import Constraint, Proposition, SafetySpec

MGDATA = "import sys; from mgdata.cli import main; sys.argv = ['mgdata', *sys.argv[1:]]; main()"


def _cold(formula: str) -> None:
    compile_ltlf.cache_clear()
    compile_ltlf(formula)


@pytest.mark.parametrize(("formula", "fragment"), [
    ("(" * 200 + "a" + ")" * 200, f"more than {MAX_DEPTH} levels of nesting at column {MAX_DEPTH + 1}"),
    ("!" * 200 + "a", f"more than {MAX_DEPTH} levels of nesting"),
    (" U ".join(["a"] * 100), f"more than {MAX_DEPTH} levels of nesting"),
    (" & ".join(["a"] * 500), f"1997 characters long; the limit is {MAX_LENGTH}"),
    (" & ".join(["a"] * 200), f"nests 199 operators deep; the limit is {MAX_DEPTH}"),
    (" | ".join(f"p{i}" for i in range(14)), f"14 distinct propositions; the limit is {MAX_PROPOSITIONS}"),
    (" & ".join(f"p{i}" for i in range(64)), "uses 64 distinct propositions"),
    ("G(a -> " + "X " * 18 + "b)", "too complex to monitor: it needs more than 4096 automaton states"),
    ("G(a -> " + " U ".join(f"p{i % 6}" for i in range(30)) + ")", "it needs more than 2,000,000 work units"),
])
def test_formulas_beyond_the_limits_are_refused_quickly(formula: str, fragment: str) -> None:
    start = time.perf_counter()
    with pytest.raises(LtlLimitError) as err:
        _cold(formula)
    assert fragment in str(err.value)
    assert isinstance(err.value, LtlSyntaxError) and "\n" not in str(err.value) and len(str(err.value)) < 300
    assert time.perf_counter() - start < 30  # 98 s and out-of-memory before; ~1.5 s at most measured


def test_formulas_at_the_limits_compile() -> None:
    at_depth = "(" * (MAX_DEPTH - 1) + "G a" + ")" * (MAX_DEPTH - 1)
    assert compile_ltlf(at_depth).n_states == compile_ltlf("G a").n_states
    chain = " & ".join(["a"] * (MAX_DEPTH + 1))  # a chain of n operands nests n - 1 deep
    assert compile_ltlf(chain).aps == ("a",)
    many = " & ".join(f"G p{i}" for i in range(MAX_PROPOSITIONS))
    assert len(compile_ltlf(many).aps) == MAX_PROPOSITIONS
    long = "G(" + " | ".join(["a"] * 30) + ")"
    assert len(long) <= MAX_LENGTH and parse(long) is not None


def test_a_spec_constraint_beyond_the_limits_is_a_spec_error() -> None:
    props = tuple(Proposition(f"p{i}", "dropped", ("jar",)) for i in range(10))
    formula = " & ".join(f"G !p{i}" for i in range(10))
    spec = SafetySpec("big", (Constraint("all", formula, "none drops"),), props)
    with pytest.raises(SpecError, match="uses 10 distinct propositions; the limit is 8"):
        Monitor(spec)


def test_cli_prints_one_line_for_a_formula_beyond_the_limits() -> None:
    out = subprocess.run([sys.executable, "-c", MGDATA, "ltl", "(" * 200 + "a" + ")" * 200],
                         capture_output=True, text=True, timeout=120)
    assert out.returncode == 2 and out.stdout == "" and "Traceback" not in out.stderr
    lines = out.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: LTL_f formula '((((") and "nesting" in lines[0]
