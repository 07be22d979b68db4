"""Candidate grasps from an object model's geometry: side grasps around round objects, top grasps on narrow
ones. Candidates are ``source="generated"``, ``status="unvalidated"`` until ``mgdata grasps validate`` runs.

* **side** (objects with ``outer_radius`` in their geometry, e.g. jars, cups, bottles): the gripper points at
  the object's axis horizontally from ``angles`` directions around it, fingers closing horizontally, at the
  model's ``grasp_height`` (or mid-height) raised to ``min_side_height`` (the wrist clears the table) but
  kept ``side_top_clearance`` below the top; the TCP sits on the axis unless the palm would touch the object,
  in which case it backs off. Two rolls per direction (fingers swapped), which reach differently.
* **top** (objects whose narrower horizontal extent fits between the fingers, without an articulation): the
  gripper points straight down at the bounding box's centre line, ``top_depth`` below the top, closing
  across the narrow side; two rolls.

Example::

    grasps = candidates(get_model("jar/hinged_03"), CandidateConfig())
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import mujoco
import numpy as np

from mgdata.grasps.db import Grasp, approach_hint
from mgdata.sim.assets.model import ObjectModel

MAX_OPENING = 0.08
"""The Panda hand's finger gap when open (m)."""


@dataclass(frozen=True)
class CandidateConfig:
    """Tunables of the generator (``recipes/grasps.toml`` ``[candidates]``)."""

    angles: int = 12  # side-grasp directions around the axis
    palm_depth: float = 0.0325  # m from the TCP back to the palm, along the approach
    palm_clearance: float = 0.008  # m kept between the palm and the object
    finger_clearance: float = 0.012  # m of opening to spare around the grasped width
    top_depth: float = 0.02  # m below the object's top for top grasps (fingertips overlap the object)
    min_side_height: float = 0.055  # m above the object's base: lower side grasps put the wrist on the table
    side_top_clearance: float = 0.015  # m kept between a side grasp and the object's top (rim, lid)


def _quat(x: np.ndarray, y: np.ndarray, z: np.ndarray) -> tuple[float, float, float, float]:
    """Unit quaternion (w, x, y, z) of the rotation whose columns are ``x``, ``y``, ``z``."""
    mat = np.stack([x, y, z], axis=1)
    quat = np.empty(4)
    mujoco.mju_mat2Quat(quat, mat.ravel())
    if quat[0] < 0:
        quat = -quat
    return tuple(float(v) for v in quat)  # type: ignore[return-value]


def side_grasps(model: ObjectModel, cfg: CandidateConfig) -> list[Grasp]:
    """Horizontal grasps around a round object's axis (empty if it is too wide for the hand)."""
    geo = model.geometry
    if "outer_radius" not in geo:
        return []
    radius = float(geo["outer_radius"])
    if 2.0 * radius + cfg.finger_clearance > MAX_OPENING:
        return []
    top = float(geo.get("height", model.size[2])) - cfg.side_top_clearance
    height = min(max(float(geo.get("grasp_height", model.size[2] / 2.0)), cfg.min_side_height), top)
    back = max(0.0, radius + cfg.palm_clearance - cfg.palm_depth)
    out = []
    for k in range(cfg.angles):
        phi = 2.0 * math.pi * k / cfg.angles
        side = np.array([math.cos(phi), math.sin(phi), 0.0])  # where the gripper sits
        approach = -side
        for roll in (0, 1):
            y = np.array([-math.sin(phi), math.cos(phi), 0.0]) * (1.0 if roll == 0 else -1.0)
            x = np.cross(y, approach)
            pos = side * back + np.array([0.0, 0.0, height])
            quat = _quat(x, y, approach)
            out.append(Grasp(f"side_{round(math.degrees(phi)):03d}_r{roll}", tuple(pos.tolist()), quat,
                             approach_hint(quat), "generated"))
    return out


def top_grasps(model: ObjectModel, cfg: CandidateConfig) -> list[Grasp]:
    """Straight-down grasps across the narrow horizontal side (empty for articulated or wide objects)."""
    if model.articulation is not None:
        return []
    sx, sy, sz = model.size
    narrow = min(sx, sy)
    if narrow + cfg.finger_clearance > MAX_OPENING:
        return []
    close_along = np.array([1.0, 0.0, 0.0]) if sx <= sy else np.array([0.0, 1.0, 0.0])
    approach = np.array([0.0, 0.0, -1.0])
    pos = (0.0, 0.0, max(sz - cfg.top_depth, sz / 2.0))
    out = []
    for roll in (0, 1):
        y = close_along * (1.0 if roll == 0 else -1.0)
        x = np.cross(y, approach)
        quat = _quat(x, y, approach)
        out.append(Grasp(f"top_r{roll}", pos, quat, approach_hint(quat), "generated"))
    return out


def candidates(model: ObjectModel, cfg: CandidateConfig) -> list[Grasp]:
    """All candidate grasps of a model, side grasps first."""
    return side_grasps(model, cfg) + top_grasps(model, cfg)
