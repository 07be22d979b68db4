"""Recipe: a family's TOML (``recipes/<family>.toml``) as typed data, with errors naming file and key.

A recipe holds everything about a family that is data rather than code: the safety spec file, the prompt
template, how many base tasks to generate and from which seed, the success (goal) predicate, the layout
rules the family's layout builder reads, the per-attempt variation knobs and the skeleton's tunables.

Top-level keys and tables::

    family = "jar"                       # the file name's stem
    skeleton = "jar"                     # skeletons/jar.py: the motion (several recipes may share one)
    spec = "specs/jar.toml"              # relative to the recipe's folder
    prompt = "Close the lid of the hinged jar holding the {food}, then ..."   # {role}: its display name

    [tasks]   count, seed, horizon (control steps), hold_steps, settle_steps, rest speeds, max_draws,
              min_grasps, cameras, image_size
    [success.<name>]  evaluator, subjects, params, quantifier   (all must hold; like spec propositions)
    [layout]      roles, goal and display names for the generic placer (mgdata.tasks.layout_rules)
    [variation]   knob = [low, high]      (drawn per attempt; draw 0 takes the midpoints)
    [params]      skeleton tunables (copied into every TaskSpec.params)
    [ood]         how the OOD variants are built (mgdata.tasks.ood; optional, docs/scenarios.md)
    [recovery]    perturbed execution with corrective labels (mgdata.tasks.recovery; optional, off)
    [cameras]     the family's third-person framing over recipes/sim.toml's (mgdata.sim.cameras; optional)
    [appearance]  per-episode appearance draws for the cameras (mgdata.sim.appearance_draw; optional, off)

``[params]`` and ``[variation]`` hold exactly the keys the family's skeleton declares it reads
(:class:`mgdata.tasks.recipe_keys.RecipeKeys`); :func:`check_recipe_keys` checks them (names, types, ranges)
and gives typed values. The engine loads recipes through ``mgdata.skeleton.skeleton.load_family_recipe``,
which does both.

Example::

    recipe = load_recipe("jar")
    recipe.tasks.count, recipe.variation["standoff_m"]
"""

from __future__ import annotations

import dataclasses
import hashlib
import math
import tomllib
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from types import MappingProxyType
from typing import Any

from mgdata.errors import RecipeError, UnknownFamilyError
from mgdata.paths import recipe_dirs, recipes_dir
from mgdata.sim.appearance_draw import AppearanceSettings, parse_appearance
from mgdata.sim.cameras import parse_family_cameras
from mgdata.sim.config import load_sim_config
from mgdata.spec import Proposition, SafetySpec, load_spec, proposition_from_mapping
from mgdata.tasks.layout_rules import Layout, parse_layout
from mgdata.tasks.ood import OodSettings, parse_ood
from mgdata.tasks.recipe_keys import RecipeKeys, check_params, check_variation
from mgdata.tasks.recovery import RecoverySettings, parse_recovery

CAMERAS: tuple[str, ...] = ("front", "left", "right", "shoulder", "wrist")
MAX_IMAGE_SIZE = 2048
"""Largest camera image side (pixels) a recipe may ask for (an offscreen framebuffer per worker)."""


@dataclass(frozen=True)
class TaskSettings:
    """The ``[tasks]`` table: base-task count and seed, attempt horizon and gate, recording settings."""

    count: int
    seed: int
    horizon: int
    hold_steps: int = 10
    settle_steps: int = 40
    rest_linear_speed: float = 0.005  # m/s: the goal's objects count as at rest below this (the gate)
    rest_angular_speed: float = 0.05  # rad/s: … and below this
    max_penetration: float = 0.001  # m: no contact of a kept demo's frames overlaps deeper (the gate)
    max_draws: int = 20  # the initial-state gate draws a task at most this many times before giving up
    min_grasps: int = 2  # … and accepts it when at least this many target grasps are reachable
    cameras: tuple[str, ...] = CAMERAS
    image_size: int = field(kw_only=True)  # the recipe's, else recipes/sim.toml [cameras] image_size


@dataclass(frozen=True)
class Recipe:
    """A loaded family recipe.

    Attributes:
        family: family name (file stem).
        skeleton: the skeleton module (``skeletons/<skeleton>.py``) that performs it.
        path: the recipe file.
        spec: the safety specification (from the file named by ``spec``).
        prompt: instruction template; ``{name}`` fields are filled by the layout builder.
        tasks: the ``[tasks]`` settings.
        success: the goal predicate, a conjunction of propositions over the scene.
        layout: the placement rules (roles, goal, display names).
        variation: knob name -> (low, high).
        params: skeleton tunables.
        digest: hash of the recipe and spec files (a dataset records it; resume requires the same).
        ood: how its OOD variants are built (``[ood]``, :mod:`mgdata.tasks.ood`; defaults if absent).
        recovery: perturbed execution (``[recovery]``, :mod:`mgdata.tasks.recovery`; off if absent).
        appearance: per-episode appearance draws (``[appearance]``, :mod:`mgdata.sim.appearance_draw`; off
            if absent).
        cameras: the family's third-person framing (``[cameras]``: ``fovy``, ``look_at``, the four eyes)
            over ``recipes/sim.toml``'s, copied into every TaskSpec (empty if absent).
    """

    family: str
    skeleton: str
    path: Path
    spec: SafetySpec
    prompt: str
    tasks: TaskSettings
    success: tuple[Proposition, ...]
    layout: Layout
    variation: Mapping[str, tuple[float, float]]
    params: Mapping[str, Any]
    digest: str
    ood: OodSettings | None = None
    recovery: RecoverySettings = field(default_factory=RecoverySettings)
    appearance: AppearanceSettings = field(default_factory=AppearanceSettings)
    cameras: Mapping[str, Any] = field(default_factory=lambda: MappingProxyType({}))


def recipe_path(family: str) -> Path:
    """``recipes/<family>.toml`` (or a plugin's, :func:`mgdata.paths.recipe_dirs`), or
    :class:`UnknownFamilyError` listing the recipes that exist."""
    for folder in recipe_dirs():
        if (folder / f"{family}.toml").is_file():
            return folder / f"{family}.toml"
    path = recipes_dir() / f"{family}.toml"
    known = ", ".join(family_recipes()) or "none"
    raise UnknownFamilyError(f"no recipe for family {family!r} at {path} (family recipes: {known})")


def family_recipes() -> tuple[str, ...]:
    """The families with a recipe in ``recipes/`` (files with a ``family`` key; not sim, motion, grasps)."""
    found: list[str] = []
    for path in (p for folder in recipe_dirs() for p in sorted(folder.glob("*.toml"))):
        try:
            if path.stem not in found and "family" in tomllib.loads(path.read_text(encoding="utf-8")):
                found.append(path.stem)
        except (OSError, UnicodeDecodeError, tomllib.TOMLDecodeError):
            continue
    return tuple(found)


def check_recipe_keys(recipe: Recipe, keys: RecipeKeys) -> Recipe:
    """``recipe`` with ``[params]`` and ``[variation]`` checked against what its skeleton reads (``keys``):
    unknown keys (with the closest known one), missing keys, types and ranges; values come back typed."""
    src = str(recipe.path)
    params = check_params(recipe.params, keys.params, f"{src}: [params]")
    variation = check_variation(recipe.variation, keys.variation, f"{src}: [variation]")
    return dataclasses.replace(recipe, params=MappingProxyType(params), variation=MappingProxyType(variation))


def with_recovery(recipe: Recipe, mode: str | None) -> Recipe:
    """``recipe`` with its ``[recovery] mode`` replaced by ``mode`` (``generate --recovery``; ``None``:
    unchanged), checked as the recipe's own key is."""
    if mode is None:
        return recipe
    table = {**dataclasses.asdict(recipe.recovery), "mode": mode}
    return dataclasses.replace(recipe, recovery=parse_recovery(table, "--recovery:"))


def load_recipe(family_or_path: str | Path) -> Recipe:
    """Load and validate a recipe by family name (a ``str`` not ending in ``.toml``) or by path (a ``Path``,
    or a ``str`` ending in ``.toml``)."""
    by_path = isinstance(family_or_path, Path) or str(family_or_path).endswith(".toml")
    path = Path(family_or_path) if by_path else recipe_path(str(family_or_path))
    raw = _read_toml(path)
    src = str(path)
    family = _get(raw, "family", str, src)
    if family != path.stem:
        raise RecipeError(f"{src}: family = {family!r} must match the file name {path.stem!r}")
    skeleton = _get(raw, "skeleton", str, src)
    if not skeleton.isidentifier():
        raise RecipeError(f"{src}: skeleton = {skeleton!r} must name a module skeletons/<name>.py")
    spec_path = path.parent / _get(raw, "spec", str, src)
    spec = _load_spec(spec_path, src)
    prompt = _get(raw, "prompt", str, src)
    tasks = _tasks(_table(raw, "tasks", src), src)
    success = tuple(proposition_from_mapping(k, v, f"{src}: success.{k}")
                    for k, v in _table(raw, "success", src).items())
    if not success:
        raise RecipeError(f"{src}: [success] must name at least one goal proposition")
    layout = parse_layout(_table(raw, "layout", src), f"{src}: [layout]")
    variation = {k: _range(v, f"{src}: [variation] {k}") for k, v in _table(raw, "variation", src).items()}
    params = _table(raw, "params", src, required=False)
    ood = parse_ood(_table(raw, "ood", src, required=False), layout, f"{src}: [ood]")
    recovery = parse_recovery(_table(raw, "recovery", src, required=False), f"{src}: [recovery]")
    appearance = parse_appearance(_table(raw, "appearance", src, required=False), f"{src}: [appearance]")
    cameras = parse_family_cameras(_table(raw, "cameras", src, required=False), load_sim_config().cameras,
                                   f"{src}: [cameras]")
    top = {"family", "skeleton", "spec", "prompt", "tasks", "success", "layout", "variation", "params", "ood",
           "recovery", "appearance", "cameras"}
    unknown = set(raw) - top
    if unknown:
        raise RecipeError(f"{src}: unknown top-level key(s) {sorted(unknown)}")
    digest = hashlib.sha256(path.read_bytes() + b"\0" + spec_path.read_bytes()).hexdigest()[:16]
    return Recipe(family, skeleton, path, spec, prompt, tasks, success, layout,
                  MappingProxyType(variation), MappingProxyType(params), digest, ood, recovery, appearance,
                  cameras)


def _read_toml(path: Path) -> dict[str, Any]:
    try:
        return tomllib.loads(path.read_text(encoding="utf-8"))
    except FileNotFoundError:
        raise RecipeError(f"recipe {path} does not exist") from None
    except UnicodeDecodeError:
        raise RecipeError(f"{path}: not a UTF-8 text file") from None
    except OSError as err:
        raise RecipeError(f"recipe {path}: cannot be read ({err.strerror or err})") from None
    except tomllib.TOMLDecodeError as err:
        raise RecipeError(f"{path}: not valid TOML: {err}") from None


def _load_spec(path: Path, src: str) -> SafetySpec:
    if not path.is_file():
        raise RecipeError(f"{src}: spec file {path} does not exist")
    try:
        return load_spec(path)
    except UnicodeDecodeError:
        raise RecipeError(f"{src}: spec file {path} is not a UTF-8 text file") from None
    except OSError as err:
        raise RecipeError(f"{src}: spec file {path} cannot be read ({err.strerror or err})") from None


def _tasks(table: dict[str, Any], src: str) -> TaskSettings:
    where = f"{src}: [tasks]"
    rest_keys = ("rest_linear_speed", "rest_angular_speed", "max_penetration")
    known = {"count", "seed", "horizon", "hold_steps", "settle_steps", *rest_keys, "max_draws", "min_grasps",
             "cameras", "image_size"}
    if set(table) - known:
        raise RecipeError(f"{where} unknown key(s) {sorted(set(table) - known)}; expected {sorted(known)}")
    ints = {k: _get(table, k, int, where) for k in ("count", "seed", "horizon")}
    for k in ("hold_steps", "settle_steps", "max_draws", "min_grasps", "image_size"):
        if k in table:
            ints[k] = _get(table, k, int, where)
    for k, v in ints.items():
        low = 0 if k in ("seed", "settle_steps", "min_grasps") else 8 if k == "image_size" else 1
        high = MAX_IMAGE_SIZE if k == "image_size" else None
        if v < low or (high is not None and v > high):
            expected = f"an integer in [{low}, {high}]" if high else f"an integer >= {low}"
            raise RecipeError(f"{where} {k} = {v} is out of range (expected {expected})")
    rest = {k: _get(table, k, float, where) for k in rest_keys if k in table}
    for k, v in rest.items():
        if not v > 0:
            what = "a depth > 0 (m)" if k == "max_penetration" else "a speed > 0"
            raise RecipeError(f"{where} {k} = {v} is out of range (expected {what})")
    raw_cameras = table.get("cameras", list(CAMERAS))
    cameras = tuple(raw_cameras) if isinstance(raw_cameras, list) else ("?",)
    bad = [c for c in cameras if c not in CAMERAS]
    if bad or len(set(cameras)) != len(cameras):  # [] : a camera-free (state-only) dataset
        raise RecipeError(f"{where} cameras = {raw_cameras!r}: expected a subset of {list(CAMERAS)} "
                          "([] for a camera-free, state-only dataset)")
    if "image_size" not in ints:
        from mgdata.sim.config import default_image_size  # imports mujoco: only when a recipe sets no size

        ints["image_size"] = default_image_size()
    return TaskSettings(cameras=cameras, **ints, **rest)


def _range(raw: Any, where: str) -> tuple[float, float]:
    ok = isinstance(raw, list) and len(raw) == 2 and all(
        isinstance(v, int | float) and not isinstance(v, bool) and math.isfinite(v) for v in raw)
    if not ok or raw[0] > raw[1]:
        raise RecipeError(f"{where} = {raw!r}: expected [low, high] numbers with low <= high")
    return float(raw[0]), float(raw[1])


def _get(table: Mapping[str, Any], key: str, kind: type, where: str) -> Any:
    if key not in table:
        raise RecipeError(f"{where}: missing key {key!r}")
    value = table[key]
    if kind is float and isinstance(value, int) and not isinstance(value, bool):
        return float(value)
    if not isinstance(value, kind) or (kind is int and isinstance(value, bool)):
        raise RecipeError(f"{where}: {key} = {value!r} should be a {kind.__name__}")
    return value


def _table(raw: Mapping[str, Any], key: str, src: str, required: bool = True) -> dict[str, Any]:
    if key not in raw:
        if required:
            raise RecipeError(f"{src}: missing table [{key}]")
        return {}
    if not isinstance(raw[key], dict):
        raise RecipeError(f"{src}: {key} must be a table ([{key}])")
    return dict(raw[key])
