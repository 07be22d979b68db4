"""Which objects the annotator offers: asset-library models filtered by family and/or category, sorted.

A family's objects are the models its recipe's ``[layout]`` names: every list of strings there whose entries
are model names or glob patterns over them (``jar_models = ["jar/hinged_*"]``, ``foods = ["food/*"]``).
Particle models (liquid, dust) cannot be grasped and are never offered. Keys the browser sends are checked
against this list (:meth:`Catalog.index`), so the client can only ever name an object the library has.

Example::

    cat = Catalog.build(family="jar", category="jar")
    cat.keys[:2]        # ('jar/hinged_00', 'jar/hinged_01')
"""

from __future__ import annotations

import fnmatch
from collections.abc import Iterable
from dataclasses import dataclass

from mgdata.errors import AssetError
from mgdata.sim.assets import categories, get_model, model_names
from mgdata.tasks.recipe import Recipe, load_recipe


def family_models(recipe: Recipe) -> list[str]:
    """The models a family's recipe layout names (sorted)."""
    names = model_names()
    patterns = recipe.layout.model_patterns()
    return sorted({n for n in names for p in patterns if fnmatch.fnmatchcase(n, p)})


@dataclass(frozen=True)
class Catalog:
    """The sorted object keys offered, and the family whose recipe supplies placements (or None)."""

    keys: tuple[str, ...]
    family: str | None = None

    @classmethod
    def build(cls, family: str | None = None, category: str | None = None) -> Catalog:
        """Objects of ``family`` (its recipe's layout) and/or ``category``; all graspable models if neither.

        Raises:
            UnknownFamilyError: no recipe for ``family``.
            AssetError: unknown category, or the filters leave nothing.
        """
        names: Iterable[str] = model_names()
        if family is not None:
            names = family_models(load_recipe(family))
        if category is not None:
            if category not in categories():
                raise AssetError(f"unknown object category {category!r}; known: {', '.join(categories())}")
            names = [n for n in names if n.split("/", 1)[0] == category]
        keys = tuple(sorted(n for n in names if get_model(n).particles is None))
        if not keys:
            what = " and ".join(x for x in (f"family {family!r}" if family else "",
                                             f"category {category!r}" if category else "") if x)
            raise AssetError(f"no graspable object models for {what or 'the asset library'}")
        return cls(keys, family)

    def index(self, key: str) -> int:
        """Position of ``key`` in the list.

        Raises:
            AssetError: ``key`` is not offered (the message names close keys).
        """
        try:
            return self.keys.index(key)
        except ValueError:
            close = [k for k in self.keys if key.split("/")[-1] in k][:5]
            hint = f"; did you mean {', '.join(close)}?" if close else ""
            raise AssetError(f"object {key!r} is not in this annotation session's list ({len(self.keys)} "
                             f"objects){hint}") from None

    def search(self, text: str) -> tuple[str, ...]:
        """Keys containing ``text`` (case-insensitive); all keys for empty text."""
        t = text.strip().lower()
        return tuple(k for k in self.keys if t in k.lower()) if t else self.keys
