"""Contact readings between two sets of geoms: are they touching, and how hard do they press (N)?

A set is a boolean mask over the model's geoms; :func:`geom_set` builds one from a name: ``"hand"`` (the
hand and both fingers), an object instance (all its colliding geoms), ``"table"``, ``"floor"``, or any
body's full name (``"jar/lid"``: that body and its descendants). The force is the sum over the contacts
between the two sets of the normal component that ``mujoco.mj_contactForce`` reports (the first entry of
the contact-frame force), from the live ``data`` after ``mj_forward``/``mj_step``.

Example::

    hand, box = geom_set(scene, "hand"), geom_set(scene, "box")
    touching, newtons = pair_contact(scene.model, scene.data, hand, box)
"""

from __future__ import annotations

import mujoco
import numpy as np

from mgdata.errors import SceneError
from mgdata.sim import robot
from mgdata.sim.scene import OWNER_FLOOR, OWNER_TABLE, Scene

HAND = "hand"
"""The name of the gripper's geom set: the hand body and its descendants (both fingers)."""


def geom_set(scene: Scene, name: str) -> np.ndarray:
    """Boolean mask (ngeom,) of the colliding geoms named by ``name`` (see the module docstring).

    Raises:
        SceneError: no instance, fixed owner or body has that name.
    """
    m = scene.model
    if name in scene.object_names:
        mask = np.zeros(m.ngeom, dtype=bool)
        mask[scene.object_geom_ids(name)] = True
        return mask
    if name in ("table", "floor"):
        return scene.geom_owner == (OWNER_TABLE if name == "table" else OWNER_FLOOR)
    body = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, robot.HAND_BODY if name == HAND else name)
    if body < 0:
        raise SceneError(f"no object, body or fixed part named {name!r}; objects: "
                         f"{', '.join(scene.object_names) or 'none'} (or 'hand', 'table', 'floor', a body "
                         "name such as 'jar/lid')")
    inside = np.zeros(m.nbody, dtype=bool)
    inside[body] = True
    for b in range(body + 1, m.nbody):  # MuJoCo numbers children after their parents
        inside[b] = inside[m.body_parentid[b]]
    return inside[m.geom_bodyid] & (scene.geom_owner >= 0)


def pair_contact(model: mujoco.MjModel, data: mujoco.MjData, a: np.ndarray,
                 b: np.ndarray) -> tuple[bool, float]:
    """Whether a geom of set ``a`` touches one of set ``b``; the sum of those contacts' normal forces (N)."""
    n = data.ncon
    if n == 0:
        return False, 0.0
    g = data.contact.geom[:n]
    hits = np.flatnonzero((a[g[:, 0]] & b[g[:, 1]]) | (b[g[:, 0]] & a[g[:, 1]]))
    force = np.zeros(6)
    total = 0.0
    for i in hits:
        mujoco.mj_contactForce(model, data, int(i), force)
        total += float(force[0])
    return hits.size > 0, total
