"""The annotator's view of the grasp DB: add and delete annotated grasps, one atomic file write per change.

Only files the store derives itself are written: ``<dir>/<category>.json`` for a key the caller has checked
against the catalog (no path ever comes from the browser). Each write goes through
:func:`mgdata.grasps.db.write_file` (``mgdata.atomic``), so a crash leaves the old file or the new one.
The file is re-read before each change, so a concurrent ``mgdata grasps validate`` is not overwritten with
stale data (the last writer of a category file still wins for that file).

Example::

    store = GraspStore(grasps_dir())
    g = store.add("jar/hinged_03", pos, quat, mode="guided")
    store.delete_last("jar/hinged_03")
"""

from __future__ import annotations

import threading
from pathlib import Path

from mgdata.atomic import remove_stale_temps
from mgdata.grasps.db import Grasp, GraspDB, approach_hint, write_file

MODES: tuple[str, ...] = ("guided", "free")


class GraspStore:
    """Annotated grasps of the grasp DB folder ``directory``."""

    def __init__(self, directory: Path) -> None:
        self.directory = Path(directory)
        self._lock = threading.Lock()
        for path in self.directory.glob("*.json"):  # temporaries of a write that was killed
            remove_stale_temps(path)
        self._db = GraspDB.load_dir(self.directory)

    def _path(self, key: str) -> Path:
        return self.directory / f"{key.split('/', 1)[0]}.json"

    def _reload(self, key: str) -> None:
        path = self._path(key)
        if path.is_file():
            fresh = GraspDB.load([path])
            objects = {k: v for k, v in self._db.objects.items() if k.split("/", 1)[0] != path.stem}
            objects.update(fresh.objects)
            self._db = GraspDB(objects)

    @property
    def db(self) -> GraspDB:
        return self._db

    def grasps(self, key: str) -> tuple[Grasp, ...]:
        return tuple(self._db.objects.get(key, ()))

    def annotated(self, key: str) -> tuple[Grasp, ...]:
        return tuple(g for g in self.grasps(key) if g.source == "annotated")

    def _write(self, key: str, grasps: list[Grasp]) -> None:
        self._db = self._db.with_object(key, grasps)
        category = key.split("/", 1)[0]
        write_file(self._path(key), {k: v for k, v in self._db.objects.items()
                                     if k.split("/", 1)[0] == category})

    def add(self, key: str, pos: tuple[float, float, float], quat: tuple[float, float, float, float],
            mode: str, status: str = "unvalidated", detail: str = "") -> Grasp:
        """Append an annotated grasp (id ``<mode>_NN``, the next free number) and write the file."""
        if mode not in MODES:
            raise ValueError(f"mode must be one of {MODES}, got {mode!r}")
        with self._lock:
            self._reload(key)
            existing = list(self.grasps(key))
            ids = {g.id for g in existing}
            n = len(self.annotated(key))
            while f"{mode}_{n:02d}" in ids:
                n += 1
            grasp = Grasp(f"{mode}_{n:02d}", pos, quat, approach_hint(quat), "annotated", status, detail)
            self._write(key, [*existing, grasp])
            return grasp

    def delete_last(self, key: str) -> Grasp | None:
        """Remove the last annotated grasp of ``key`` (generated ones are never touched); None if none."""
        with self._lock:
            self._reload(key)
            existing = list(self.grasps(key))
            for i in range(len(existing) - 1, -1, -1):
                if existing[i].source == "annotated":
                    gone = existing.pop(i)
                    self._write(key, existing)
                    return gone
            return None

    def resume_index(self, keys: tuple[str, ...]) -> int:
        """Where the last session stopped: the last object in ``keys`` with annotated grasps (0 if none)."""
        done = [i for i, k in enumerate(keys) if self.annotated(k)]
        return done[-1] if done else 0
