"""The edge pick's pinch lands where the arm comes to rest (mgdata.grasps.rest), measured from raw MuJoCo.

The servos do not compensate gravity: aimed at the pinch's plain pose, the arm rested ~5 mm low, so the
upper finger met the board before the lower one and drove it into the table's edge (stack, task 9: 5.2 mm
deep). The family lives only in ``tests/families/toy_board`` (a board alone by the table's back edge); its
skeleton is loaded from there, and the attempt runs in this process with a raw-contact probe as controller.
"""

from __future__ import annotations

import importlib.util
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from mgdata.engine.init_gate import base_task
from mgdata.grasps.db import GraspDB
from mgdata.paths import grasps_dir
from mgdata.sim.controller import JointController
from mgdata.sim.scene import Scene
from mgdata.skeleton.skeleton import load_family_recipe
from tests.helpers.probed import probed_attempt

TOY = Path(__file__).resolve().parents[1] / "families" / "toy_board"


def _toy_skeleton() -> type:
    spec = importlib.util.spec_from_file_location("toy_board_skeleton", TOY / "skeletons" / "toy_board.py")
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)  # registers the toy_board skeleton
    return module.ToyBoardSkeleton


class _Probe(JointController):
    """After every control step: the deepest board–table overlap (m, raw ``-data.contact.dist``) and whether
    the hand is closed (its finger bodies under 5 cm apart; open they are 8 cm)."""

    def __init__(self, scene: Scene) -> None:
        super().__init__(scene)
        m = scene.model
        self.pair = {m.body("board").id, m.body("table").id}
        self.fingers = [m.body(n).id for n in ("left_finger", "right_finger")]
        self.depth: list[float] = []
        self.closed: list[bool] = []

    def step(self) -> None:
        super().step()
        m, d = self.scene.model, self.scene.data
        self.depth.append(max((-float(c.dist) for c in d.contact[:d.ncon]
                               if {int(m.geom_bodyid[c.geom1]), int(m.geom_bodyid[c.geom2])} == self.pair),
                              default=0.0))
        self.closed.append(float(np.linalg.norm(d.xpos[self.fingers[0]] - d.xpos[self.fingers[1]])) < 0.05)


@pytest.mark.parametrize("task_id", [0, 1])
def test_the_pinch_closes_on_the_board_without_pressing_it_into_the_table(task_id: int) -> None:
    skeleton = _toy_skeleton()
    recipe = load_family_recipe(TOY / "recipes" / "toy_board.toml")
    lax = replace(recipe, tasks=replace(recipe.tasks, max_penetration=0.01))  # the raw probe judges here
    result, _, _, probe = probed_attempt(base_task(recipe, task_id), lax, GraspDB.load_dir(grasps_dir()),
                                         skeleton(), _Probe)
    assert result.kept and result.grasp_id.startswith("edge_"), (result.stage, result.reason)
    # closed on the board: 0.3-0.5 mm; aimed at the plain pose 3.4-4.3 mm (the open hand's push presses the
    # board's edge 0.7 mm into the table's, with the hand open: not counted here)
    pinched = [depth for depth, closed in zip(probe.depth, probe.closed, strict=True) if closed]
    assert pinched and max(pinched) < 0.001, f"{max(pinched) * 1000:.2f} mm"
