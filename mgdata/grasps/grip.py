"""The grip contact model: how the Panda's finger geoms hold what they squeeze.

MuJoCo's default contacts (``condim=3``) resist sliding but not spinning about the contact normal. A side
grasp squeezes an object between two contacts whose normals lie on one line, so nothing resists the object
pivoting about that line, and a jar swings down in the fingers when the arm accelerates (measured: up to 50°
of tilt on a 10 cm lift). Real finger pads have a contact patch that resists that torque; ``condim=4`` with a
torsional friction coefficient models it. With MuJoCo's default pyramidal friction cones a held jar also
creeps slowly out of the fingers while it is carried (5 of 10 carries lost the jar); elliptic cones, the
setting MuJoCo recommends for grasping, stop the creep (0 of 10). The settings live in
``recipes/grasps.toml`` ``[grip]`` and are applied by the generator and the grasp check alike.

Example::

    apply_grip(scene.model, GripConfig())
"""

from __future__ import annotations

from dataclasses import dataclass

import mujoco
import numpy as np

from mgdata.sim import robot


@dataclass(frozen=True)
class GripConfig:
    """Contact settings of the finger geoms (``recipes/grasps.toml`` ``[grip]``)."""

    condim: int = 4  # 3: sliding friction only; 4: plus torsional friction about the normal
    torsional_friction: float = 0.02  # m, torsional friction coefficient of the finger pads
    elliptic_cone: bool = True  # elliptic friction cones: held objects no longer creep out of the fingers


def finger_geom_ids(model: mujoco.MjModel) -> np.ndarray:
    """The colliding geoms of the two finger bodies."""
    bodies = [model.body(b).id for b in robot.FINGER_BODIES]
    colliding = (model.geom_contype != 0) | (model.geom_conaffinity != 0)
    return np.flatnonzero(np.isin(model.geom_bodyid, bodies) & colliding)


def apply_grip(model: mujoco.MjModel, cfg: GripConfig) -> None:
    """Set the finger geoms' contact dimension and torsional friction in a compiled model (in place)."""
    if cfg.condim not in (3, 4, 6):
        raise ValueError(f"grip condim must be 3, 4 or 6, got {cfg.condim}")
    ids = finger_geom_ids(model)
    model.geom_condim[ids] = cfg.condim
    model.geom_friction[ids, 1] = cfg.torsional_friction
    if cfg.elliptic_cone:
        model.opt.cone = mujoco.mjtCone.mjCONE_ELLIPTIC
