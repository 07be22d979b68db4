"""Layout rules: a recipe's ``[layout]`` table as typed data, checked when the recipe loads.

A layout names **roles** (the jar, the food, the target, the obstacles …), each drawn from a pool of models
(globs over the asset library) and placed by one rule, and the **goal** sphere. Roles are placed in the order
the recipe lists them; a rule may refer only to roles listed before it. ::

    [layout]
    tries = 200                          # position draws per object before the whole draw is rejected

    [layout.roles.target]
    models = ["cup/*", "mug/*"]          # globs over the asset library
    count = 1                            # or [low, high]: instances target_0 … target_{n-1}
    region = { x = [0.45, 0.60], y = [-0.12, 0.12] }   # robot base frame (m); or:
    # near = "jar", distance = [0.10, 0.20], bearing_deg = [-180, 180]   (0 = away from the robot)
    # inside = "jar"                     # in the host's cavity (only models that fit are drawn)
    # on = "board"                       # standing on the host's top; with count > 1 a stack: instance 0
                                         # on the host, each next one on the one before
    yaw = { rule = "uniform" }           # "away" (object +X away from the robot), "toward", "uniform",
                                         # "aligned" (the host's yaw), "fixed" (deg = world yaw);
                                         # jitter_deg = ±jitter
    clearance = 0.01                     # m between this object's footprint and every other one
    open = 1.0                           # articulation opening fraction (0 closed … 1 open)
    model_of = { role = "container", key = "lid" }   # the model named by an earlier role's model's
                                         # geometry[key] (a container's own lid); it must match `models`
    same_model = false                   # true: every instance of the role is one model (drawn once)
    # a drawn model matching a glob here (the first that does) is placed by these keys merged over the
    # role's: region or near (+ distance, bearing_deg), yaw, clearance, open (region and near roles only;
    # each glob must match some of the role's models)
    by_model."mug/*" = { region = { x = [0.40, 0.46], y = [0.20, 0.30] }, yaw = { rule = "away" } }

    [layout.goal]
    from = "target"                      # the goal centre is `distance` from this role, any bearing
    distance = [0.18, 0.30]
    region = { x = [0.38, 0.62], y = [-0.30, 0.30] }
    height = [0.10, 0.10]                # m above the table top
    radius = 0.05                        # or { scale = 0.45, of = "target", min = 0.03 }: × the role's width
    clear_of = ["obstacle"]              # keep the goal's xy this far outside these roles' footprints
    clearance = 0.03
    # keyed by the model drawn for `from`: distance, region, height, radius, clear_of, clearance
    by_model."mug/*" = { distance = [0.0, 0.12], region = { x = [0.30, 0.50], y = [0.15, 0.35] } }

    [layout.names]                       # display names for prompt fields {role}: by model, kind or category
    candy = "piece of candy"

Example::

    layout = parse_layout(raw["layout"], "recipes/jar.toml: [layout]")
    layout.roles[0].name, layout.model_patterns()
"""

from __future__ import annotations

import fnmatch
import math
from collections.abc import Mapping
from dataclasses import dataclass, replace
from typing import Any

from mgdata.errors import RecipeError

PLACEMENTS: tuple[str, ...] = ("region", "near", "inside", "on")
YAW_RULES: tuple[str, ...] = ("away", "toward", "uniform", "aligned", "fixed")
ROLE_OVERRIDES: tuple[str, ...] = ("region", "near", "distance", "bearing_deg", "yaw", "clearance", "open")
"""The keys a role's ``by_model`` entry may set."""
GOAL_OVERRIDES: tuple[str, ...] = ("distance", "region", "height", "radius", "clear_of", "clearance")
"""The keys the goal's ``by_model`` entry may set."""
FIXED_BY_MODEL: tuple[str, ...] = ("models", "count", "inside", "on", "model_of", "same_model", "from",
                                   "by_model")
"""Keys a ``by_model`` entry may not set: they decide which models are drawn, or where from."""
Range = tuple[float, float]


@dataclass(frozen=True)
class Yaw:
    """How a role's yaw is drawn: ``rule`` (see :data:`YAW_RULES`) give or take ``jitter_deg``; ``fixed``:
    ``deg`` about world +Z (0 = object +X along the robot's +X)."""

    rule: str = "uniform"
    jitter_deg: float = 0.0
    deg: float = 0.0


@dataclass(frozen=True)
class Role:
    """One role of the layout.

    Attributes:
        name: the instance name (``count`` 1) or prefix (``name_0`` …).
        models: glob patterns over the asset library.
        count: (low, high) number of instances, drawn uniformly.
        placement: one of :data:`PLACEMENTS`.
        region: ``region``: (x range, y range) in the robot base frame.
        host: ``near``/``inside``/``on``: the role it is placed relative to.
        distance: ``near``: centre-to-centre distance range (m).
        bearing_deg: ``near``: bearing range from the host, 0 = pointing away from the robot.
        yaw: the yaw rule.
        clearance: m between footprints (``inside`` objects have none; ``inside`` uses it as the room
            left around and above the object in the cavity).
        open: articulation opening fraction, if the model has one.
        model_of: (role, key): the model is ``geometry[key]`` of that earlier role's model (its mate).
        same_model: every instance is the model drawn for the first one (a stack of identical objects).
        by_model: (glob, rule) overrides for drawn models matching the glob; see :meth:`for_model`.
    """

    name: str
    models: tuple[str, ...]
    count: tuple[int, int]
    placement: str
    region: tuple[Range, Range] | None = None
    host: str | None = None
    distance: Range = (0.0, 0.0)
    bearing_deg: Range = (-180.0, 180.0)
    yaw: Yaw = Yaw()
    clearance: float = 0.0
    open: float | None = None
    model_of: tuple[str, str] | None = None
    same_model: bool = False
    by_model: tuple[tuple[str, Role], ...] = ()

    def for_model(self, model: str) -> Role:
        """The rule placing ``model``: the first ``by_model`` override whose glob matches it, else this."""
        return next((rule for glob, rule in self.by_model if fnmatch.fnmatchcase(model, glob)), self)


@dataclass(frozen=True)
class Radius:
    """The goal radius: ``value`` m, or ``scale`` × the width of role ``of`` (at least ``min``)."""

    value: float | None = None
    scale: float = 0.0
    of: str | None = None
    min: float = 0.0


@dataclass(frozen=True)
class GoalRule:
    """Where the goal sphere goes (see the module docstring); ``by_model``: (glob, rule) overrides keyed by
    the model drawn for the ``origin`` role (see :meth:`for_model`)."""

    origin: str
    distance: Range
    region: tuple[Range, Range]
    height: Range
    radius: Radius
    clear_of: tuple[str, ...] = ()
    clearance: float = 0.0
    by_model: tuple[tuple[str, GoalRule], ...] = ()

    def for_model(self, model: str) -> GoalRule:
        """The rule when ``model`` was drawn for the origin: the first matching override, else this."""
        return next((rule for glob, rule in self.by_model if fnmatch.fnmatchcase(model, glob)), self)


@dataclass(frozen=True)
class Layout:
    """The parsed ``[layout]`` table."""

    roles: tuple[Role, ...]
    goal: GoalRule | None
    names: Mapping[str, str]
    tries: int = 200

    def role(self, name: str) -> Role:
        for role in self.roles:
            if role.name == name:
                return role
        raise KeyError(name)

    def model_patterns(self) -> tuple[str, ...]:
        """Every model glob the layout draws from."""
        return tuple(p for role in self.roles for p in role.models)


def parse_layout(raw: Mapping[str, Any], where: str) -> Layout:
    """The typed layout of ``raw`` (a recipe's ``[layout]`` table); errors name ``where`` and the key."""
    _known(raw, ("tries", "roles", "goal", "names"), where)
    tries = _int(raw.get("tries", 200), f"{where} tries", 1, 100_000)
    roles_raw = raw.get("roles")
    if not isinstance(roles_raw, Mapping) or not roles_raw:
        raise RecipeError(f"{where}: expected at least one role ([layout.roles.<name>] tables)")
    roles: list[Role] = []
    for name, table in roles_raw.items():
        roles.append(_role(str(name), table, f"{where} roles.{name}", [r.name for r in roles]))
    names = {r.name for r in roles}
    goal = _goal(raw["goal"], f"{where} goal", names) if "goal" in raw else None
    shown = raw.get("names", {})
    if not isinstance(shown, Mapping) or not all(isinstance(v, str) for v in shown.values()):
        raise RecipeError(f"{where} names: expected a table of model, kind or category = display name")
    return Layout(tuple(roles), goal, dict(shown), tries)


def _role(name: str, table: Any, where: str, earlier: list[str]) -> Role:
    if not isinstance(table, Mapping):
        raise RecipeError(f"{where}: expected a table")
    if not name.isidentifier():
        raise RecipeError(f"{where}: a role name must be an identifier (letters, digits, _)")
    _known(table, ("models", "count", *PLACEMENTS, "distance", "bearing_deg", "yaw", "clearance", "open",
                   "model_of", "same_model", "by_model"), where)
    models = table.get("models")
    if isinstance(models, str):
        models = [models]
    if not isinstance(models, list) or not models or not all(isinstance(m, str) and m for m in models):
        raise RecipeError(f"{where} models: expected a list of model names or glob patterns")
    count = table.get("count", 1)
    lo_hi = (count, count) if isinstance(count, int) and not isinstance(count, bool) else count
    ints = isinstance(lo_hi, list | tuple) and len(lo_hi) == 2 and all(
        isinstance(c, int) and not isinstance(c, bool) for c in lo_hi)
    if not (ints and 1 <= lo_hi[0] <= lo_hi[1] <= 64):
        raise RecipeError(f"{where} count = {count!r}: expected an integer or [low, high] in 1 … 64")
    given = [k for k in PLACEMENTS if k in table]
    if len(given) != 1:
        raise RecipeError(f"{where}: give exactly one of {', '.join(PLACEMENTS)} (got {given or 'none'})")
    placement = given[0]
    region, host = None, None
    if placement == "region":
        region = _region(table["region"], f"{where} region")
    else:
        host = table[placement]
        if host not in earlier:
            raise RecipeError(f"{where} {placement} = {host!r}: expected a role listed before this one "
                              f"({', '.join(earlier) or 'none'})")
    if placement == "near":
        if "distance" not in table:
            raise RecipeError(f"{where}: near needs distance = [low, high] (m)")
        distance = _range(table["distance"], f"{where} distance", 0.0, 2.0)
    elif "distance" in table:
        raise RecipeError(f"{where} distance: only a `near` placement reads it")
    else:
        distance = (0.0, 0.0)
    bearing = _range(table.get("bearing_deg", [-180.0, 180.0]), f"{where} bearing_deg", -360.0, 360.0)
    default_yaw = "aligned" if placement in ("inside", "on") else "uniform"
    yaw = _yaw(table.get("yaw", {"rule": default_yaw}), f"{where} yaw", host)
    clearance = _number(table.get("clearance", 0.0), f"{where} clearance", 0.0, 0.5)
    opened = table.get("open")
    opened = None if opened is None else _number(opened, f"{where} open", 0.0, 1.0)
    same = table.get("same_model", False)
    if not isinstance(same, bool):
        raise RecipeError(f"{where} same_model = {same!r}: expected true or false")
    role = Role(name, tuple(models), (int(lo_hi[0]), int(lo_hi[1])), placement, region, host, distance,
                bearing, yaw, clearance, opened,
                _model_of(table.get("model_of"), f"{where} model_of", earlier), same)
    overrides = _overrides(table, ROLE_OVERRIDES, where)
    if overrides and placement not in ("region", "near"):
        raise RecipeError(f"{where} by_model: only a role placed by region or near can vary by model "
                          f"(this one is placed {placement})")
    rules = []
    for glob, extra in overrides:
        # the override's placement replaces the role's: region drops near's keys, near drops region
        dropped = {"region": ("near", "distance", "bearing_deg"), "near": ("region",)}
        gone = {k for key, keys in dropped.items() if key in extra for k in keys}
        base = {k: v for k, v in table.items() if k != "by_model" and k not in gone}
        rules.append((glob, _role(name, {**base, **extra}, f'{where} by_model."{glob}"', earlier)))
    return replace(role, by_model=tuple(rules))


def _overrides(table: Mapping[str, Any], allowed: tuple[str, ...], where: str) -> list[tuple[str, Any]]:
    """The ``by_model`` entries of ``table`` as (glob, override table), their keys checked against
    ``allowed``."""
    raw = table.get("by_model", {})
    if not isinstance(raw, Mapping):
        raise RecipeError(f'{where} by_model: expected a table of model glob = {{ keys to override }}, e.g. '
                          f'by_model."board/*" = {{ ... }}')
    out = []
    for glob, extra in raw.items():
        at = f'{where} by_model."{glob}"'
        if not glob:
            raise RecipeError(f"{where} by_model: a model glob must not be empty")
        if not isinstance(extra, Mapping):
            raise RecipeError(f"{at} = {extra!r}: expected a table of keys to override "
                              f"({', '.join(allowed)})")
        fixed = sorted(k for k in extra if k in FIXED_BY_MODEL)
        if fixed:
            raise RecipeError(f"{at}: {', '.join(fixed)} cannot vary by model (an override may set "
                              f"{', '.join(allowed)})")
        _known(extra, allowed, at)
        out.append((str(glob), extra))
    return out


def _model_of(raw: Any, where: str, earlier: list[str]) -> tuple[str, str] | None:
    if raw is None:
        return None
    if not isinstance(raw, Mapping) or set(raw) != {"role", "key"} or not isinstance(raw["key"], str):
        raise RecipeError(f"{where}: expected {{ role = <an earlier role>, key = <a geometry key> }}")
    if raw["role"] not in earlier:
        raise RecipeError(f"{where} role = {raw['role']!r}: expected a role listed before this one "
                          f"({', '.join(earlier) or 'none'})")
    return str(raw["role"]), raw["key"]


def _goal(table: Any, where: str, roles: set[str]) -> GoalRule:
    if not isinstance(table, Mapping):
        raise RecipeError(f"{where}: expected a table")
    _known(table, ("from", *GOAL_OVERRIDES, "by_model"), where)
    for key in ("from", "distance", "region", "height", "radius"):
        if key not in table:
            raise RecipeError(f"{where}: missing key {key!r}")
    origin = table["from"]
    if origin not in roles:
        raise RecipeError(f"{where} from = {origin!r}: expected a role ({', '.join(sorted(roles))})")
    clear_of = table.get("clear_of", [])
    if not isinstance(clear_of, list) or any(r not in roles for r in clear_of):
        raise RecipeError(f"{where} clear_of = {clear_of!r}: expected a list of roles "
                          f"({', '.join(sorted(roles))})")
    raw_radius = table["radius"]
    if isinstance(raw_radius, Mapping):
        _known(raw_radius, ("scale", "of", "min"), f"{where} radius")
        if raw_radius.get("of") not in roles:
            raise RecipeError(f"{where} radius.of = {raw_radius.get('of')!r}: expected a role")
        scale = _number(raw_radius.get("scale"), f"{where} radius.scale", 0.01, 10.0)
        least = _number(raw_radius.get("min", 0.0), f"{where} radius.min", 0.0, 0.5)
        radius = Radius(None, scale, raw_radius["of"], least)
    else:
        radius = Radius(_number(raw_radius, f"{where} radius", 0.005, 0.5))
    rule = GoalRule(origin, _range(table["distance"], f"{where} distance", 0.0, 2.0),
                    _region(table["region"], f"{where} region"),
                    _range(table["height"], f"{where} height", 0.0, 1.0), radius, tuple(clear_of),
                    _number(table.get("clearance", 0.0), f"{where} clearance", 0.0, 0.5))
    base = {k: v for k, v in table.items() if k != "by_model"}
    return replace(rule, by_model=tuple((glob, _goal({**base, **extra}, f'{where} by_model."{glob}"', roles))
                                        for glob, extra in _overrides(table, GOAL_OVERRIDES, where)))


def _yaw(raw: Any, where: str, host: str | None) -> Yaw:
    if not isinstance(raw, Mapping):
        raise RecipeError(f"{where}: expected a table {{ rule = ..., jitter_deg = ... }}")
    _known(raw, ("rule", "jitter_deg", "deg"), where)
    rule = raw.get("rule", "uniform")
    if rule not in YAW_RULES:
        raise RecipeError(f"{where} rule = {rule!r}: expected one of {', '.join(YAW_RULES)}")
    if rule == "aligned" and host is None:
        raise RecipeError(f"{where}: rule 'aligned' needs a host (near, inside or on)")
    if ("deg" in raw) != (rule == "fixed"):
        raise RecipeError(f"{where}: deg = ... goes with rule 'fixed' (and only with it)")
    return Yaw(rule, _number(raw.get("jitter_deg", 0.0), f"{where} jitter_deg", 0.0, 180.0),
               _number(raw.get("deg", 0.0), f"{where} deg", -180.0, 180.0))


def _region(raw: Any, where: str) -> tuple[Range, Range]:
    if not isinstance(raw, Mapping) or set(raw) != {"x", "y"}:
        raise RecipeError(f"{where}: expected {{ x = [low, high], y = [low, high] }} (m, robot base frame)")
    return _range(raw["x"], f"{where} x", -2.0, 2.0), _range(raw["y"], f"{where} y", -2.0, 2.0)


def _known(table: Mapping[str, Any], keys: tuple[str, ...], where: str) -> None:
    unknown = sorted(set(table) - set(keys))
    if unknown:
        raise RecipeError(f"{where}: unknown key(s) {unknown} (known: {', '.join(keys)})")


def _finite(v: Any) -> bool:
    return isinstance(v, int | float) and not isinstance(v, bool) and math.isfinite(v)


def _number(v: Any, where: str, low: float, high: float) -> float:
    if not _finite(v) or not low <= v <= high:
        raise RecipeError(f"{where} = {v!r}: expected a number in [{low:g}, {high:g}]")
    return float(v)


def _int(v: Any, where: str, low: int, high: int) -> int:
    if not isinstance(v, int) or isinstance(v, bool) or not low <= v <= high:
        raise RecipeError(f"{where} = {v!r}: expected an integer in [{low}, {high}]")
    return v


def _range(v: Any, where: str, low: float, high: float) -> Range:
    ok = isinstance(v, list | tuple) and len(v) == 2 and all(map(_finite, v))
    if not ok or v[0] > v[1] or v[0] < low or v[1] > high:
        raise RecipeError(f"{where} = {v!r}: expected [low, high], numbers with low <= high in "
                          f"[{low:g}, {high:g}]")
    return float(v[0]), float(v[1])
