"""Values of command-line options that several commands share, parsed into typed values (bad text is one
:class:`~mgdata.errors.RecipeError` naming the option).

Example::

    parse_ids("0-3,7")   # (0, 1, 2, 3, 7)
"""

from __future__ import annotations

from mgdata.errors import RecipeError


def parse_ids(text: str, option: str = "--tasks") -> tuple[int, ...] | None:
    """``"all"`` -> ``None``; ``"0-3,7"`` -> ``(0, 1, 2, 3, 7)``."""
    if text.strip() == "all":
        return None
    out: list[int] = []
    try:
        for part in text.split(","):
            lo, _, hi = part.strip().partition("-")
            first, last = int(lo), int(hi or lo)
            if last < first:
                raise ValueError(part)
            out += range(first, last + 1)
    except ValueError:
        raise RecipeError(f"{option} {text!r}: expected 'all' or ids and ranges such as '0-3,7' "
                          "(each range low-high with low <= high)") from None
    return tuple(out)
