"""Parser: precedence, associativity, round trips and syntax-error messages."""

from __future__ import annotations

import pytest

from mgdata.errors import LtlSyntaxError
from mgdata.ltl import parse


@pytest.mark.parametrize(("text", "tree"), [
    ("a & b | c", "((a & b) | c)"),
    ("a | b & c", "(a | (b & c))"),
    ("a -> b -> c", "(a -> (b -> c))"),
    ("a <-> b -> c", "(a <-> (b -> c))"),
    ("a | b -> c", "((a | b) -> c)"),
    ("a U b U c", "(a U (b U c))"),
    ("a W b R c", "(a W (b R c))"),
    ("a U b & c", "((a U b) & c)"),
    ("!a U b", "(!a U b)"),
    ("G !a & F b", "(G !a & F b)"),
    ("X WX a", "X WX a"),
    ("GFa", "G F a"),
    ("G(!a)", "G !a"),
    ("a W X b", "(a W X b)"),
    ("(a & b) U c", "((a & b) U c)"),
    ("true U false", "(true U false)"),
    ("_a1 & b_2", "(_a1 & b_2)"),
    ("  jar_on_support  W  jar_closed ", "(jar_on_support W jar_closed)"),
])
def test_precedence_and_associativity(text: str, tree: str) -> None:
    assert str(parse(text)) == tree
    assert parse(tree) == parse(text)


@pytest.mark.parametrize(("text", "message"), [
    ("", "expected a formula, found nothing"),
    ("a &", "at column 4: expected an operand (proposition, 'true', 'false', '(' or one of ! X WX F G), "
            "found end of formula"),
    ("(a | b", "at column 7: expected ')' or a binary operator, found end of formula"),
    ("a b", "at column 3: expected a binary operator (& | -> <-> U W R) or end of formula, found 'b'"),
    ("a WX b", "found 'WX' ('WX' is weak next; for W followed by X write 'W X')"),
    ("a & jarClosed", "at column 8: expected an operator or a proposition, found 'C' (proposition names "
                      "are lower case"),
    ("a && b", "at column 4: expected an operand"),
    ("a # b", "at column 3: expected an operator or a proposition, found '#'"),
    (")", "at column 1: expected an operand"),
    ("G", "at column 2: expected an operand"),
])
def test_syntax_errors_name_the_column_and_what_was_expected(text: str, message: str) -> None:
    with pytest.raises(LtlSyntaxError) as err:
        parse(text)
    assert message in str(err.value)
    assert repr(text) in str(err.value)
