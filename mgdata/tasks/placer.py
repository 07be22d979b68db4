"""The generic placer: one draw of a layout's roles and goal (``mgdata.tasks.layout_rules``) as object poses.

Objects stand upright on the table (z = table top) unless they go ``inside`` a host (on its cavity floor) or
``on`` one (on its top; several instances of an ``on`` role make a stack, each on the one before). Footprints
are the objects' xy bounding circles (from their collision geoms); two objects on the table never come closer
than the sum of their radii plus the larger of their clearances. A rule that cannot be met in ``tries``
position draws raises :class:`LayoutRejected` naming it: the caller draws the task again
(``mgdata.engine.init_gate``). A role's ``by_model`` override places the models it matches
(``Role.for_model``); the goal's is chosen by the model drawn for its ``from`` role. Overrides draw no extra
random numbers.

Example::

    placed = place(layout, np.random.default_rng(0))
    placed.objects, placed.goal, placed.names["food"]
"""

from __future__ import annotations

import fnmatch
import math
from dataclasses import dataclass
from functools import cache

import mujoco
import numpy as np

from mgdata.errors import RecipeError
from mgdata.sim.assets import get_model, model_names
from mgdata.sim.particles import fill_top
from mgdata.sim.taskspec import GoalRegion, ObjectPlacement
from mgdata.sim.world import TABLE_TOP_Z
from mgdata.tasks.layout_rules import Layout, Role

DROP = 0.001
"""m above its support an object is placed (it settles onto it)."""


class LayoutRejected(Exception):
    """This draw cannot satisfy a layout rule (``rule`` names it); draw again."""

    def __init__(self, rule: str, why: str) -> None:
        super().__init__(f"{rule}: {why}")
        self.rule = rule


@dataclass(frozen=True)
class Placed:
    """One draw: the objects, the goal, the articulation openings and each role's display name."""

    objects: tuple[ObjectPlacement, ...]
    goal: GoalRegion | None
    articulation: dict[str, float]
    names: dict[str, str]


@cache
def footprint_radius(name: str) -> float:
    """Radius (m) of the smallest origin-centred circle holding the model's collision geoms in xy."""
    model = get_model(name)
    parts = [((0.0, 0.0, 0.0), model.geoms)] + [(link.pos, link.geoms) for link in model.links]
    radius = 0.0
    for origin, geoms in parts:
        for g in geoms:
            centre = math.hypot(origin[0] + g.pos[0], origin[1] + g.pos[1])
            if g.mesh is not None:
                rot = np.empty(9)
                mujoco.mju_quat2Mat(rot, np.asarray(g.quat, dtype=np.float64))
                rot = rot.reshape(3, 3)
                pts = g.mesh.verts @ rot.T + np.asarray(g.pos) + np.asarray(origin)
                extent = float(np.max(np.hypot(pts[:, 0], pts[:, 1])))
            elif g.kind == "box":
                extent = centre + math.hypot(g.size[0], g.size[1]) if g.quat == (1.0, 0.0, 0.0, 0.0) \
                    else centre + math.sqrt(sum(s * s for s in g.size))
            else:
                extent = centre + (max(g.size) if g.kind in ("sphere", "ellipsoid") else
                                   g.size[0] + (g.size[1] if g.quat != (1.0, 0.0, 0.0, 0.0) else 0.0))
            radius = max(radius, extent)
    return radius if radius > 0 else 0.5 * math.hypot(model.size[0], model.size[1])


def width(name: str) -> float:
    """The larger horizontal extent (m) of the model's bounding box."""
    size = get_model(name).size
    return float(max(size[0], size[1]))


def matching_models(patterns: tuple[str, ...], where: str) -> list[str]:
    """Library models matching any glob, in library order; an error if none does."""
    found = [n for n in model_names() if any(fnmatch.fnmatchcase(n, p) for p in patterns)]
    if not found:
        raise RecipeError(f"{where} models = {list(patterns)!r} match no object model")
    return found


def display_name(model: str, names: dict[str, str]) -> str:
    """A model's name in prompts: ``names`` by model, then geometry kind, then category; else the kind
    (``cherry``) or the category (``mug``)."""
    obj = get_model(model)
    kind = str(obj.geometry.get("kind", ""))
    for key in (model, kind, obj.category):
        if key in names:
            return names[key]
    return (kind or obj.category).replace("_", " ")


def place(layout: Layout, rng: np.random.Generator, where: str = "[layout]") -> Placed:
    """One draw of ``layout`` (see the module docstring)."""
    objects: list[ObjectPlacement] = []
    by_role: dict[str, list[ObjectPlacement]] = {}
    floor: list[tuple[ObjectPlacement, float, float]] = []  # on the table: placement, radius, clearance
    articulation: dict[str, float] = {}
    names: dict[str, str] = {}
    pools: dict[str, list[str]] = {}  # role -> the library models its globs match
    for role in layout.roles:
        at = f"{where} roles.{role.name}"
        count = int(rng.integers(role.count[0], role.count[1] + 1))
        pools[role.name] = matching_models(role.models, at)
        _check_overrides(role.by_model, pools[role.name], f"{at} by_model", role)
        pool = _hosts(layout, role, pools[role.name], at)
        if role.model_of is not None:
            pool = [_mate(pool, by_role[role.model_of[0]][0].model, role.model_of[1], at)]
        placed_here: list[ObjectPlacement] = []
        for i in range(count):
            name = role.name if role.count == (1, 1) else f"{role.name}_{i}"
            host = by_role[role.host][0] if role.host else None
            rule = role  # inside/on: one rule for every model (by_model is for region and near roles)
            if role.placement == "on" and placed_here:
                host = placed_here[-1]  # a stack: each instance on the one before
            if role.placement == "inside":
                assert host is not None
                model = _fitting(pool, host.model, role.clearance, at, rng)
                cavity = get_model(host.model).cavity
                assert cavity is not None
                pos = (host.pos[0], host.pos[1], host.pos[2] + cavity.floor_z + DROP)
                obj = ObjectPlacement(name, model, pos, _yaw(role, pos, host, rng))
            elif role.placement == "on":
                assert host is not None
                model = _draw(pool, placed_here, role, rng)
                pos = (host.pos[0], host.pos[1], host.pos[2] + get_model(host.model).size[2] + DROP)
                obj = ObjectPlacement(name, model, pos, _yaw(role, pos, host, rng))
            else:
                model = _draw(pool, placed_here, role, rng)
                rule = role.for_model(model)
                host = by_role[rule.host][0] if rule.host else None
                obj = _on_table(rule, name, model, host, floor, layout.tries, rng, at)
                floor.append((obj, footprint_radius(model), rule.clearance))
            objects.append(obj)
            placed_here.append(obj)
            if rule.open is not None and get_model(model).articulation is not None:
                articulation[name] = rule.open
        by_role[role.name] = placed_here
        names[role.name] = display_name(placed_here[0].model, dict(layout.names))
    goal = None
    if layout.goal is not None:
        origin = layout.goal.origin
        _check_overrides(layout.goal.by_model, pools[origin], f"{where} goal by_model", layout.role(origin))
        goal = _goal(layout, by_role, rng, where)
    return Placed(tuple(objects), goal, articulation, names)


def _check_overrides(by_model: tuple[tuple[str, object], ...], models: list[str], at: str,
                     role: Role) -> None:
    """Every ``by_model`` glob matches one of ``models`` (those of ``role``), else a RecipeError naming it."""
    for glob, _ in by_model:
        if not any(fnmatch.fnmatchcase(m, glob) for m in models):
            raise RecipeError(f'{at}."{glob}" matches none of role {role.name}\'s models '
                              f'({", ".join(role.models)})')


def _draw(pool: list[str], placed_here: list[ObjectPlacement], role: Role, rng: np.random.Generator) -> str:
    """A model for the role's next instance: the first one's if ``same_model``, else drawn from the pool."""
    if role.same_model and placed_here:
        return placed_here[0].model
    return pool[int(rng.integers(len(pool)))]


def _hosts(layout: Layout, role: Role, pool: list[str], at: str) -> list[str]:
    """``pool`` without the models that some later ``inside`` role (the food, the liquid) cannot fit in."""
    guests = [(matching_models(r.models, f"{at} (guest {r.name})"), r.clearance) for r in layout.roles
              if r.placement == "inside" and r.host == role.name]
    if not guests:
        return pool
    kept = [h for h in pool if all(any(_fits(m, h, *_room(h), c) for m in ms) for ms, c in guests)]
    if not kept:
        guests_named = ", ".join(_guest_names(layout, role))
        raise RecipeError(f"{at} models: what goes inside ({guests_named}) fits in none of them")
    return kept


def _mate(pool: list[str], model: str, key: str, at: str) -> str:
    """The model ``model`` names as its ``geometry[key]`` (``model_of``), which must be in ``pool``."""
    mate = get_model(model).geometry.get(key)
    if mate not in pool:
        raise RecipeError(f"{at} model_of: {model} names {mate!r} as its {key!r}, which is not among "
                          f"the role's models")
    return str(mate)


def _guest_names(layout: Layout, role: Role) -> list[str]:
    return [r.name for r in layout.roles if r.placement == "inside" and r.host == role.name]


def _room(host: str) -> tuple[float, float]:
    """Radius and depth (m) of the space inside ``host``'s cavity (its mouth, if narrower)."""
    cavity = get_model(host).cavity
    if cavity is None:
        return 0.0, 0.0
    geo = get_model(host).geometry
    room_r = min(cavity.radius_floor or cavity.half_x, cavity.radius_rim or cavity.half_y,
                 float(geo.get("mouth_radius", math.inf)))
    return room_r, float(geo.get("height", cavity.rim_z)) - cavity.floor_z


def _fitting(pool: list[str], host: str, clearance: float, at: str, rng: np.random.Generator) -> str:
    if get_model(host).cavity is None:
        raise RecipeError(f"{at} inside: {host} has no cavity")
    room_r, room_h = _room(host)
    fits = [m for m in pool if _fits(m, host, room_r, room_h, clearance)]
    if not fits:
        raise LayoutRejected(at, f"nothing in the pool fits inside {host} "
                                 f"({2 * room_r * 100:.1f} cm wide, {room_h * 100:.1f} cm deep)")
    return fits[int(rng.integers(len(fits)))]


def _fits(model: str, host: str, room_r: float, room_h: float, clearance: float) -> bool:
    """Does ``model`` fit in the host's cavity with ``clearance`` to spare (a liquid: its fill level below
    the rim by ``clearance``)?"""
    obj = get_model(model)
    if get_model(host).cavity is None:
        return False
    if obj.particles is not None:
        top, cavity = fill_top(obj, get_model(host)), get_model(host).cavity
        return top is not None and cavity is not None and top <= cavity.rim_z - clearance
    return width(model) <= 2.0 * room_r - clearance and obj.size[2] <= room_h - clearance


def _on_table(role: Role, name: str, model: str, host: ObjectPlacement | None,
              floor: list[tuple[ObjectPlacement, float, float]], tries: int, rng: np.random.Generator,
              at: str) -> ObjectPlacement:
    radius = footprint_radius(model)
    for _ in range(tries):
        if role.placement == "region":
            assert role.region is not None
            x, y = float(rng.uniform(*role.region[0])), float(rng.uniform(*role.region[1]))
        else:
            assert host is not None
            d = float(rng.uniform(*role.distance))
            away = math.atan2(host.pos[1], host.pos[0])
            bearing = away + math.radians(float(rng.uniform(*role.bearing_deg)))
            x, y = host.pos[0] + d * math.cos(bearing), host.pos[1] + d * math.sin(bearing)
        clear = all(math.hypot(x - o.pos[0], y - o.pos[1]) >= radius + r + max(c, role.clearance)
                    for o, r, c in floor)
        if clear:
            pos = (x, y, TABLE_TOP_Z)
            return ObjectPlacement(name, model, pos, _yaw(role, pos, host, rng))
    raise LayoutRejected(at, f"no free spot for {name} ({model}, footprint radius {radius * 100:.1f} cm) "
                             f"after {tries} draws")


def _yaw(role: Role, pos: tuple[float, float, float], host: ObjectPlacement | None,
         rng: np.random.Generator) -> float:
    away = math.atan2(pos[1], pos[0])
    jitter = math.radians(role.yaw.jitter_deg)
    base = {"away": away, "toward": away + math.pi, "fixed": math.radians(role.yaw.deg),
            "aligned": host.yaw if host is not None else 0.0}.get(role.yaw.rule)
    if base is None:  # uniform
        return float(rng.uniform(-math.pi, math.pi))
    return _wrap(base + float(rng.uniform(-jitter, jitter)))


def _goal(layout: Layout, by_role: dict[str, list[ObjectPlacement]], rng: np.random.Generator,
          where: str) -> GoalRegion:
    assert layout.goal is not None
    origin = by_role[layout.goal.origin][0]
    rule = layout.goal.for_model(origin.model)
    rad = rule.radius
    if rad.value is not None:
        radius = rad.value
    else:
        assert rad.of is not None
        radius = max(rad.scale * width(by_role[rad.of][0].model), rad.min)
    keep_out = [(o, footprint_radius(o.model)) for role in rule.clear_of for o in by_role[role]]
    reach = 0.5 * width(origin.model)
    for _ in range(layout.tries):
        d = float(rng.uniform(*rule.distance))
        bearing = float(rng.uniform(-math.pi, math.pi))
        x, y = origin.pos[0] + d * math.cos(bearing), origin.pos[1] + d * math.sin(bearing)
        (x0, x1), (y0, y1) = rule.region
        if not (x0 <= x <= x1 and y0 <= y <= y1):
            continue
        if all(math.hypot(x - o.pos[0], y - o.pos[1]) >= r + reach + rule.clearance for o, r in keep_out):
            z = TABLE_TOP_Z + float(rng.uniform(*rule.height))
            return GoalRegion((x, y, z), radius)
    lo, hi = rule.distance
    clear = f" and clear of {', '.join(rule.clear_of)}" if rule.clear_of else ""
    raise LayoutRejected(f"{where} goal", f"no goal centre {lo:g}–{hi:g} m from {origin.name} inside the "
                                          f"region{clear} after {layout.tries} draws")


def _wrap(angle: float) -> float:
    return (angle + math.pi) % (2.0 * math.pi) - math.pi
