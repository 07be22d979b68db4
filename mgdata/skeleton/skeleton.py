"""FamilySkeleton: the contract a task family fills in (Layer 3), and the registry by skeleton name.

A family is a recipe (``recipes/<family>.toml``) and the skeleton it names (``skeleton = "clutter"`` →
``skeletons/clutter.py``); several recipes may share one skeleton (``clutter_dry``, ``clutter_liquid``).

A skeleton says *what* the demonstration does, as an ordered list of :class:`MotionSegment` (``segments``),
or as named phases of segments, each with a physical postcondition (``phases``,
:mod:`mgdata.skeleton.phase`: a demonstration restarted from a mid-task state runs only the phases not done
yet); a skeleton defines one of the two and the other follows. The executor does the planning, execution,
monitoring and gating. Hooks beyond these:

* ``resolve(name, ctx)``: the world TCP pose of a named runtime target, computed from the live state;
* ``success_extra(ctx)``: a family check on top of the recipe's goal predicate (default: none);
* ``feasibility(ctx, min_grasps)``: the skeleton's part of the initial-state gate
  (``mgdata.engine.init_gate``): raise
  :class:`~mgdata.skeleton.skeleton.Infeasible` when the task cannot be done from its initial state (default:
  nothing to check).

A skeleton also declares, as ``recipe_keys``, every ``[params]`` and ``[variation]`` key it reads (name, type,
range, one-line doc); :func:`load_family_recipe` checks the recipe against it when it loads, so a skeleton
reads only declared keys, with the declared types (``ctx.params["open_steps"]`` is an ``int``).

Skeletons live in ``skeletons/<name>.py`` (the package ``mgdata.skeletons``) and register themselves with
:func:`register`; each is declared in the ``mgdata.families`` entry-point group and imported on first use by
:func:`skeleton_for` (another distribution contributes a family the same way; see docs/new-family.md).

Example::

    @register
    class JarSkeleton(FamilySkeleton):
        name = "jar"
        recipe_keys = RecipeKeys(params=(Param("open_steps", int, "steps to open the gripper", low=1),),
                                 variation=(Knob("lift_height", "m lifted above the table", 0.0, 0.3),))

        def segments(self, ctx):
            return [free("pre", "pre_grasp"), ...]

        def resolve(self, name, ctx):
            ...
"""

from __future__ import annotations

import sys
from collections.abc import Sequence
from importlib.metadata import EntryPoint, entry_points
from importlib.util import module_from_spec, spec_from_file_location
from pathlib import Path
from typing import TYPE_CHECKING, ClassVar

from mgdata.errors import RecipeError, UnknownFamilyError
from mgdata.paths import project_root
from mgdata.skeleton.phase import Phase, flatten
from mgdata.tasks.recipe import Recipe, check_recipe_keys, family_recipes, load_recipe
from mgdata.tasks.recipe_keys import Knob, Param, RecipeKeys

__all__ = ["FamilySkeleton", "Infeasible", "Knob", "Param", "RecipeKeys", "available_families",
           "available_skeletons", "load_family_recipe", "register", "skeleton_class", "skeleton_for"]

if TYPE_CHECKING:
    from mgdata.motion.types import Pose
    from mgdata.skeleton.context import Context
    from mgdata.skeleton.segment import MotionSegment


class Infeasible(Exception):
    """The drawn task fails the gate: ``rule`` names what (``"init.at_rest"``, ``"reach.grasps"`` …)."""

    def __init__(self, rule: str, why: str) -> None:
        super().__init__(f"{rule}: {why}")
        self.rule, self.why = rule, why


class FamilySkeleton:
    """Base class of the per-family skeletons. Subclasses set ``name`` and ``recipe_keys`` and implement
    ``segments`` or ``phases``."""

    name: ClassVar[str] = ""
    recipe_keys: ClassVar[RecipeKeys] = RecipeKeys()
    """The recipe's ``[params]`` and ``[variation]`` keys this skeleton reads (a recipe must have exactly
    these)."""

    def __init_subclass__(cls, **kwargs: object) -> None:
        super().__init_subclass__(**kwargs)
        if cls.segments is FamilySkeleton.segments and cls.phases is FamilySkeleton.phases:
            raise TypeError(f"{cls.__name__} must define segments() or phases()")

    def segments(self, ctx: Context) -> Sequence[MotionSegment]:
        """The demonstration's segments, in order, for this attempt (``ctx.variation`` holds the draws);
        default: those of :meth:`phases`."""
        return flatten(self.phases(ctx))

    def phases(self, ctx: Context) -> Sequence[Phase]:
        """The demonstration as named phases (:mod:`mgdata.skeleton.phase`); default: one phase,
        ``demonstration``, of every segment, without a postcondition (a restart runs all of it)."""
        return [Phase("demonstration", tuple(self.segments(ctx)))]

    def resolve(self, name: str, ctx: Context) -> Pose:
        """The world TCP pose of runtime target ``name``, from the live state in ``ctx``."""
        raise KeyError(f"skeleton {self.name!r} has no runtime target {name!r}")

    def success_extra(self, ctx: Context) -> bool:
        """A family-specific success condition evaluated with the goal predicate (default: always true)."""
        return True

    def feasibility(self, ctx: Context, min_grasps: int) -> dict[str, object]:
        """Check that the task can be done from its settled initial state (``ctx`` at draw 0), with at
        least ``min_grasps`` reachable grasps of what it picks; raise ``mgdata.skeleton.skeleton.Infeasible``
        if not. Returns facts the accepted task keeps in ``TaskSpec.gate`` (e.g. the reachable grasp ids)."""
        return {}


_REGISTRY: dict[str, type[FamilySkeleton]] = {}


def register(cls: type[FamilySkeleton]) -> type[FamilySkeleton]:
    """Class decorator: make ``cls`` the skeleton named ``cls.name``."""
    if not cls.name:
        raise ValueError(f"{cls.__name__} must set the class attribute 'name'")
    _REGISTRY[cls.name] = cls
    return cls


def available_families() -> tuple[str, ...]:
    """The families: the recipes under ``recipes/`` (each names its skeleton)."""
    return family_recipes()


FAMILIES_GROUP = "mgdata.families"
"""Entry-point group naming the skeletons: ``<skeleton name> = "<module registering it>"`` (or
``"<module>:<class>"``). mgdata's own families are declared in its ``pyproject.toml``; another installed
distribution adds its families the same way."""


def _entry_points() -> dict[str, EntryPoint]:
    return {ep.name: ep for ep in entry_points(group=FAMILIES_GROUP)}


def _root_skeleton(name: str) -> Path | None:
    """``<root>/skeletons/<name>.py`` of a user's root folder (``MGDATA_ROOT`` / ``--root``), if any."""
    root = project_root()
    file = root / "skeletons" / f"{name}.py" if root is not None and name.isidentifier() else None
    return file if file is not None and file.is_file() else None


def _load_file(module: str, file: Path) -> None:
    spec = spec_from_file_location(module, file)
    if spec is None or spec.loader is None:
        raise UnknownFamilyError(f"{file}: not a Python module")
    loaded = module_from_spec(spec)
    sys.modules[module] = loaded
    spec.loader.exec_module(loaded)


def available_skeletons() -> tuple[str, ...]:
    """Skeletons declared in the ``mgdata.families`` entry-point group, in the root folder's ``skeletons/``
    or registered in this process."""
    root = project_root()
    in_root = {p.stem for p in (root / "skeletons").glob("[!_]*.py")} if root is not None else set()
    return tuple(sorted(set(_entry_points()) | {n for n in in_root if n.isidentifier()} | set(_REGISTRY)))


def skeleton_for(name: str) -> FamilySkeleton:
    """A fresh instance of skeleton ``name``, loading it (:func:`skeleton_class`) if needed.

    Raises:
        UnknownFamilyError: no such skeleton; the message lists the skeletons that exist.
    """
    return skeleton_class(name)()


def load_family_recipe(family_or_path: str | Path) -> Recipe:
    """Load a recipe (by family name or path) and check it against its skeleton's ``recipe_keys``: the
    whole recipe is checked before anything runs, and ``params``/``variation`` hold typed values.

    Raises:
        RecipeError: the recipe is malformed, or lacks/misspells/mistypes a key the skeleton reads.
        UnknownFamilyError: no recipe or no skeleton for the family.
    """
    recipe = load_recipe(family_or_path)
    try:
        cls = skeleton_class(recipe.skeleton)
    except UnknownFamilyError as err:
        raise RecipeError(f"{recipe.path}: skeleton = {recipe.skeleton!r}: {err}") from None
    return check_recipe_keys(recipe, cls.recipe_keys)


def skeleton_class(name: str) -> type[FamilySkeleton]:
    """The skeleton class named ``name``, loading its ``mgdata.families`` entry point, else
    ``<root>/skeletons/<name>.py``, if needed."""
    if name not in _REGISTRY and (ep := _entry_points().get(name)) is not None:
        loaded = ep.load()
        if isinstance(loaded, type) and issubclass(loaded, FamilySkeleton) and name not in _REGISTRY:
            register(loaded)
    if name not in _REGISTRY and (file := _root_skeleton(name)) is not None:
        _load_file(f"mgdata_root_skeletons.{name}", file)
    if name not in _REGISTRY:
        known = ", ".join(available_skeletons()) or "none"
        raise UnknownFamilyError(f"no skeleton {name!r} (skeletons: {known})")
    return _REGISTRY[name]
