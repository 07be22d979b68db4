"""The four OOD variant builders (paper, "ID/OOD task generation"; docs/scenarios.md): each changes one factor
of a gated base task and nothing else, deterministically per task.

* :func:`target_variant`: recolours the ``[ood] target`` role (palette entry ``task_id mod 6``, skipping
  entries within :data:`~mgdata.tasks.ood.MIN_COLOUR_DISTANCE` of its mean colour); material only.
* :func:`language_variant`: the recipe's swaps applied literally to the prompt template's text (never to the
  role names filled into it); a guard word may not appear more often than in the base prompt.
* :func:`location_proposal`: attempt ``a`` of the displacement (grouping, magnitude, clamp to the table);
  the engine gates each proposal and resamples (``mgdata.scenarios.store``).
* :func:`environment_variant`: the same task inside a room style drawn per task (``mgdata.sim.rooms``).

Each returns the new TaskSpec and its provenance (a JSON-ready dict saying what changed).
"""

from __future__ import annotations

import dataclasses
import math
import re
import string
from types import MappingProxyType
from typing import Any

import numpy as np

from mgdata.errors import RecipeError
from mgdata.sim.assets import get_model
from mgdata.sim.taskspec import GoalRegion, TaskSpec
from mgdata.sim.world import TABLE_X, TABLE_Y
from mgdata.spec import SafetySpec, prompt_suffix
from mgdata.tasks.ood import MIN_COLOUR_DISTANCE, PALETTE, OodSettings, default_ood
from mgdata.tasks.placer import LayoutRejected, footprint_radius
from mgdata.tasks.recipe import Recipe

CONDITIONS: tuple[str, ...] = ("base", "target", "language", "location", "environment")
PROMPT_FORMS: tuple[str, ...] = ("none", "nl", "ltl")
_LOCATION_STREAM = 0x10CA7
_ENV_STREAM = 0xE5
Provenance = dict[str, Any]


# -- target ---------------------------------------------------------------------------------------------
def mean_colour(model: str) -> tuple[float, float, float]:
    """Mean RGB of a model's visible geoms (each geom counts once)."""
    m = get_model(model)
    geoms = [*m.geoms, *(g for link in m.links for g in link.geoms)]
    rgbs = [(g.rgba or m.rgba)[:3] for g in geoms if g.role != "collision"]
    mean = np.mean(np.asarray(rgbs, dtype=np.float64), axis=0)
    return (float(mean[0]), float(mean[1]), float(mean[2]))


def target_variant(task: TaskSpec, recipe: Recipe) -> tuple[TaskSpec, Provenance]:
    """Recolour the target role's first instance with palette entry ``task_id mod 6`` (or the next one far
    enough from its mean colour)."""
    role = ood_settings(recipe).target
    instance = _instances(task, recipe)[role][0]
    mean = np.array(mean_colour(task.object(instance).model))
    skipped = []
    for step in range(len(PALETTE)):
        index = (task.task_id + step) % len(PALETTE)
        hexa, rgb = PALETTE[index]
        distance = float(np.linalg.norm(np.array(rgb) - mean))
        if distance >= MIN_COLOUR_DISTANCE:
            break
        skipped.append(hexa)
    else:  # pragma: no cover - the palette spans the colour cube; no colour is near all six entries
        raise RecipeError(
            f"{recipe.path}: every palette colour is within {MIN_COLOUR_DISTANCE} of {instance}"
        )
    variant = dataclasses.replace(task, condition="target", tint=MappingProxyType({instance: rgb}))
    return variant, {
        "kind": "target",
        "role": role,
        "instance": instance,
        "model": task.object(instance).model,
        "palette_index": index,
        "colour": hexa,
        "tint": list(rgb),
        "skipped": skipped,
        "mean_rgb": [round(float(v), 6) for v in mean],
        "distance": round(distance, 6),
    }


# -- language -------------------------------------------------------------------------------------------
def language_variant(task: TaskSpec, recipe: Recipe) -> tuple[TaskSpec, Provenance]:
    """The prompt with the recipe's swaps applied to the template's literal text (names untouched)."""
    ood = ood_settings(recipe)
    names = _template_names(recipe.prompt, task.prompt, str(recipe.path))
    pieces, applied = [], []
    for literal, field, spec, conv in string.Formatter().parse(recipe.prompt):
        for old, new in ood.swaps:
            literal, n = _swap(literal, old, new)
            if n:
                applied.append([old, new])
        pieces.append(literal.replace("{", "{{").replace("}", "}}"))
        if field is not None:
            pieces.append("{" + field + (f"!{conv}" if conv else "") + (f":{spec}" if spec else "") + "}")
    prompt = "".join(pieces).format(**names)
    if prompt == task.prompt:
        raise RecipeError(
            f"{recipe.path}: [ood.language] swaps change nothing in the prompt "
            f"{recipe.prompt!r}; add a swap for one of its words"
        )
    for word in ood.guard:
        pattern = rf"\b{re.escape(word)}\b"
        if len(re.findall(pattern, prompt, re.I)) > len(re.findall(pattern, task.prompt, re.I)):
            raise RecipeError(
                f"{recipe.path}: [ood.language] swaps introduce the guarded word {word!r}: {prompt!r}"
            )
    variant = dataclasses.replace(task, condition="language", prompt=prompt)
    unique = [list(p) for p in dict.fromkeys(tuple(a) for a in applied)]
    return variant, {"kind": "language", "base_prompt": task.prompt, "swaps": unique}


def prompt_forms(prompt: str, spec: SafetySpec) -> dict[str, str]:
    """The instruction-form study's three prompts: no clause, a natural-language clause, the LTL_f one."""
    return {form: prompt + prompt_suffix(spec, form) for form in PROMPT_FORMS}


def _swap(text: str, old: str, new: str) -> tuple[str, int]:
    """Replace whole-word ``old`` by ``new``; a capitalised ``Old`` becomes a capitalised ``New``."""
    count = 0
    cap_old, cap_new = old[:1].upper() + old[1:], new[:1].upper() + new[1:]

    def repl(match: re.Match[str]) -> str:
        nonlocal count
        found = match.group(0)
        if found not in (old, cap_old):
            return found
        count += 1
        return new if found == old else cap_new

    return re.sub(rf"(?<!\w){re.escape(old)}(?!\w)", repl, text, flags=re.IGNORECASE), count


def _template_names(template: str, prompt: str, where: str) -> dict[str, str]:
    """The values the template's fields were filled with in ``prompt``."""
    regex, seen = "", set()
    for literal, field, _, _ in string.Formatter().parse(template):
        regex += re.escape(literal)
        if field is not None:
            regex += f"(?P={field})" if field in seen else f"(?P<{field}>.+?)"
            seen.add(field)
    match = re.fullmatch(regex, prompt, re.S)
    if match is None:
        raise RecipeError(f"{where}: the prompt {prompt!r} does not come from the template {template!r}")
    return match.groupdict()


# -- environment ----------------------------------------------------------------------------------------
def environment_variant(task: TaskSpec, recipe: Recipe) -> tuple[TaskSpec, Provenance]:
    """The task inside a room style drawn from ``[ood.environment] rooms`` by the task's own seed."""
    rooms = ood_settings(recipe).rooms
    rng = np.random.default_rng(np.random.SeedSequence([recipe.tasks.seed, task.task_id, _ENV_STREAM]))
    room = rooms[int(rng.integers(len(rooms)))]
    return dataclasses.replace(task, condition="environment", room=room), {
        "kind": "environment",
        "room": room,
    }


# -- location -------------------------------------------------------------------------------------------
def location_proposal(task: TaskSpec, recipe: Recipe, attempt: int) -> tuple[TaskSpec, Provenance]:
    """Attempt ``attempt`` of the displacement (ungated). Attempts in the later half of ``tries`` turn an
    earlier attempt's direction by 90° and scale its magnitude by ``fallback_scale``.

    Raises:
        LayoutRejected: the clamped move is too small, footprints overlap, or the goal is no longer clear.
    """
    rule = ood_settings(recipe).location
    half = rule.tries // 2
    fallback = attempt >= half
    rng = np.random.default_rng(
        np.random.SeedSequence(
            [recipe.tasks.seed, task.task_id, _LOCATION_STREAM, attempt - half if fallback else attempt]
        )
    )
    instances = _instances(task, recipe)
    units = _units(task, recipe, instances)
    moves: dict[str, tuple[float, float]] = {}
    record = []
    for unit in units:
        top = [n for n in unit if n in _standing(recipe, instances)]
        extent = _extent(task, top)
        magnitude = float(rng.uniform(*rule.fraction)) * extent
        direction = _direction(task, recipe, instances, rng)
        if fallback:
            direction = np.array([-direction[1], direction[0]])
            magnitude *= rule.fallback_scale
        want = direction * magnitude
        d = _clamp(task, top, want, rule.margin)
        if np.linalg.norm(d) < 0.5 * rule.fraction[0] * extent * (rule.fallback_scale if fallback else 1.0):
            raise LayoutRejected(
                "location.clamped",
                f"the table's edge leaves {unit[0]!r} a move of only {np.linalg.norm(d) * 100:.1f} cm",
            )
        for n in unit:
            moves[n] = (float(d[0]), float(d[1]))
        record.append(
            {
                "objects": list(unit),
                "extent": round(extent, 6),
                "offset": [round(float(d[0]), 6), round(float(d[1]), 6)],
            }
        )
    objects = tuple(
        dataclasses.replace(
            o,
            pos=(o.pos[0] + moves.get(o.name, (0, 0))[0], o.pos[1] + moves.get(o.name, (0, 0))[1], o.pos[2]),
        )
        for o in task.objects
    )
    goal = task.goal
    if goal is not None and rule.grouping == "pack":
        dx, dy = moves[unit[0]]
        goal = GoalRegion((goal.pos[0] + dx, goal.pos[1] + dy, goal.pos[2]), goal.radius, goal.name)
    variant = dataclasses.replace(
        task, condition="location", objects=objects, goal=goal, gate=MappingProxyType({})
    )
    _check_clear(variant, recipe, instances)
    return variant, {
        "kind": "location",
        "grouping": rule.grouping,
        "attempt": attempt,
        "fallback": fallback,
        "units": record,
        "goal_moved": rule.grouping == "pack",
    }


def _units(task: TaskSpec, recipe: Recipe, instances: dict[str, list[str]]) -> list[list[str]]:
    """Instance names moved together, each unit with the guests of its members."""
    rule = ood_settings(recipe).location
    standing = _standing(recipe, instances)
    if rule.grouping == "pack":
        groups = [[n for n in (o.name for o in task.objects) if n in standing]]
    elif rule.grouping == "each":
        groups = [[n] for n in (o.name for o in task.objects) if n in standing]
    else:
        groups = [[n for role in unit for n in instances[role]] for unit in rule.units]
    hosts = _host_of(recipe, instances)
    out = []
    for group in groups:
        members = list(group)
        for guest, host in hosts.items():  # guests in task order, after their hosts
            if host in members:
                members.append(guest)
        out.append(members)
    return out


def _host_of(recipe: Recipe, instances: dict[str, list[str]]) -> dict[str, str]:
    """guest instance -> the standing instance it rides on (transitively)."""
    direct = {}
    for role in recipe.layout.roles:
        if role.host is not None and role.placement in ("inside", "on"):
            for n in instances.get(role.name, []):
                direct[n] = instances[role.host][0]
    out = {}
    for guest, host in direct.items():
        while host in direct:
            host = direct[host]
        out[guest] = host
    return out


def _standing(recipe: Recipe, instances: dict[str, list[str]]) -> set[str]:
    return {
        n
        for role in recipe.layout.roles
        if role.placement not in ("inside", "on")
        for n in instances.get(role.name, [])
    }


def _extent(task: TaskSpec, names: list[str]) -> float:
    """Diameter (m) of a circle around the names' footprints, centred on their mean position."""
    pts = np.array([task.object(n).pos[:2] for n in names])
    centre = pts.mean(axis=0)
    return 2.0 * max(
        float(np.linalg.norm(p - centre)) + footprint_radius(task.object(n).model)
        for n, p in zip(names, pts, strict=True)
    )


def _direction(
    task: TaskSpec, recipe: Recipe, instances: dict[str, list[str]], rng: np.random.Generator
) -> np.ndarray:
    rule = ood_settings(recipe).location.direction
    if rule.of is None:
        angle = float(rng.uniform(-math.pi, math.pi))
        return np.array([math.cos(angle), math.sin(angle)])
    yaw = task.object(instances[rule.of][0]).yaw
    c, s = math.cos(yaw), math.sin(yaw)
    axis = np.array([c * rule.axis[0] - s * rule.axis[1], s * rule.axis[0] + c * rule.axis[1]])
    return axis if rng.uniform() < 0.5 else -axis


def _clamp(task: TaskSpec, names: list[str], want: np.ndarray, margin: float) -> np.ndarray:
    """``want`` limited per axis so every footprint of ``names`` stays on the table (``margin`` inside)."""
    lo, hi = np.array([-np.inf, -np.inf]), np.array([np.inf, np.inf])
    for n in names:
        o = task.object(n)
        r = footprint_radius(o.model) + margin
        lo = np.maximum(lo, [TABLE_X[0] + r - o.pos[0], TABLE_Y[0] + r - o.pos[1]])
        hi = np.minimum(hi, [TABLE_X[1] - r - o.pos[0], TABLE_Y[1] - r - o.pos[1]])
    return np.clip(want, np.minimum(lo, 0.0), np.maximum(hi, 0.0))


def _check_clear(task: TaskSpec, recipe: Recipe, instances: dict[str, list[str]]) -> None:
    """Standing footprints apart; the goal still clear of the roles the layout keeps it clear of."""
    standing = [o for o in task.objects if o.name in _standing(recipe, instances)]
    for i, a in enumerate(standing):
        for b in standing[i + 1 :]:
            gap = math.dist(a.pos[:2], b.pos[:2]) - footprint_radius(a.model) - footprint_radius(b.model)
            if gap < 0.0:
                raise LayoutRejected(
                    "location.overlap", f"{a.name} and {b.name} would overlap ({-gap * 100:.1f} cm)"
                )
    rule = recipe.layout.goal
    if task.goal is None or rule is None:
        return
    if instances.get(rule.origin):
        rule = rule.for_model(task.object(instances[rule.origin][0]).model)
    for role in rule.clear_of:
        for n in instances.get(role, []):
            o = task.object(n)
            if math.dist(o.pos[:2], task.goal.pos[:2]) < footprint_radius(o.model) + rule.clearance:
                raise LayoutRejected("location.goal_clear", f"{n} would stand under the goal")


def _instances(task: TaskSpec, recipe: Recipe) -> dict[str, list[str]]:
    """role -> its instance names in the task (``role`` or ``role_0`` …)."""
    out: dict[str, list[str]] = {}
    for role in recipe.layout.roles:
        out[role.name] = [
            o.name
            for o in task.objects
            if o.name == role.name or re.fullmatch(rf"{re.escape(role.name)}_\d+", o.name)
        ]
    return out


def ood_settings(recipe: Recipe) -> OodSettings:
    """The recipe's ``[ood]`` (defaults for a Recipe built without :func:`load_recipe`)."""
    return recipe.ood or default_ood(recipe.layout)
