"""The LTL_f abstract syntax tree: constants, propositions, unary and binary operators.

Nodes are frozen dataclasses, so equal formulas compare and hash equal. ``str(node)`` prints the formula
with every binary operation parenthesised, which re-parses to the same tree.

Operators (``op`` strings): unary ``! X WX F G``; binary ``& | -> <-> U W R``.
"""

from __future__ import annotations

from dataclasses import dataclass

UNARY_OPS: tuple[str, ...] = ("!", "X", "WX", "F", "G")
BINARY_OPS: tuple[str, ...] = ("&", "|", "->", "<->", "U", "W", "R")


@dataclass(frozen=True)
class Const:
    """``true`` or ``false``."""

    value: bool

    def __str__(self) -> str:
        return "true" if self.value else "false"


@dataclass(frozen=True)
class Prop:
    """An atomic proposition, e.g. ``jar_closed``."""

    name: str

    def __str__(self) -> str:
        return self.name


@dataclass(frozen=True)
class Unary:
    """``op arg`` with ``op`` in :data:`UNARY_OPS`."""

    op: str
    arg: Formula

    def __str__(self) -> str:
        sep = "" if self.op == "!" else " "
        return f"{self.op}{sep}{self.arg}"


@dataclass(frozen=True)
class Binary:
    """``(left op right)`` with ``op`` in :data:`BINARY_OPS`."""

    op: str
    left: Formula
    right: Formula

    def __str__(self) -> str:
        return f"({self.left} {self.op} {self.right})"


Formula = Const | Prop | Unary | Binary


def propositions(formula: Formula) -> tuple[str, ...]:
    """The proposition names occurring in ``formula``, sorted."""
    found: set[str] = set()
    stack: list[Formula] = [formula]
    while stack:
        node = stack.pop()
        if isinstance(node, Prop):
            found.add(node.name)
        elif isinstance(node, Unary):
            stack.append(node.arg)
        elif isinstance(node, Binary):
            stack.extend((node.left, node.right))
    return tuple(sorted(found))


def depth(formula: Formula) -> int:
    """Operator nesting depth (0 for a constant or a proposition); iterative, so any tree is fine."""
    deepest = 0
    stack: list[tuple[Formula, int]] = [(formula, 0)]
    while stack:
        node, d = stack.pop()
        deepest = max(deepest, d)
        if isinstance(node, Unary):
            stack.append((node.arg, d + 1))
        elif isinstance(node, Binary):
            stack.extend(((node.left, d + 1), (node.right, d + 1)))
    return deepest
