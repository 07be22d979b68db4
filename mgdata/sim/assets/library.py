"""The asset library: stable model names ``category/stem_NN`` mapped to seeded procedural builders.

A model's parameters are drawn from a generator seeded by the SHA-256 of its own name, so ``jar/hinged_03``
is the same object on every machine and does not change when variants are added. ``VARIANTS`` says how many
numbered variants each kind exposes; raising a count grows the library without touching existing models.
A user's own objects (``<root>/objects/<category>/<model>.toml``, :mod:`mgdata.sim.assets.entries`) join the
library when it is first asked, read once per process (:func:`forget_user_objects` reads them again).

Example::

    from mgdata.sim.assets import get_model, model_names
    model_names("jar")[:2]          # ['jar/hinged_00', 'jar/hinged_01']
    jar = get_model("jar/hinged_03")
    jar.geometry["outer_radius"]
"""

from __future__ import annotations

import difflib
from collections.abc import Callable
from dataclasses import dataclass
from functools import cache
from pathlib import Path

import numpy as np

from mgdata.errors import AssetError
from mgdata.paths import objects_dir
from mgdata.sim.assets import boxes, jar, vessels
from mgdata.sim.assets.bottle import build_bottle
from mgdata.sim.assets.cabinet import build_cabinet
from mgdata.sim.assets.container import build_container, build_lid
from mgdata.sim.assets.entries import ObjectEntry, find_entries
from mgdata.sim.assets.food import food_builder
from mgdata.sim.assets.granular import build_dust, build_liquid
from mgdata.sim.assets.holder import build_towel_holder
from mgdata.sim.assets.lidded import build_bottle as build_capped_bottle
from mgdata.sim.assets.lidded import build_canister, build_canister_lid, build_cap
from mgdata.sim.assets.model import ObjectModel, model_seed

Builder = Callable[[str, int, np.random.Generator], ObjectModel]


@dataclass(frozen=True)
class Kind:
    """One procedural kind: models ``<category>/<stem>_00`` … ``_<count-1>`` built by ``build``."""

    category: str
    stem: str
    count: int
    build: Builder


def _kinds() -> tuple[Kind, ...]:
    kinds = [
        Kind("jar", "hinged", 16, jar.build_hinged_jar),
        Kind("cup", "tumbler", 16, vessels.build_cup),
        Kind("mug", "handled", 16, vessels.build_mug),
        Kind("teacup", "flared", 12, vessels.build_teacup),
        Kind("bowl", "round", 16, vessels.build_bowl),
        Kind("plate", "flat", 12, vessels.build_plate),
        Kind("box", "carton", 16, boxes.build_box),
        Kind("bottle", "round", 16, build_bottle),
        Kind("container", "tub", 12, build_container),
        Kind("lid", "tub", 12, build_lid),
        Kind("container", "lunchbox", 8, build_container),
        Kind("lid", "lunchbox", 8, build_lid),
        Kind("container", "canister", 8, build_canister),
        Kind("lid", "canister", 8, build_canister_lid),
        Kind("container", "bottle", 8, build_capped_bottle),
        Kind("lid", "cap", 8, build_cap),
        Kind("tray", "flat", 8, boxes.build_tray),
        Kind("sponge", "block", 8, boxes.build_sponge),
        Kind("board", "chopping", 8, boxes.build_board),
        Kind("cabinet", "drawer", 8, build_cabinet),
        Kind("holder", "towel", 8, build_towel_holder),
    ]
    kinds += [Kind("food", k, 8, food_builder(k)) for k in ("cherry", "cookie", "candy", "olive", "nugget")]
    kinds += [Kind("liquid", "water", 8, build_liquid), Kind("dust", "layer", 8, build_dust)]
    return tuple(kinds)


KINDS: tuple[Kind, ...] = _kinds()


def _index() -> dict[str, Kind]:
    return {f"{k.category}/{k.stem}_{i:02d}": k for k in KINDS for i in range(k.count)}


_BY_NAME: dict[str, Kind] = _index()
_REGISTERED: dict[str, ObjectModel] = {}


def register(model: ObjectModel) -> None:
    """Add a model built elsewhere (e.g. ``imported.mesh_model``) so scenes can name it.

    Raises:
        AssetError: the name is taken by a procedural model, a user object or another registered one.
    """
    if model.name in _BY_NAME or model.name in _REGISTERED or model.name in user_objects():
        raise AssetError(f"object model name {model.name!r} is already taken")
    _REGISTERED[model.name] = model


def user_objects() -> dict[str, ObjectEntry]:
    """The entries of the root's ``objects/`` folder (:func:`mgdata.paths.objects_dir`), by name.

    Raises:
        AssetError: a malformed entry (naming its file and key), or one named like a procedural model.
    """
    directory = objects_dir()
    return _entries(directory) if directory is not None else {}


@cache
def _entries(directory: Path) -> dict[str, ObjectEntry]:
    found = find_entries(directory)
    for name, entry in found.items():
        if name in _BY_NAME:
            raise AssetError(f"{entry.path}: {name!r} is a procedural model's name; rename the entry")
    return found


def forget_user_objects() -> None:
    """Read the ``objects/`` folder again on the next question (after an import in this process)."""
    _entries.cache_clear()
    get_model.cache_clear()


def categories() -> list[str]:
    """All categories, sorted."""
    return sorted({k.category for k in KINDS} | {m.category for m in _REGISTERED.values()}
                  | {n.split("/", 1)[0] for n in user_objects()})


def model_names(category: str | None = None) -> list[str]:
    """All model names (sorted), or those of one ``category``.

    Raises:
        AssetError: ``category`` is not a known category.
    """
    if category is not None and category not in categories():
        raise AssetError(f"unknown object category {category!r}; known: {', '.join(categories())}")
    names = (*_BY_NAME, *_REGISTERED, *user_objects())
    return sorted(n for n in names if category is None or n.split("/", 1)[0] == category)


@cache
def get_model(name: str) -> ObjectModel:
    """The model called ``name`` (built once per process, then cached).

    Raises:
        AssetError: no such model (the message lists close names), or a user object that cannot be built.
    """
    if name in _REGISTERED:
        return _REGISTERED[name]
    kind = _BY_NAME.get(name)
    if kind is None:
        users = user_objects()
        if name in users:
            return users[name].model()
        known = [*_BY_NAME, *_REGISTERED, *users]
        close = difflib.get_close_matches(name, known, n=5, cutoff=0.5)
        hint = f"; did you mean {', '.join(close)}?" if close else f"; categories: {', '.join(categories())}"
        raise AssetError(f"unknown object model {name!r} (expected 'category/model'){hint}")
    seed = model_seed(name)
    return kind.build(name, seed, np.random.default_rng(seed))
