"""The direct recursive LTL_f semantics over non-empty finite traces (De Giacomo & Vardi 2013).

This is the definition the compiled automata are tested against, written straight from the textbook
clauses and independent of the compiler: for a trace ``w`` of length ``n`` and a position ``i < n``,

- ``X f`` (strong next): ``i + 1 < n`` and ``f`` holds at ``i + 1``;
- ``WX f`` (weak next): ``i + 1 == n`` or ``f`` holds at ``i + 1``;
- ``f U g``: some ``j >= i`` has ``g``, and ``f`` holds at every ``k`` in ``[i, j)``;
- ``f R g``: every ``j >= i`` has ``g``, or some ``k`` in ``[i, j)`` has ``f``;
- ``f W g``: ``(f U g) | G f``;  ``F f``: some ``j >= i``;  ``G f``: every ``j >= i``.

Example::

    >>> holds(parse("a W b"), [{"a": True, "b": False}, {"a": False, "b": True}])
    True
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

from mgdata.errors import MgdataError
from mgdata.ltl.syntax import Binary, Const, Formula, Prop, Unary, propositions


def holds(formula: Formula, trace: Sequence[Mapping[str, bool]], position: int = 0) -> bool:
    """Whether ``trace`` (non-empty) satisfies ``formula`` from ``position`` on."""
    if not trace:
        raise MgdataError("LTL_f traces are non-empty; got an empty trace")
    for t, step in enumerate(trace):
        missing = [ap for ap in propositions(formula) if ap not in step]
        if missing:
            raise MgdataError(f"trace step {t} has no truth value for {', '.join(missing)}")
    memo: dict[tuple[int, int], bool] = {}
    return _holds(formula, trace, position, memo)


def _holds(f: Formula, w: Sequence[Mapping[str, bool]], i: int, memo: dict[tuple[int, int], bool]) -> bool:
    key = (id(f), i)
    if key in memo:
        return memo[key]
    n = len(w)
    if isinstance(f, Const):
        value = f.value
    elif isinstance(f, Prop):
        value = bool(w[i][f.name])
    elif isinstance(f, Unary):
        a = f.arg
        if f.op == "!":
            value = not _holds(a, w, i, memo)
        elif f.op == "X":
            value = i + 1 < n and _holds(a, w, i + 1, memo)
        elif f.op == "WX":
            value = i + 1 >= n or _holds(a, w, i + 1, memo)
        elif f.op == "F":
            value = any(_holds(a, w, j, memo) for j in range(i, n))
        else:  # G
            value = all(_holds(a, w, j, memo) for j in range(i, n))
    else:
        value = _binary(f, w, i, memo)
    memo[key] = value
    return value


def _binary(f: Binary, w: Sequence[Mapping[str, bool]], i: int, memo: dict[tuple[int, int], bool]) -> bool:
    n = len(w)
    a, b = f.left, f.right
    if f.op == "&":
        return _holds(a, w, i, memo) and _holds(b, w, i, memo)
    if f.op == "|":
        return _holds(a, w, i, memo) or _holds(b, w, i, memo)
    if f.op == "->":
        return (not _holds(a, w, i, memo)) or _holds(b, w, i, memo)
    if f.op == "<->":
        return _holds(a, w, i, memo) == _holds(b, w, i, memo)
    if f.op == "U":
        return _until(a, b, w, i, memo)
    if f.op == "W":
        return _until(a, b, w, i, memo) or all(_holds(a, w, j, memo) for j in range(i, n))
    # R: every j >= i has b, unless some earlier k in [i, j) has a
    return all(_holds(b, w, j, memo) or any(_holds(a, w, k, memo) for k in range(i, j)) for j in range(i, n))


def _until(a: Formula, b: Formula, w: Sequence[Mapping[str, bool]], i: int,
           memo: dict[tuple[int, int], bool]) -> bool:
    return any(_holds(b, w, j, memo) and all(_holds(a, w, k, memo) for k in range(i, j))
               for j in range(i, len(w)))
