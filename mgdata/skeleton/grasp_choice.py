"""Choosing this attempt's grasp from the initial-state gate's facts.

The gate records the ids of the grasps it found reachable as a fact (``"grasps"``, ``"sponge_grasps"``,
``"handle_grasps"`` …); an attempt takes one of them round-robin by its draw. Without the fact (a scenario
built before the gate recorded it, a test calling the skeleton directly) the grasps reachable from the live
state count instead.

Example::

    grasp = choose_grasp(ctx, "sponge", "sponge_grasps", lambda: sponge.reachable_grasps(ctx),
                         none="no reachable valid grasp of the sponge")
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import TYPE_CHECKING

from mgdata.episode.gate import AttemptFailed

if TYPE_CHECKING:
    from mgdata.grasps.db import Grasp
    from mgdata.skeleton.context import Context


def usable_grasps(ctx: Context, obj: str, fact: str,
                  reachable: Callable[[], Sequence[Grasp]]) -> tuple[Grasp, ...]:
    """The grasps of ``obj`` the gate fact ``fact`` names, in the fact's order (``reachable()`` without the
    fact)."""
    ids = ctx.task.gate.get(fact)
    if ids is None:
        return tuple(reachable())
    by_id = {g.id: g for g in ctx.grasps.get(obj, ())}
    return tuple(by_id[i] for i in ids if i in by_id)


def choose_grasp(ctx: Context, obj: str, fact: str, reachable: Callable[[], Sequence[Grasp]], *,
                 none: str) -> Grasp:
    """This attempt's grasp of ``obj``: round-robin by the draw over :func:`usable_grasps`; none usable ends
    the attempt (``no_grasp``, the message ``none``)."""
    usable = usable_grasps(ctx, obj, fact, reachable)
    if not usable:
        raise AttemptFailed("no_grasp", none)
    return usable[ctx.variation.pick(len(usable))]
