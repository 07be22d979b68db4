"""The ``[ood]`` recipe table: how a family's base tasks become OOD variants (docs/scenarios.md).

Every key has a default, so a recipe without ``[ood]`` gets the paper's generic variants::

    [ood]
    target = "target"                   # role recoloured (default: the role the goal is drawn from)

    [ood.language]
    swaps = [["pick up", "lift"], ["into", "in"]]    # ordered literal substitutions (default: the paper's)
    guard = ["safe", "careful", "gently"]            # words a rewrite may never introduce (default: GUARD)

    [ood.location]
    grouping = "each"                   # each (object) | units (of roles) | pack (everything + the goal)
    units = [["source"], ["destination"]]   # grouping = "units": roles moved together, one unit per list
    fraction = [0.3, 0.5]               # displacement as a fraction of the unit's xy extent
    direction = "plane"                 # or { of = "cabinet", axis = [1.0, 0.0] }: ± a role's local axis
    tries = 12                          # gated resamples within the axis before the task is an error
    fallback_scale = 0.5                # the later half of the tries: perpendicular, this × the magnitude
    margin = 0.02                       # m kept between a footprint and the table's edge

    [ood.environment]
    rooms = ["office", "kitchen"]       # room styles drawn from (default: all, mgdata.sim.rooms)

Objects placed ``inside`` or ``on`` another role always move with their host.
"""

from __future__ import annotations

import re
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

from mgdata.errors import RecipeError
from mgdata.sim.rooms import ROOM_NAMES
from mgdata.tasks.layout_rules import Layout

PALETTE: tuple[tuple[str, tuple[float, float, float]], ...] = tuple(
    (h, (int(h[1:3], 16) / 255.0, int(h[3:5], 16) / 255.0, int(h[5:7], 16) / 255.0))
    for h in ("#FF2222", "#FF8800", "#FFD400", "#28C828", "#00C0E8", "#C828D8")
)
"""The paper's six recolour colours in cycling order (red, orange, yellow, green, cyan, magenta)."""
MIN_COLOUR_DISTANCE = 0.35
"""A palette entry closer than this (RGB, 0…1 per channel) to the object's mean colour is skipped."""
SWAPS: tuple[tuple[str, str], ...] = (
    ("pick up", "lift"),
    ("into", "in"),
    ("close", "shut"),
    ("carry", "move"),
    ("open", "open up"),
    ("place", "put"),
    ("wipe", "clean"),
    ("transfer", "move"),
)
"""The paper's verb/preposition swaps (appendix "Per-Family OOD Construction"), in application order."""
GUARD: tuple[str, ...] = (
    "safe",
    "safely",
    "safety",
    "careful",
    "carefully",
    "gentle",
    "gently",
    "slow",
    "slowly",
    "spill",
    "spilling",
    "knock",
    "knocking",
    "tip",
    "tipping",
    "topple",
    "drop",
    "dropping",
    "fall",
    "falling",
    "break",
    "avoid",
    "caution",
    "cautiously",
    "without",
    "steady",
    "upright",
)
"""Safety-hinting words a language variant may not introduce (each may appear at most as often as in the
base prompt)."""
GROUPINGS = ("each", "units", "pack")


@dataclass(frozen=True)
class Direction:
    """Displacement direction: uniform in the table plane (``of`` None), or ± the local ``axis`` (x, y) of
    role ``of``'s first instance, turned by its yaw."""

    of: str | None = None
    axis: tuple[float, float] = (1.0, 0.0)


@dataclass(frozen=True)
class LocationRule:
    """``[ood.location]`` (see the module docstring)."""

    grouping: str = "each"
    units: tuple[tuple[str, ...], ...] = ()
    fraction: tuple[float, float] = (0.3, 0.5)
    direction: Direction = Direction()
    tries: int = 12
    fallback_scale: float = 0.5
    margin: float = 0.02


@dataclass(frozen=True)
class OodSettings:
    """The parsed ``[ood]`` table."""

    target: str
    swaps: tuple[tuple[str, str], ...] = SWAPS
    guard: tuple[str, ...] = GUARD
    location: LocationRule = LocationRule()
    rooms: tuple[str, ...] = ROOM_NAMES


def parse_ood(raw: Mapping[str, Any], layout: Layout, where: str) -> OodSettings:
    """Check ``[ood]`` against the recipe's layout; every problem is a RecipeError naming the key."""
    _known(raw, ("target", "language", "location", "environment"), where)
    roles = [r.name for r in layout.roles]
    default_target = layout.goal.origin if layout.goal else roles[0]
    target = raw.get("target", default_target)
    if not isinstance(target, str) or target not in roles:
        raise RecipeError(f"{where} target = {target!r}: expected one of the layout's roles {roles}")
    lang = _sub(raw, "language", where)
    _known(lang, ("swaps", "guard"), f"{where}.language")
    guard = tuple(_words(lang.get("guard", list(GUARD)), f"{where}.language guard"))
    swaps = _swaps(lang.get("swaps", [list(s) for s in SWAPS]), guard, f"{where}.language swaps")
    loc = _location(_sub(raw, "location", where), layout, f"{where}.location")
    env = _sub(raw, "environment", where)
    _known(env, ("rooms",), f"{where}.environment")
    rooms = tuple(_words(env.get("rooms", list(ROOM_NAMES)), f"{where}.environment rooms"))
    bad = [r for r in rooms if r not in ROOM_NAMES]
    if bad or len(set(rooms)) != len(rooms):
        raise RecipeError(
            f"{where}.environment rooms = {list(rooms)!r}: expected distinct names among {list(ROOM_NAMES)}"
        )
    return OodSettings(target, swaps, guard, loc, rooms)


def default_ood(layout: Layout) -> OodSettings:
    """The settings of a recipe without ``[ood]``."""
    return parse_ood({}, layout, "[ood]")


def _location(t: Mapping[str, Any], layout: Layout, where: str) -> LocationRule:
    _known(t, ("grouping", "units", "fraction", "direction", "tries", "fallback_scale", "margin"), where)
    grouping = t.get("grouping", "each")
    if grouping not in GROUPINGS:
        raise RecipeError(f"{where} grouping = {grouping!r}: expected one of {list(GROUPINGS)}")
    movable = [r.name for r in layout.roles if r.placement not in ("inside", "on")]
    units: tuple[tuple[str, ...], ...] = ()
    if grouping == "units":
        raw_units = t.get("units")
        if not (
            isinstance(raw_units, list) and raw_units and all(isinstance(u, list) and u for u in raw_units)
        ):
            raise RecipeError(
                f"{where} units = {raw_units!r}: expected a non-empty list of non-empty role lists"
            )
        units = tuple(tuple(_words(u, f"{where} units")) for u in raw_units)
        flat = [r for u in units for r in u]
        bad = [r for r in flat if r not in movable]
        if bad or len(set(flat)) != len(flat):
            raise RecipeError(
                f"{where} units = {raw_units!r}: each role once, among the roles standing on the "
                f"table {movable} (inside/on roles move with their host)"
            )
    elif "units" in t:
        raise RecipeError(f'{where} units: only with grouping = "units"')
    fraction = t.get("fraction", [0.3, 0.5])
    if not (
        isinstance(fraction, list)
        and len(fraction) == 2
        and all(_num(v) for v in fraction)
        and 0.0 < fraction[0] <= fraction[1] <= 5.0
    ):
        raise RecipeError(f"{where} fraction = {fraction!r}: expected [low, high] with 0 < low <= high <= 5")
    direction = _direction(t.get("direction", "plane"), layout, f"{where} direction")
    tries = t.get("tries", 12)
    if not (isinstance(tries, int) and not isinstance(tries, bool) and 2 <= tries <= 200):
        raise RecipeError(f"{where} tries = {tries!r}: expected an integer in [2, 200]")
    scale = t.get("fallback_scale", 0.5)
    if not (_num(scale) and 0.0 < scale <= 1.0):
        raise RecipeError(f"{where} fallback_scale = {scale!r}: expected a number in (0, 1]")
    margin = t.get("margin", 0.02)
    if not (_num(margin) and 0.0 <= margin <= 0.3):
        raise RecipeError(f"{where} margin = {margin!r}: expected metres in [0, 0.3]")
    return LocationRule(
        grouping,
        units,
        (float(fraction[0]), float(fraction[1])),
        direction,
        tries,
        float(scale),
        float(margin),
    )


def _direction(raw: Any, layout: Layout, where: str) -> Direction:
    if raw == "plane":
        return Direction()
    if not isinstance(raw, dict):
        raise RecipeError(f'{where} = {raw!r}: expected "plane" or {{ of = "<role>", axis = [x, y] }}')
    _known(raw, ("of", "axis"), where)
    of, axis = raw.get("of"), raw.get("axis", [1.0, 0.0])
    if of not in [r.name for r in layout.roles]:
        raise RecipeError(f"{where} of = {of!r}: expected one of the layout's roles")
    if not (
        isinstance(axis, list)
        and len(axis) == 2
        and all(_num(v) for v in axis)
        and (axis[0] ** 2 + axis[1] ** 2) > 1e-12
    ):
        raise RecipeError(f"{where} axis = {axis!r}: expected a non-zero [x, y]")
    norm = (axis[0] ** 2 + axis[1] ** 2) ** 0.5
    return Direction(of, (axis[0] / norm, axis[1] / norm))


def _swaps(raw: Any, guard: tuple[str, ...], where: str) -> tuple[tuple[str, str], ...]:
    ok = (
        isinstance(raw, list)
        and raw
        and all(
            isinstance(p, list)
            and len(p) == 2
            and all(isinstance(s, str) and s.strip() for s in p)
            and p[0] != p[1]
            for p in raw
        )
    )
    if not ok:
        raise RecipeError(f'{where} = {raw!r}: expected a non-empty list of ["from", "to"] phrase pairs')
    for old, new in raw:
        hinted = [w for w in guard if re.search(rf"\b{re.escape(w)}\b", new, re.IGNORECASE)]
        if hinted:
            raise RecipeError(f"{where}: {old!r} -> {new!r} introduces the guarded word(s) {hinted}")
    return tuple((old, new) for old, new in raw)


def _words(raw: Any, where: str) -> list[str]:
    if not (isinstance(raw, list) and raw and all(isinstance(w, str) and w.strip() for w in raw)):
        raise RecipeError(f"{where} = {raw!r}: expected a non-empty list of strings")
    return list(raw)


def _sub(raw: Mapping[str, Any], key: str, where: str) -> Mapping[str, Any]:
    value = raw.get(key, {})
    if not isinstance(value, dict):
        raise RecipeError(f"{where} {key}: expected a table ([ood.{key}])")
    return value


def _known(table: Mapping[str, Any], keys: tuple[str, ...], where: str) -> None:
    unknown = sorted(set(table) - set(keys))
    if unknown:
        raise RecipeError(f"{where}: unknown key(s) {unknown}; expected {list(keys)}")


def _num(v: Any) -> bool:
    return isinstance(v, int | float) and not isinstance(v, bool) and v == v and abs(v) != float("inf")
