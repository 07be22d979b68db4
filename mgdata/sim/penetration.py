"""Interpenetration: how deep the deepest contact of a state sinks, and between which bodies.

MuJoCo's contacts are soft: two geoms in contact overlap by ``-data.contact.dist`` (m). A grasp at 70 N
sinks the pads ~0.5 mm into an object; a contact centimetres deep means an object passed into another (a
food box through a tray's floor). :func:`deepest_contact` reads the contacts of the state in ``data`` (after
``mj_forward``), from the raw model alone, so a dataset reader can compute it from a stored scene and frame.

Example::

    mujoco.mj_forward(model, data)
    p = deepest_contact(model, data)          # Penetration(depth=0.00041, body1='jar', body2='right_finger')
"""

from __future__ import annotations

from dataclasses import dataclass

import mujoco
import numpy as np


@dataclass(frozen=True)
class Penetration:
    """The deepest overlap of a state (or the deepest over an episode's frames).

    Attributes:
        depth: overlap in metres (0.0: no contact overlaps).
        body1, body2: the bodies of the two geoms ("" when ``depth`` is 0).
        step: the frame it was found at, for an episode's deepest (``None`` for one state).
    """

    depth: float = 0.0
    body1: str = ""
    body2: str = ""
    step: int | None = None

    @property
    def bodies(self) -> str:
        """``"body1|body2"`` (sorted), or "" without an overlap."""
        return "|".join(sorted((self.body1, self.body2))) if self.depth > 0.0 else ""


NONE = Penetration()


def deepest_contact(model: mujoco.MjModel, data: mujoco.MjData) -> Penetration:
    """The deepest overlap among ``data``'s contacts (every contact MuJoCo found, active or not)."""
    n = data.ncon
    if n == 0:
        return NONE
    dist = data.contact.dist[:n]
    i = int(np.argmin(dist))
    if dist[i] >= 0.0:
        return NONE
    g1, g2 = (int(g) for g in data.contact.geom[i])
    name = lambda g: model.body(int(model.geom_bodyid[g])).name  # noqa: E731
    return Penetration(float(-dist[i]), name(g1), name(g2))
