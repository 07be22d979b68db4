"""Engagement: the first control step at which any robot link touches a task object.

Task objects are the scene's object instances (not the table, the floor or the robot itself); contact is
whole-arm, not just the fingers (reference §3). The flag latches: ``t_engage`` is the step of first contact.

Example::

    eng = EngagementTracker(scene)
    for t in range(T):
        ...step...
        engaged = eng.update(t)
"""

from __future__ import annotations

import numpy as np

from mgdata.sim.predicates import Contacts
from mgdata.sim.scene import OWNER_ROBOT, Scene


class EngagementTracker:
    """Latches the first step with robot–object contact.

    Attributes:
        t_engage: the step of first engagement, or ``None`` before it.
    """

    def __init__(self, scene: Scene) -> None:
        self.scene = scene
        self._robot = np.zeros(len(scene.owners) + 1, dtype=bool)
        self._robot[OWNER_ROBOT] = True
        self._objects = np.zeros(len(scene.owners) + 1, dtype=bool)
        self._objects[OWNER_ROBOT + 1 : len(scene.owners)] = True
        self.t_engage: int | None = None

    def reset(self) -> None:
        self.t_engage = None

    @property
    def engaged(self) -> bool:
        return self.t_engage is not None

    def touching(self, contacts: Contacts | None = None) -> bool:
        """Does a robot link touch a task object in the scene's current state?"""
        c = contacts or Contacts(self.scene)
        return bool(c.between(self._robot, self._objects).any())

    def update(self, t: int, contacts: Contacts | None = None) -> bool:
        """Record step ``t``; returns whether engagement has happened at or before it (latched)."""
        if self.t_engage is None and self.touching(contacts):
            self.t_engage = t
        return self.t_engage is not None
