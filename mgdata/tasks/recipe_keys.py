"""What a family skeleton reads from its recipe: typed ``[params]`` and ``[variation]`` declarations.

Each skeleton declares every key it reads (name, type, allowed range or shape, a one-line doc) as
:class:`RecipeKeys`; :func:`mgdata.tasks.recipe.check_recipe_keys` checks a recipe against it when the recipe
loads, so a misspelled, missing or mistyped key is one error naming it before any dataset is created, and the
skeleton reads values of the declared type.

Example::

    KEYS = RecipeKeys(
        params=(Param("open_steps", int, "control steps to open the gripper", low=1, high=200),
                Param("carry_yaws_deg", tuple, "jar turns tried at the goal (deg)", low=-180, high=180)),
        variation=(Knob("lift_height", "m the jar is lifted above the table", low=0.0, high=0.3),),
    )
"""

from __future__ import annotations

import difflib
import math
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

from mgdata.errors import RecipeError

NUMBER_KINDS: tuple[type, ...] = (float, int, tuple)


@dataclass(frozen=True)
class Param:
    """One ``[params]`` key.

    Attributes:
        name: the key.
        kind: ``float`` (an int is accepted and converted), ``int``, or ``tuple`` (a non-empty list of
            numbers, read as a tuple of floats).
        doc: one line: what it is, with its unit.
        low, high: inclusive bounds of the value (of every element, for a tuple); ``None``: unbounded.
        default: the value when a recipe leaves the key out (``None``: the key is required). Only for keys
            added after recipes existed, so that their datasets and digests stay as they were.
    """

    name: str
    kind: type
    doc: str
    low: float | None = None
    high: float | None = None
    default: Any = None

    def __post_init__(self) -> None:
        if self.kind not in NUMBER_KINDS:
            raise ValueError(f"Param {self.name!r}: kind must be float, int or tuple, not {self.kind!r}")

    @property
    def expected(self) -> str:
        """What a valid value looks like, in words (for error messages)."""
        what = {float: "a number", int: "an integer", tuple: "a non-empty list of numbers"}[self.kind]
        return what + _bounds(self.low, self.high)


@dataclass(frozen=True)
class Knob:
    """One ``[variation]`` key: the recipe gives ``[low, high]`` and each attempt draws a value in it.

    Attributes:
        name: the key.
        doc: one line: what it varies, with its unit.
        low, high: the range the recipe's ``[low, high]`` must lie within.
    """

    name: str
    doc: str
    low: float
    high: float


@dataclass(frozen=True)
class RecipeKeys:
    """The ``[params]`` and ``[variation]`` keys a skeleton reads (all of them required)."""

    params: tuple[Param, ...] = ()
    variation: tuple[Knob, ...] = ()

    def __add__(self, other: RecipeKeys) -> RecipeKeys:
        """Both sets of keys (a skeleton adds its own to a Layer 2 motion's)."""
        return RecipeKeys(self.params + other.params, self.variation + other.variation)

    def __post_init__(self) -> None:
        for kind, names in (("params", [p.name for p in self.params]),
                            ("variation", [k.name for k in self.variation])):
            dup = sorted({n for n in names if names.count(n) > 1})
            if dup:
                raise ValueError(f"RecipeKeys: duplicate {kind} key(s) {dup}")


def check_params(raw: Mapping[str, Any], declared: tuple[Param, ...], where: str) -> dict[str, Any]:
    """``[params]`` as typed values (floats, ints, tuples of floats), in declaration order."""
    _check_names(raw, [p.name for p in declared], where,
                 optional=[p.name for p in declared if p.default is not None])
    out: dict[str, Any] = {}
    for p in declared:
        out[p.name] = _param_value(raw.get(p.name, p.default), p, f"{where} {p.name}")
    return out


def check_variation(raw: Mapping[str, Any], declared: tuple[Knob, ...],
                    where: str) -> dict[str, tuple[float, float]]:
    """``[variation]`` as ``name -> (low, high)`` with low <= high inside each knob's declared range."""
    _check_names(raw, [k.name for k in declared], where)
    out: dict[str, tuple[float, float]] = {}
    for k in declared:
        value = raw[k.name]
        at = f"{where} {k.name}"
        ok = (isinstance(value, list | tuple) and len(value) == 2 and all(_is_number(v) for v in value))
        if not ok or value[0] > value[1]:
            raise RecipeError(f"{at} = {_show(value)}: expected [low, high], two numbers with low <= high "
                              f"({k.doc})")
        low, high = float(value[0]), float(value[1])
        if low < k.low or high > k.high:
            raise RecipeError(f"{at} = {_show(value)}: outside the allowed range [{k.low:g}, {k.high:g}] "
                              f"({k.doc})")
        out[k.name] = (low, high)
    return out


def _check_names(raw: Mapping[str, Any], known: list[str], where: str, optional: Sequence[str] = ()) -> None:
    for key in raw:
        if key not in known:
            close = difflib.get_close_matches(str(key), known, n=1)
            hint = f"; did you mean {close[0]!r}?" if close else ""
            raise RecipeError(f"{where} unknown key {key!r}{hint} (known: {', '.join(known) or 'none'})")
    missing = [k for k in known if k not in raw and k not in optional]
    if missing:
        raise RecipeError(f"{where} missing key(s) {', '.join(map(repr, missing))} (the skeleton reads them)")


def _param_value(value: Any, p: Param, at: str) -> Any:
    if p.kind is tuple:
        items = list(value) if isinstance(value, (list, tuple)) else None  # a tuple: the key's default
        if not items or not all(_is_number(v) for v in items):
            raise RecipeError(f"{at} = {_show(value)}: expected {p.expected} ({p.doc})")
        numbers = tuple(float(v) for v in items)
    elif p.kind is int:
        if not isinstance(value, int) or isinstance(value, bool):
            raise RecipeError(f"{at} = {_show(value)}: expected {p.expected} ({p.doc})")
        numbers = (value,)
    else:
        if not _is_number(value):
            raise RecipeError(f"{at} = {_show(value)}: expected {p.expected} ({p.doc})")
        numbers = (float(value),)
    if any((p.low is not None and v < p.low) or (p.high is not None and v > p.high) for v in numbers):
        raise RecipeError(f"{at} = {_show(value)}: expected {p.expected} ({p.doc})")
    return numbers if p.kind is tuple else numbers[0]


def _is_number(v: Any) -> bool:
    return isinstance(v, int | float) and not isinstance(v, bool) and math.isfinite(v)


def _bounds(low: float | None, high: float | None) -> str:
    if low is not None and high is not None:
        return f" in [{low:g}, {high:g}]"
    if low is not None:
        return f" >= {low:g}"
    return f" <= {high:g}" if high is not None else ""


def _show(value: Any) -> str:
    """A TOML-ish rendering of a recipe value for messages (``[0.08, 0.05]``, ``"many"``, ``nan``)."""
    if isinstance(value, str):
        return repr(value)
    if isinstance(value, Iterable) and not isinstance(value, Mapping):
        return "[" + ", ".join(_show(v) for v in value) + "]"
    return str(value).lower() if isinstance(value, bool) else str(value)
