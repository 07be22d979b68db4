"""The console every CLI command prints through: user text is printed literally.

A default rich console reads ``[tasks]`` or ``[low, high]`` in a message as markup and drops it, and raises on
a stray ``[/x]`` in a path; it also colours numbers and turns ``:name:`` into emoji. This one does none of
that, so file names, keys and values reach the terminal exactly as they are.

Example::

    plain_console().print(f"dataset: {path}")      # a path like datasets/[/x] prints as is
"""

from __future__ import annotations

import sys

from rich.console import Console


def plain_console(*, stderr: bool = False, width: int | None = None) -> Console:
    """A rich console with markup, highlighting and emoji codes off, and lines never wrapped (a path stays
    on one line, whole); tables still render to the terminal's width."""
    return Console(stderr=stderr, width=width, markup=False, highlight=False, emoji=False, soft_wrap=True)


def print_error(message: object) -> None:
    """Print one ``error: <message>`` line on stderr, literally."""
    sys.stderr.write(f"error: {message}\n")
    sys.stderr.flush()
