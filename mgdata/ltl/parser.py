"""Parse LTL_f formula text into a :mod:`mgdata.ltl.syntax` tree.

Grammar (loosest binding first)::

    formula := implication
    implication := or (("->" | "<->") implication)?      right-associative
    or := and ("|" and)*
    and := temporal ("&" temporal)*
    temporal := unary (("U" | "W" | "R") temporal)?      right-associative
    unary := ("!" | "X" | "WX" | "F" | "G") unary | atom
    atom := "true" | "false" | identifier | "(" formula ")"

Identifiers are ``[a-z_][a-z0-9_]*``; operators are upper case, so ``G!a`` and ``G (!a)`` read the same.
``WX`` (weak next) is one token: write ``a W X b`` for "a weak-until next b".

Limits (each a clear :class:`mgdata.errors.LtlLimitError`, never a ``RecursionError`` or a compile that runs
for minutes): at most :data:`MAX_LENGTH` characters, :data:`MAX_DEPTH` levels of nesting (parentheses,
operators, and operands chained by one operator all count), and :data:`MAX_PROPOSITIONS` distinct
propositions per formula (its automaton reads ``2^k`` letters). See ``docs/ltl.md``.

Example::

    >>> str(parse("a W b & G !c"))
    '((a W b) & G !c)'
"""

from __future__ import annotations

import re
from dataclasses import dataclass

from mgdata.errors import LtlLimitError, LtlSyntaxError
from mgdata.ltl.syntax import Binary, Const, Formula, Prop, Unary, depth, propositions

_TOKEN = re.compile(r"\s*(?:(?P<ident>[a-z_][a-z0-9_]*)|(?P<op><->|->|WX|[!&|()XFGUWR]))")
_OPERAND = "an operand (proposition, 'true', 'false', '(' or one of ! X WX F G)"
_KEYWORDS = ("true", "false")

MAX_LENGTH = 1000
"""Most characters in one formula."""
MAX_DEPTH = 32
"""Most nesting levels in one formula: of its syntax tree, and of parentheses and operators as written."""
MAX_PROPOSITIONS = 8
"""Most distinct propositions in one formula (one constraint): its DFA has ``2^k`` letters per state."""


@dataclass(frozen=True)
class Token:
    """One lexical token: ``kind`` is ``"ident"``, ``"op"`` or ``"end"``; ``pos`` is its 0-based offset."""

    kind: str
    text: str
    pos: int


def tokenize(text: str) -> list[Token]:
    """Split ``text`` into tokens, ending with an ``end`` token; raises :class:`LtlSyntaxError`."""
    tokens: list[Token] = []
    pos = 0
    while True:
        while pos < len(text) and text[pos].isspace():
            pos += 1
        if pos == len(text):
            tokens.append(Token("end", "", pos))
            return tokens
        match = _TOKEN.match(text, pos)
        if match is None:
            char = text[pos]
            hint = (" (proposition names are lower case: [a-z_][a-z0-9_]*)" if char.isalnum() else "")
            raise _error(text, pos, "an operator or a proposition", repr(char) + hint)
        kind = "ident" if match.group("ident") else "op"
        tokens.append(Token(kind, match.group(kind), match.start(kind)))
        pos = match.end()


def parse(text: str) -> Formula:
    """Parse an LTL_f formula; raises :class:`LtlSyntaxError` naming the column and what was expected, or
    :class:`LtlLimitError` for a formula beyond the documented limits."""
    if len(text) > MAX_LENGTH:
        raise LtlLimitError(f"LTL_f formula {quoted(text)} is {len(text)} characters long; the limit is "
                            f"{MAX_LENGTH} (split it into several constraints)")
    tree = _Parser(text).parse()
    aps = propositions(tree)
    if len(aps) > MAX_PROPOSITIONS:
        raise LtlLimitError(f"LTL_f formula {quoted(text)} uses {len(aps)} distinct propositions; the limit "
                            f"is {MAX_PROPOSITIONS} per constraint (split it into several constraints)")
    if depth(tree) > MAX_DEPTH:
        raise LtlLimitError(f"LTL_f formula {quoted(text)} nests {depth(tree)} operators deep; the limit is "
                            f"{MAX_DEPTH} (a chain of n '&' or '|' counts n - 1; split it into several "
                            "constraints)")
    return tree


def quoted(text: str) -> str:
    """The formula for a message: quoted, cut to 60 characters."""
    return repr(text) if len(text) <= 60 else repr(text[:57]) + "…"


def _error(text: str, pos: int, expected: str, found: str) -> LtlSyntaxError:
    where = f"bad LTL_f formula {quoted(text)}: at column {pos + 1}"
    return LtlSyntaxError(f"{where}: expected {expected}, found {found}")


def _describe(token: Token) -> str:
    return "end of formula" if token.kind == "end" else repr(token.text)


class _Parser:
    """Recursive-descent parser over the token list (one method per precedence level)."""

    def __init__(self, text: str) -> None:
        self.text = text
        self.tokens = tokenize(text)
        self.i = 0
        self.nesting = 0  # parentheses, unary and right-associative operators currently open

    def deeper(self, token: Token) -> None:
        """Open one more nesting level at ``token`` (bounded, so the recursion stays shallow)."""
        self.nesting += 1
        if self.nesting > MAX_DEPTH:
            raise LtlLimitError(f"LTL_f formula {quoted(self.text)}: more than {MAX_DEPTH} levels of nesting "
                                f"at column {token.pos + 1}; the limit is {MAX_DEPTH}")

    def parse(self) -> Formula:
        if self.tokens[0].kind == "end":
            raise _error(self.text, 0, "a formula", "nothing")
        node = self.implication()
        token = self.peek()
        if token.kind != "end":
            expected = "a binary operator (& | -> <-> U W R) or end of formula"
            found = _describe(token)
            if token.text == "WX":
                found += " ('WX' is weak next; for W followed by X write 'W X')"
            raise _error(self.text, token.pos, expected, found)
        return node

    def peek(self) -> Token:
        return self.tokens[self.i]

    def take(self) -> Token:
        token = self.tokens[self.i]
        self.i += 1
        return token

    def at(self, *ops: str) -> bool:
        token = self.peek()
        return token.kind == "op" and token.text in ops

    def implication(self) -> Formula:
        left = self.disjunction()
        if self.at("->", "<->"):
            self.deeper(self.peek())
            op = self.take().text
            node = Binary(op, left, self.implication())
            self.nesting -= 1
            return node
        return left

    def disjunction(self) -> Formula:
        node = self.conjunction()
        while self.at("|"):
            self.take()
            node = Binary("|", node, self.conjunction())
        return node

    def conjunction(self) -> Formula:
        node = self.temporal()
        while self.at("&"):
            self.take()
            node = Binary("&", node, self.temporal())
        return node

    def temporal(self) -> Formula:
        left = self.unary()
        if self.at("U", "W", "R"):
            self.deeper(self.peek())
            op = self.take().text
            node = Binary(op, left, self.temporal())
            self.nesting -= 1
            return node
        return left

    def unary(self) -> Formula:
        if self.at("!", "X", "WX", "F", "G"):
            self.deeper(self.peek())
            op = self.take().text
            node = Unary(op, self.unary())
            self.nesting -= 1
            return node
        return self.atom()

    def atom(self) -> Formula:
        token = self.take()
        if token.kind == "ident":
            if token.text in _KEYWORDS:
                return Const(token.text == "true")
            return Prop(token.text)
        if token.kind == "op" and token.text == "(":
            self.deeper(token)
            node = self.implication()
            self.nesting -= 1
            closing = self.take()
            if not (closing.kind == "op" and closing.text == ")"):
                raise _error(self.text, closing.pos, "')' or a binary operator", _describe(closing))
            return node
        raise _error(self.text, token.pos, _OPERAND, _describe(token))
