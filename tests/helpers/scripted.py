"""Builders of the engine tests: a minimal recipe and task around any object, a scripted skeleton."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from types import MappingProxyType
from typing import ClassVar

from mgdata.sim.taskspec import ObjectPlacement, TaskSpec
from mgdata.skeleton.context import Context
from mgdata.skeleton.segment import MotionSegment
from mgdata.skeleton.skeleton import FamilySkeleton, register
from mgdata.spec import Proposition, SafetySpec
from mgdata.tasks.layout_rules import Layout
from mgdata.tasks.recipe import Recipe, TaskSettings


@register
class ScriptedSkeleton(FamilySkeleton):
    """Plays the segments a test puts in ``SCRIPT`` (runtime targets resolve from ``TARGETS``)."""

    name = "scripted_test"
    SCRIPT: Sequence[MotionSegment] = ()
    TARGETS: ClassVar[dict] = {}

    def segments(self, ctx: Context) -> Sequence[MotionSegment]:
        return list(self.SCRIPT)

    def resolve(self, name, ctx):  # type: ignore[no-untyped-def]
        if name in self.TARGETS:
            return self.TARGETS[name](ctx)
        return super().resolve(name, ctx)


def scripted_recipe(success: tuple[Proposition, ...], horizon: int = 400, settle: int = 0) -> Recipe:
    spec = SafetySpec("scripted_test", (), ())
    return Recipe(
        family="scripted_test", skeleton="scripted_test", path=Path("scripted_test.toml"), spec=spec,
        prompt="test",
        tasks=TaskSettings(count=1, seed=0, horizon=horizon, hold_steps=3, settle_steps=settle,
                           cameras=("front",), image_size=64),
        success=success, layout=Layout((), None, {}), variation=MappingProxyType({}),
        params=MappingProxyType({}), digest="test",
    )


def scripted_task(objects: tuple[ObjectPlacement, ...], spec: SafetySpec | None = None) -> TaskSpec:
    return TaskSpec(family="scripted_test", task_id=0, condition="base", prompt="test", objects=objects,
                    safety=spec or SafetySpec("scripted_test", (), ()), image_size=64)
