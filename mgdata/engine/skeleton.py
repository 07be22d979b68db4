"""FamilySkeleton: the contract a task family fills in (Layer 3), and the registry by family name.

A skeleton says *what* the demonstration does, as an ordered list of :class:`MotionSegment`; the executor
does the planning, execution, monitoring and gating. Hooks beyond ``segments``:

* ``resolve(name, ctx)``: the world TCP pose of a named runtime target, computed from the live state;
* ``success_extra(ctx)``: a family check on top of the recipe's goal predicate (default: none).

A skeleton also declares, as ``recipe_keys``, every ``[params]`` and ``[variation]`` key it reads (name, type,
range, one-line doc); :func:`load_family_recipe` checks the recipe against it when it loads, so a skeleton
reads only declared keys, with the declared types (``ctx.params["open_steps"]`` is an ``int``).

Skeletons live in ``skeletons/<family>.py`` and register themselves with :func:`register`; they are imported
on first use by :func:`skeleton_for`.

Example::

    @register
    class JarSkeleton(FamilySkeleton):
        family = "jar"
        recipe_keys = RecipeKeys(params=(Param("open_steps", int, "steps to open the gripper", low=1),),
                                 variation=(Knob("lift_height", "m lifted above the table", 0.0, 0.3),))

        def segments(self, ctx):
            return [free("pre", "pre_grasp"), ...]

        def resolve(self, name, ctx):
            ...
"""

from __future__ import annotations

import importlib
from abc import ABC, abstractmethod
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING, ClassVar

from mgdata.errors import RecipeError, UnknownFamilyError
from mgdata.paths import project_root
from mgdata.tasks.recipe import Recipe, check_recipe_keys, load_recipe
from mgdata.tasks.recipe_keys import Knob, Param, RecipeKeys

__all__ = ["FamilySkeleton", "Knob", "Param", "RecipeKeys", "available_families", "load_family_recipe",
           "register", "skeleton_class", "skeleton_for"]

if TYPE_CHECKING:
    from mgdata.engine.context import Context
    from mgdata.engine.segment import MotionSegment
    from mgdata.motion.types import Pose


class FamilySkeleton(ABC):
    """Base class of the per-family skeletons. Subclasses set ``family`` and ``recipe_keys`` and implement
    ``segments``."""

    family: ClassVar[str] = ""
    recipe_keys: ClassVar[RecipeKeys] = RecipeKeys()
    """The recipe's ``[params]`` and ``[variation]`` keys this skeleton reads (a recipe must have exactly
    these)."""

    @abstractmethod
    def segments(self, ctx: Context) -> Sequence[MotionSegment]:
        """The demonstration's segments, in order, for this attempt (``ctx.variation`` holds the draws)."""

    def resolve(self, name: str, ctx: Context) -> Pose:
        """The world TCP pose of runtime target ``name``, from the live state in ``ctx``."""
        raise KeyError(f"skeleton {self.family!r} has no runtime target {name!r}")

    def success_extra(self, ctx: Context) -> bool:
        """A family-specific success condition evaluated with the goal predicate (default: always true)."""
        return True


_REGISTRY: dict[str, type[FamilySkeleton]] = {}


def register(cls: type[FamilySkeleton]) -> type[FamilySkeleton]:
    """Class decorator: make ``cls`` the skeleton of ``cls.family``."""
    if not cls.family:
        raise ValueError(f"{cls.__name__} must set the class attribute 'family'")
    _REGISTRY[cls.family] = cls
    return cls


def available_families() -> tuple[str, ...]:
    """Families with a skeleton module under ``skeletons/`` (or registered in this process)."""
    found = {p.stem for p in (project_root() / "skeletons").glob("*.py") if not p.stem.startswith("_")}
    return tuple(sorted(found | set(_REGISTRY)))


def skeleton_for(family: str) -> FamilySkeleton:
    """A fresh skeleton instance for ``family``, importing ``skeletons.<family>`` if needed.

    Raises:
        UnknownFamilyError: no such skeleton; the message lists the families that exist.
    """
    return skeleton_class(family)()


def load_family_recipe(family_or_path: str | Path) -> Recipe:
    """Load a recipe (by family name or path) and check it against its skeleton's ``recipe_keys``: the
    whole recipe is checked before anything runs, and ``params``/``variation`` hold typed values.

    Raises:
        RecipeError: the recipe is malformed, or lacks/misspells/mistypes a key the skeleton reads.
        UnknownFamilyError: no recipe or no skeleton for the family.
    """
    recipe = load_recipe(family_or_path)
    try:
        cls = skeleton_class(recipe.family)
    except UnknownFamilyError as err:
        raise RecipeError(f"{recipe.path}: family = {recipe.family!r}: {err}") from None
    return check_recipe_keys(recipe, cls.recipe_keys)


def skeleton_class(family: str) -> type[FamilySkeleton]:
    """The skeleton class of ``family``, importing ``skeletons.<family>`` if needed."""
    if family not in _REGISTRY and family.isidentifier():
        try:
            importlib.import_module(f"skeletons.{family}")
        except ModuleNotFoundError as err:
            if err.name not in (f"skeletons.{family}", "skeletons"):
                raise
    if family not in _REGISTRY:
        known = ", ".join(available_families()) or "none"
        raise UnknownFamilyError(f"no skeleton for family {family!r} (families with a skeleton: {known})")
    return _REGISTRY[family]
