"""Where the live checks stand the object: the sim check's placement plus a few representative placements
from the family's recipe.

* **sim check**: where ``mgdata grasps validate`` stands it (``recipes/grasps.toml`` ``[check]``), turned so
  the grasp's approach points away from the robot; it depends on the grasp, so it is computed per pose.
* **recipe placements**: the positions and yaws at which the family's base tasks put a model of the same
  category, standing on the table (the z the recipe gives, e.g. food inside a jar, is dropped: the object
  stands alone in the check). ``placements`` of them are picked by farthest-point sampling over
  (x, y, yaw), starting from the base task nearest the mean, so they span the recipe's range.
* **default** (no family, or its recipe never places this category): the object upright at
  (``default_x``, y) for each ``default_y`` (``recipes/annotate.toml`` ``[live]``), yaw 0.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from mgdata.annotator.config import LiveConfig
from mgdata.grasps.check import GraspCheckConfig, check_placement
from mgdata.grasps.db import Grasp
from mgdata.sim.world import TABLE_TOP_Z
from mgdata.tasks.base import draw_task
from mgdata.tasks.recipe import load_recipe


@dataclass(frozen=True)
class Placement:
    """The object's frame in the world: ``pos`` (m) on the table and ``yaw`` (rad) about +Z."""

    label: str
    pos: tuple[float, float, float]
    yaw: float

    def matrix(self) -> np.ndarray:
        c, s = math.cos(self.yaw), math.sin(self.yaw)
        T = np.eye(4)
        T[:3, :3] = [[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]]
        T[:3, 3] = self.pos
        return T

    def describe(self) -> str:
        return f"{self.label} (x {self.pos[0]:.2f}, y {self.pos[1]:+.2f}, yaw {math.degrees(self.yaw):+.0f}°)"


def sim_check_placement(grasp: Grasp, cfg: GraspCheckConfig, model: str) -> Placement:
    """The placement ``mgdata grasps validate`` uses for this grasp of object model ``model``."""
    pos, yaw = check_placement(grasp, cfg, model)
    return Placement("sim check", pos, yaw)


def default_placements(cfg: LiveConfig) -> tuple[Placement, ...]:
    return tuple(Placement(f"default {i + 1}", (cfg.default_x, y, TABLE_TOP_Z), 0.0)
                 for i, y in enumerate(cfg.default_y))


def recipe_placements(family: str | None, category: str, cfg: LiveConfig) -> tuple[Placement, ...]:
    """Representative placements of ``category`` in ``family``'s base tasks, or the default ones."""
    if family is None or cfg.placements <= 0:
        return default_placements(cfg)
    recipe = load_recipe(family)
    tasks = (draw_task(recipe, k) for k in range(recipe.tasks.count))
    found = [(p.pos[0], p.pos[1], p.yaw) for task in tasks for p in task.objects
             if p.model.split("/", 1)[0] == category]
    if not found:
        return default_placements(cfg)
    pts = np.array(found)
    scale = np.array([1.0, 1.0, 0.1])  # 0.1 m of position weighs like 1 rad of yaw
    chosen = [int(np.argmin(np.linalg.norm((pts - pts.mean(axis=0)) * scale, axis=1)))]
    while len(chosen) < min(cfg.placements, len(pts)):
        dist = np.min(np.linalg.norm((pts[:, None] - pts[chosen][None]) * scale, axis=2), axis=1)
        chosen.append(int(np.argmax(dist)))
    return tuple(Placement(f"{family} {i + 1}", (float(pts[k, 0]), float(pts[k, 1]), TABLE_TOP_Z),
                           float(pts[k, 2])) for i, k in enumerate(chosen))
