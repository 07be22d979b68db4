"""CLI command ``mgdata ltl``: print a formula's minimal DFA."""

from __future__ import annotations

from typing import Annotated

import typer

from mgdata.ltl.compile import compile_ltlf


def register(app: typer.Typer) -> None:
    """Add the ``ltl`` command to ``app``."""
    app.command("ltl")(ltl_command)


def ltl_command(
    formula: Annotated[str, typer.Argument(help="LTL_f: true false ! & | -> <-> X WX F G U W R ( ).")],
    dot: Annotated[bool, typer.Option("--dot", help="Print Graphviz DOT instead of the text table.")] = False,
) -> None:
    """Compile an LTL_f formula to its minimal DFA and print it (states, accepting, sink, transitions).

    Example: mgdata ltl "jar_on_support W jar_closed"
    """
    dfa = compile_ltlf(formula)
    typer.echo(dfa.to_dot() if dot else str(dfa))
