"""ObjectContact: the contact model of object geoms by asset category (``recipes/sim.toml`` ``[contact]``),
applied to each object instance's geoms as its scene is assembled (:func:`mgdata.sim.world.assemble_spec`).

MuJoCo's default contact (``solref`` 0.02 s, critically damped) is a spring-damper about 50 rad/s stiff: an
object landing at ``v`` sinks about ``v · 0.02 s / e`` into what it lands on before it stops, 7 mm at 1 m/s.
A 2 cm candy poured into a tray lands at 0.6–1.1 m/s: it sank 5–11 mm into the tray's 6 mm floor, at times
through it (docs/sim.md). The geoms of ``stiff_categories`` get ``stiff_solref`` (two timesteps, as the finger
pads') with the weight ``stiff_solmix`` in MuJoCo's mix of two geoms' ``solref`` (each geom's share is its
``solmix`` over the pair's sum; every other object geom, the table and the arm keep 1). The geoms of
``dominant_categories`` get ``dominant_solmix`` instead, so all their contacts are stiff. Against the finger
pads (weight 100, the same ``solref``, MuJoCo's default ``solimp`` on both) every mix gives the pads' own
values: grip is unchanged. What a stiff contact leaves is the timestep's travel: a candy landing at ``v``
is found up to ``v · timestep`` (2 mm at 1 m/s) inside the floor, stopped within that step and pushed out
within ~3 more (6 ms), so a 20 Hz frame rarely catches more than 1 mm. (A contact ``margin`` finds it before
it touches, but MuJoCo's contact then rests ``margin`` apart, and every contact within the margin counts as
touching: the robot passing 1.5 mm from the candy touched it.)

Example::

    ObjectContact().apply(body, "food")   # every colliding geom of body (and of its links)
"""

from __future__ import annotations

from dataclasses import dataclass

import mujoco

from mgdata.errors import RecipeError


@dataclass(frozen=True)
class ObjectContact:
    """Contact parameters of object geoms by asset category (``recipes/sim.toml`` ``[contact]``).

    Attributes:
        stiff_categories: asset categories (``food``, ``sponge`` …) whose geoms get ``stiff_solref``.
        stiff_solref: their contact ``solref`` (time constant s, damping ratio); MuJoCo raises a time
            constant under two timesteps to two timesteps.
        stiff_solmix: their ``solmix`` weight (MuJoCo's default, which every other geom keeps, is 1; the
            finger pads' is ``[gripper] finger_solmix``): a contact takes ``solmix / (solmix + other's)`` of
            its ``solref`` from each geom.
        dominant_categories: stiff categories whose geoms get ``dominant_solmix``.
        dominant_solmix: their ``solmix`` weight.
    """

    stiff_categories: tuple[str, ...] = ("food", "sponge")
    stiff_solref: tuple[float, float] = (0.004, 1.0)
    stiff_solmix: float = 2.0
    dominant_categories: tuple[str, ...] = ("food",)
    dominant_solmix: float = 100.0

    def __post_init__(self) -> None:
        from mgdata.sim.assets.library import categories  # the library imports the scene layer's users

        if not (self.stiff_solref[0] > 0 and self.stiff_solref[1] > 0):
            raise RecipeError(f"[contact] stiff_solref = {list(self.stiff_solref)}: expected [time constant "
                              "s, damping ratio], both > 0")
        for key in ("stiff_solmix", "dominant_solmix"):
            if not getattr(self, key) > 0:
                raise RecipeError(f"[contact] {key} = {getattr(self, key)!r}: expected a number > 0")
        known = categories()
        for key in ("stiff_categories", "dominant_categories"):
            unknown = sorted(set(getattr(self, key)) - set(known))
            if unknown:
                raise RecipeError(f"[contact] {key} names {unknown}: expected asset categories "
                                  f"({', '.join(known)})")
        loose = sorted(set(self.dominant_categories) - set(self.stiff_categories))
        if loose:
            raise RecipeError(f"[contact] dominant_categories names {loose}, which stiff_categories does "
                              "not: a dominant category is a stiff one")

    def apply(self, body: mujoco.MjsBody, category: str) -> None:
        """Give the colliding geoms of ``body`` and its descendants the contact model of ``category``."""
        if category not in self.stiff_categories:
            return
        for geom in body.find_all(mujoco.mjtObj.mjOBJ_GEOM):
            if geom.contype or geom.conaffinity:
                geom.solref = list(self.stiff_solref)
                geom.solmix = self.stiff_solmix
                if category in self.dominant_categories:
                    geom.solmix = self.dominant_solmix
