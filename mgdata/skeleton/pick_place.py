"""A tagged pick (open, pre-grasp, approach, settle, close, lift) and place (lower, release, retreat), as
segments; the skeleton resolves their runtime targets.

Every segment and runtime-target name is ``tag`` + a step name; ``renamed`` maps a step to another name
(``{"pre_grasp": "pre"}``: the segment and target ``sponge_pre``). The targets a skeleton resolves are
``name("pre_grasp")``, ``name("grasp")``, ``name("lift")`` and ``name("retreat")``, plus the place target
it passes to :meth:`PickPlace.place`.

Example::

    sponge = PickPlace("sponge", tag="sponge_", renamed={"pre_grasp": "pre", "grasp_settle": "settle"})
    segs = [*sponge.pick(ctx.params), s.free("sponge_back", "sponge_back", gripper="close",
            attached="sponge"), *sponge.place("sponge_place", retreat_steps=ctx.params["open_steps"])]
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from types import MappingProxyType
from typing import Any

from mgdata.skeleton import segment as s
from mgdata.tasks.recipe_keys import Param, RecipeKeys

PICK_KEYS = RecipeKeys(params=(
    Param("open_steps", int, "control steps to open the gripper", 1, 200),
    Param("grasp_settle_steps", int, "control steps holding the grasp pose before closing", 0, 200),
    Param("close_steps", int, "control steps to close the gripper on the object", 1, 200),
))
"""The recipe ``[params]`` :meth:`PickPlace.pick` reads."""


@dataclass(frozen=True)
class PickPlace:
    """The pick and place segments of ``obj``.

    Attributes:
        obj: the object picked.
        tag: prefix of every segment and runtime-target name.
        riders: instances riding inside it (carried along, never obstacles).
        support: the body it rests on when picked (the lift may leave it touching that).
        renamed: step name -> the name used instead (after ``tag``).
    """

    obj: str
    tag: str = ""
    riders: tuple[str, ...] = ()
    support: str = "table"
    renamed: Mapping[str, str] = field(default_factory=lambda: MappingProxyType({}))

    def name(self, step: str) -> str:
        """The segment or runtime-target name of ``step``.

        >>> PickPlace("lid", tag="lid_", renamed={"pre_grasp": "pre"}).name("pre_grasp")
        'lid_pre'
        """
        return f"{self.tag}{self.renamed.get(step, step)}"

    def pick(self, params: Mapping[str, Any]) -> list[s.MotionSegment]:
        """Open (``open_steps``), pre-grasp (free), approach (linear), settle (``grasp_settle_steps``), close
        (``close_steps``), lift (linear, held)."""
        n = self.name
        return [
            s.gripper(n("open"), "open", steps=params["open_steps"]),
            s.free(n("pre_grasp"), n("pre_grasp"), riders=self.riders),
            s.linear(n("approach"), n("grasp"), allow=(("hand", self.obj),), riders=self.riders),
            s.hold(n("grasp_settle"), steps=params["grasp_settle_steps"]),
            s.gripper(n("close"), "close", steps=params["close_steps"]),
            s.linear(n("lift"), n("lift"), gripper="close", attached=self.obj, riders=self.riders,
                     allow=((self.obj, self.support),)),
        ]

    def place(self, target: str, *, retreat_steps: int) -> list[s.MotionSegment]:
        """Lower the held object in a straight line to runtime target ``target`` (carry it above the spot
        first), release it (``retreat_steps``) and back off to ``name("retreat")``."""
        n = self.name
        return [
            s.linear(n("place"), target, gripper="close", attached=self.obj, riders=self.riders,
                     allow=((self.obj, "table"),)),
            s.gripper(n("release"), "open", steps=retreat_steps),
            s.linear(n("retreat"), n("retreat"), allow=(("hand", self.obj),), riders=self.riders),
        ]
