"""The inputs besides the code that shape an attempt's bytes, as one digest (runs, shards and scenarios carry
it so that data made from other inputs is never resumed, merged or reused).

Example::

    inputs_digest(load_family_recipe("jar"), grasps_dir())   # 16 hex digits
"""

from __future__ import annotations

import hashlib
from pathlib import Path

from mgdata.paths import objects_dir, recipes_dir
from mgdata.sim.config import SIM_TOML
from mgdata.tasks.recipe import Recipe


def inputs_digest(recipe: Recipe, grasps: Path) -> str:
    """Hash of everything besides the code that shapes the data: the family recipe and its spec
    (``recipe.digest``), ``recipes/sim.toml``, ``recipes/motion.toml``, the grasp database files and the
    user's imported objects (``objects/*/*``: entries, meshes, textures; none: the digest is as before)."""
    h = hashlib.sha256(recipe.digest.encode())
    for path in [recipes_dir() / SIM_TOML, recipes_dir() / "motion.toml", *sorted(grasps.glob("*.json"))]:
        h.update(b"\0" + path.name.encode() + b"\0" + path.read_bytes())
    objects = objects_dir()
    if objects is not None and objects.is_dir():
        for path in sorted(p for p in objects.glob("*/*") if p.is_file() and not p.name.startswith(".")):
            h.update(b"\0" + path.relative_to(objects).as_posix().encode() + b"\0" + path.read_bytes())
    return h.hexdigest()[:16]
