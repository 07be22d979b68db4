"""Where a Gymnasium environment finds its locked scenarios: a store the user names, or a cache built on
first use.

A named store (``mgdata scenarios build --out DIR``) is read as it is: a scenario it lacks is an error, never
built into it. Without one, scenarios are built on first use into ``<MGDATA_CACHE>/scenarios/<digest>``
(``~/.cache/mgdata`` by default), the digest being that of the recipe, spec, sim and motion settings and
grasps the scenarios are built from (:func:`mgdata.engine.inputs.inputs_digest`), so a changed or a
camera-free recipe gets its own folder. Builds are deterministic and serialised by a blocking ``flock``
(the processes of an ``AsyncVectorEnv`` build each scenario once).

Example::

    cache = ScenarioCache(load_family_recipe("jar"), None)
    restored = cache.restore(0, "base")        # built on first use, then restored bit for bit
"""

from __future__ import annotations

import fcntl
from pathlib import Path

from mgdata.engine.inputs import inputs_digest
from mgdata.errors import DatasetError
from mgdata.evaluate.restore import RestoredScenario, restore_scenario
from mgdata.paths import cache_dir, grasps_dir
from mgdata.scenarios.store import META, build_scenario, scenario_dir
from mgdata.tasks.recipe import Recipe


class ScenarioCache:
    """The scenarios of one family recipe (see the module docstring).

    Attributes:
        recipe: the family recipe the scenarios are (or were) built from.
        root: the store's folder; ``named``: whether the user named it (read-only).
    """

    def __init__(self, recipe: Recipe, store: str | Path | None) -> None:
        self.recipe = recipe
        self.named = store is not None
        self.root = Path(store) if store is not None else (
            cache_dir() / "scenarios" / inputs_digest(recipe, grasps_dir()))
        if self.named and not self.root.is_dir():
            raise DatasetError(f"scenarios={self.root}: no such folder (build it with `mgdata scenarios "
                               f"build --out {self.root}`, or leave scenarios out to build on first use)")
        self._checked: set[tuple[int, str]] = set()

    def path(self, task_id: int, condition: str) -> str:
        """The scenario's path in the set, e.g. ``jar/task_0000/base``."""
        return f"{self.recipe.family}/task_{task_id:04d}/{condition}"

    def restore(self, task_id: int, condition: str) -> RestoredScenario:
        """The scenario, restored bit for bit (built first, in the cache, if missing or stale).

        Raises:
            DatasetError: a named store lacks the scenario, or it cannot be restored.
        """
        folder = scenario_dir(self.root, self.recipe.family, task_id, condition)
        if self.named:
            if not (folder / META).is_file():
                raise DatasetError(f"{self.root}: no scenario {self.path(task_id, condition)} (build it with "
                                   f"`mgdata scenarios build --out {self.root} --family {self.recipe.family} "
                                   f"--tasks {task_id} --condition {condition}`)")
        elif (task_id, condition) not in self._checked:
            self.root.mkdir(parents=True, exist_ok=True)
            with open(self.root / ".build.lock", "a") as lock:
                fcntl.flock(lock, fcntl.LOCK_EX)  # released when the file closes
                build_scenario(self.recipe, task_id, condition, self.root)  # keeps a complete one
            self._checked.add((task_id, condition))
        return restore_scenario(folder, self.recipe)
