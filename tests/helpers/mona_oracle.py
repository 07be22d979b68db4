"""The ltlf2dfa + MONA oracle: translate a formula to ltlf2dfa syntax, run ``mona``, read its DFA back.

MONA's automaton reads one dummy symbol before the trace (its state 0), so a non-empty trace ``w`` is
accepted when the state after ``dummy · w`` is accepting. ltlf2dfa has no ``W``: ``a W b`` is given to it as
``(a U b) | G a``. It writes its MONA file into site-packages, so we run ``mona`` ourselves on a temp file.
"""

from __future__ import annotations

import re
import shutil
import subprocess
import tempfile
from dataclasses import dataclass
from pathlib import Path

from mgdata.ltl.syntax import Const, Formula, Prop, Unary

MONA = shutil.which("mona")


def to_ltlf2dfa(f: Formula) -> str:
    """Fully parenthesised ltlf2dfa text for ``f`` (its U/R associativity differs from ours)."""
    if isinstance(f, Const):
        return "true" if f.value else "false"
    if isinstance(f, Prop):
        return f.name
    if isinstance(f, Unary):
        return f"{f.op}({to_ltlf2dfa(f.arg)})"
    a, b = to_ltlf2dfa(f.left), to_ltlf2dfa(f.right)
    if f.op == "W":
        return f"((({a}) U ({b})) | G({a}))"
    return f"(({a}) {f.op} ({b}))"


@dataclass(frozen=True)
class MonaDfa:
    """MONA's DFA: ``delta[state][letter]`` over our letter encoding of ``aps``; state 0 is the dummy."""

    aps: tuple[str, ...]
    delta: list[list[int]]
    accepting: frozenset[int]

    def start(self) -> int:
        """The state after the dummy symbol (before the first real letter)."""
        return self.delta[0][0]


def mona_dfa(f: Formula, aps: tuple[str, ...]) -> MonaDfa:
    """Compile ``f`` with ltlf2dfa's MONA encoding and the ``mona`` binary."""
    from ltlf2dfa.base import MonaProgram
    from ltlf2dfa.parser.ltlf import LTLfParser

    program = MonaProgram(LTLfParser()(to_ltlf2dfa(f))).mona_program()
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "formula.mona"
        path.write_text(program)
        out = subprocess.run([MONA, "-q", "-u", "-w", str(path)], capture_output=True, text=True,
                             timeout=60, check=True).stdout
    free = re.search(r"free variables:(.*)\n", out).group(1).split()
    accepting = frozenset(int(x) for x in re.search(r"Accepting states:(.*)\n", out).group(1).split())
    n = int(re.search(r"Automaton has (\d+) state", out).group(1))
    col = {name.lower(): i for i, name in enumerate(free)}
    delta = [[-1] * (1 << len(aps)) for _ in range(n)]
    for src, bits, dst in re.findall(r"State (\d+): ([01X]*) -> state (\d+)", out):
        for letter in range(1 << len(aps)):
            if all(bits[col[ap]] in ("X", str(letter >> i & 1)) for i, ap in enumerate(aps) if ap in col):
                delta[int(src)][letter] = int(dst)
    assert all(-1 not in row for row in delta), out
    return MonaDfa(tuple(aps), delta, accepting)
