"""Shared fixtures of the motion tests: scenes are compiled once per module (they take ~0.3 s each)."""

from __future__ import annotations

import mgdata  # noqa: F401  (must precede any mujoco import: sets MUJOCO_GL)

# isort: split
import mujoco
import pytest

from mgdata.motion import MotionConfig, MotionPlanner
from tests.helpers.motion_scenes import home_data, scene


@pytest.fixture(scope="module")
def wall_model() -> mujoco.MjModel:
    return scene(wall=True, box=True)


@pytest.fixture(scope="module")
def planner(wall_model: mujoco.MjModel) -> MotionPlanner:
    mp = MotionPlanner(wall_model, MotionConfig())
    mp.sync(home_data(wall_model))
    return mp
