"""What a family will generate: its base tasks through the initial-state gate, listed and drawn.

``mgdata tasks F`` lists each base task (the draw the gate accepted, its objects, goal, prompt and the gate's
facts); ``--render`` adds a contact sheet of their initial scenes from two cameras, one row per task, so a
user can look at the scenes before spending CPU hours on them.

Example::

    for row in gate_report(recipe, range(4)):
        print(row.task_id, row.line())
    write_sheet(recipe, [row.task for row in rows if row.task], Path("clutter_tasks.png"))
"""

from __future__ import annotations

from collections.abc import Iterable, Iterator
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from mgdata.atomic import write_bytes_atomic
from mgdata.engine.init_gate import base_task
from mgdata.errors import OutputError, RecipeError
from mgdata.sim.taskspec import TaskSpec
from mgdata.tasks.recipe import Recipe

SHEET_CAMERAS = ("left", "right")
SHEET_SIZE = 192


@dataclass(frozen=True)
class TaskRow:
    """One base task's gate outcome: the accepted task, or the reason none was accepted."""

    task_id: int
    task: TaskSpec | None
    error: str | None = None

    def line(self) -> str:
        """A few lines of text describing the task (or its failure)."""
        if self.task is None:
            return f"task {self.task_id}: FAILS THE GATE: {self.error}"
        t = self.task
        objs = ", ".join(f"{o.name}={o.model}" for o in t.objects)
        goal = (f"goal ({t.goal.pos[0]:.3f}, {t.goal.pos[1]:+.3f}, {t.goal.pos[2]:.3f}) r {t.goal.radius:.3f}"
                if t.goal else "no goal sphere")
        grasps = t.gate.get("grasps")
        facts = f"{len(grasps)} reachable grasps" if grasps is not None else "gate passed"
        return (f"task {t.task_id} (draw {t.draw}): {facts}; {goal}\n  objects: {objs}\n"
                f"  prompt: {t.prompt}")


def gate_report(recipe: Recipe, task_ids: Iterable[int], grasps: Path | None = None) -> Iterator[TaskRow]:
    """Each task through the gate, in order (a failing task is a row, not an exception)."""
    for k in task_ids:
        try:
            yield TaskRow(k, base_task(recipe, k, grasps))
        except RecipeError as err:
            yield TaskRow(k, None, str(err))


def write_sheet(tasks: list[TaskSpec], path: Path, *, cameras: tuple[str, ...] = SHEET_CAMERAS,
                size: int = SHEET_SIZE) -> Path:
    """A PNG with one row per task: its settled initial scene from ``cameras``, captioned."""
    import cv2

    from mgdata.sim.renderer import CameraRig, contact_sheet
    from mgdata.sim.scene import build_scene

    if not tasks:
        raise RecipeError("no task passed the gate: nothing to render")
    rows = []
    for task in tasks:
        scene = build_scene(task)
        with CameraRig(scene, cameras, size) as rig:
            images = rig.render()
        row = contact_sheet({f"task {task.task_id} {c}": images[c] for c in cameras})
        rows.append(row)
    columns_wanted = 1 if len(rows) <= 6 else 2 if len(rows) <= 12 else 3
    per_column = int(np.ceil(len(rows) / columns_wanted))
    blank = np.full_like(rows[0], 255)
    columns = [rows[i:i + per_column] for i in range(0, len(rows), per_column)]
    columns = [np.concatenate(c + [blank] * (per_column - len(c)), axis=0) for c in columns]
    sheet = np.concatenate(columns, axis=1)
    ok, png = cv2.imencode(".png", cv2.cvtColor(sheet, cv2.COLOR_RGB2BGR))
    if not ok:
        raise OutputError(f"{path}: could not encode the contact sheet")
    write_bytes_atomic(path, png.tobytes())
    return path
