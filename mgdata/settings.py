"""Settings files: a TOML file of tables read into a dataclass of dataclasses, strictly.

``recipes/sim.toml``, ``recipes/motion.toml`` and ``recipes/grasps.toml`` share this loader. The settings
class has one field per table, each a dataclass whose fields (annotated ``float``, ``int``, ``bool``,
``str``, ``tuple[str, ...]`` (a list of strings) or a vector type from :data:`VECTOR_TYPES`) all have
defaults. A missing table or key keeps its default; an unknown table or key, a mistyped value, or a value a
dataclass's ``__post_init__`` rejects (a :class:`~mgdata.errors.RecipeError` without the file name) is one
RecipeError naming the file and key.

Example::

    config = load_settings(MotionConfig, recipes_dir() / "motion.toml", explicit=False)
"""

from __future__ import annotations

import dataclasses
import tomllib
from collections.abc import Mapping
from pathlib import Path
from typing import Any, TypeVar

from mgdata.errors import RecipeError

T = TypeVar("T")

VECTOR_TYPES: dict[str, int] = {"tuple[float, float]": 2, "tuple[float, float, float]": 3, "Vec3": 3}
"""Annotations read as a list of numbers of this length (stored as a tuple of floats)."""

_SCALARS = {"float": ((int, float), "a number"), "int": ((int,), "an integer"),
            "bool": ((bool,), "true or false"), "str": ((str,), "a string")}


def read_toml(path: Path) -> dict[str, Any]:
    """Parse a TOML file; invalid TOML is a RecipeError naming the file."""
    try:
        return tomllib.loads(Path(path).read_text(encoding="utf-8"))
    except tomllib.TOMLDecodeError as err:
        raise RecipeError(f"{path}: not valid TOML: {err}") from None


def load_settings(cls: type[T], path: Path, *, explicit: bool) -> T:
    """Load ``path`` into ``cls``; a missing file means all defaults, unless the user named it."""
    if not Path(path).is_file():
        if explicit:
            raise RecipeError(f"settings file {path} does not exist")
        return cls()
    return settings_from_dict(cls, read_toml(path), str(path))


def settings_from_dict(cls: type[T], raw: Mapping[str, Any], source: str) -> T:
    """Build ``cls`` from parsed TOML (see the module docstring); ``source`` names the file in errors."""
    tables = {f.name: f.default_factory for f in dataclasses.fields(cls)}  # type: ignore[arg-type]
    kwargs: dict[str, Any] = {}
    for name, table in raw.items():
        if name not in tables:
            raise RecipeError(f"{source}: unknown table [{name}]; expected one of {sorted(tables)}")
        if not isinstance(table, dict):
            raise RecipeError(f"{source}: [{name}] must be a table of keys")
        table_cls = tables[name]
        types = {f.name: str(f.type) for f in dataclasses.fields(table_cls)}  # type: ignore[arg-type]
        values = {}
        for key, value in table.items():
            if key not in types:
                raise RecipeError(f"{source}: unknown key [{name}] {key}; expected one of {sorted(types)}")
            values[key] = coerce_value(value, types[key], f"{source}: [{name}] {key}")
        kwargs[name] = _construct(table_cls, values, source)
    return _construct(cls, kwargs, source)


def _construct(cls: Any, values: dict[str, Any], source: str) -> Any:
    try:
        return cls(**values)
    except RecipeError as err:
        raise RecipeError(f"{source}: {err}") from None


def coerce_value(value: Any, type_name: str, where: str) -> Any:
    """``value`` (parsed TOML) as a field annotated ``type_name``; a mismatch is a RecipeError at
    ``where``."""
    if type_name in VECTOR_TYPES:
        n = VECTOR_TYPES[type_name]
        if not (isinstance(value, list) and len(value) == n
                and all(isinstance(v, int | float) and not isinstance(v, bool) for v in value)):
            raise RecipeError(f"{where} = {value!r}: expected a list of {n} numbers")
        return tuple(float(v) for v in value)
    if type_name == "tuple[str, ...]":
        if not (isinstance(value, list) and all(isinstance(v, str) for v in value)):
            raise RecipeError(f"{where} = {value!r}: expected a list of strings")
        return tuple(value)
    kinds, expected = _SCALARS[type_name]
    if isinstance(value, bool) != (type_name == "bool") or not isinstance(value, kinds):
        raise RecipeError(f"{where} = {value!r}: expected {expected}")
    return float(value) if type_name == "float" else value
