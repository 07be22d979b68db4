"""Readable guards for sets of letters: ``{1, 3}`` over ``("a", "b")`` prints as ``a``.

Prime implicants by Quine–McCluskey, then a greedy cover; used only to print automata (text and DOT).
"""

from __future__ import annotations

from collections.abc import Iterable

Cube = tuple[int, int]  # (care mask, values on the care bits)


def guard(letters: Iterable[int], aps: tuple[str, ...]) -> str:
    """A short DNF over ``aps`` true exactly on ``letters`` (``true``/``false`` at the extremes)."""
    wanted = set(letters)
    full = (1 << len(aps)) - 1
    if not wanted:
        return "false"
    if len(wanted) == 1 << len(aps):
        return "true"
    cubes = _cover(wanted, _primes(wanted, full))
    text = [_cube_text(c, aps) for c in sorted(cubes, key=lambda c: (bin(c[0]).count("1"), c))]
    return " | ".join(f"({t})" if len(cubes) > 1 and " & " in t else t for t in text)


def _primes(minterms: set[int], full: int) -> list[Cube]:
    level: set[Cube] = {(full, m) for m in minterms}
    primes: set[Cube] = set()
    while level:
        merged: set[Cube] = set()
        used: set[Cube] = set()
        by_mask: dict[int, set[int]] = {}
        for care, value in level:
            by_mask.setdefault(care, set()).add(value)
        for care, values in by_mask.items():
            for value in values:
                bit = care
                while bit:
                    low = bit & -bit
                    bit ^= low
                    if not value & low and (value | low) in values:
                        merged.add((care & ~low, value))
                        used.update({(care, value), (care, value | low)})
        primes.update(level - used)
        level = merged
    return sorted(primes)


def _covers(cube: Cube, letter: int) -> bool:
    return letter & cube[0] == cube[1]


def _cover(minterms: set[int], primes: list[Cube]) -> list[Cube]:
    left = set(minterms)
    chosen: list[Cube] = []
    while left:
        best = max(primes, key=lambda c: (sum(_covers(c, m) for m in left), -bin(c[0]).count("1")))
        chosen.append(best)
        left = {m for m in left if not _covers(best, m)}
    return chosen


def _cube_text(cube: Cube, aps: tuple[str, ...]) -> str:
    care, value = cube
    parts = [ap if value >> i & 1 else f"!{ap}" for i, ap in enumerate(aps) if care >> i & 1]
    return " & ".join(parts) if parts else "true"
