"""``compile_ltlf``: formula text → minimal DFA (parse, progression, Moore minimisation), cached."""

from __future__ import annotations

from functools import lru_cache

from mgdata.ltl.dfa import DFA
from mgdata.ltl.minimize import minimize
from mgdata.ltl.parser import parse
from mgdata.ltl.progression import explore
from mgdata.ltl.syntax import propositions


@lru_cache(maxsize=1024)
def compile_ltlf(formula: str) -> DFA:
    """The minimal DFA of an LTL_f formula over non-empty finite traces.

    Raises :class:`mgdata.errors.LtlSyntaxError` for text that does not parse, and its subclass
    :class:`mgdata.errors.LtlLimitError` for a formula beyond the limits of ``docs/ltl.md`` (length, nesting,
    propositions, automaton size). Results are cached per formula string and shared, so their arrays are
    read-only.

    Example::

        >>> dfa = compile_ltlf("G !jar_dropped")
        >>> dfa.n_states, dfa.aps
        (3, ('jar_dropped',))
    """
    tree = parse(formula)
    aps = propositions(tree)
    raw = explore(tree, aps, formula)
    table, accepting = minimize(raw.table, raw.accepting)
    return DFA(formula, aps, table, accepting)
