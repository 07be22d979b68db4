"""Shared fixtures for the simulation tests. Importing mgdata first selects the headless GL backend."""

from __future__ import annotations

import pytest

import mgdata  # noqa: F401  (must precede any mujoco import: sets MUJOCO_GL)
from mgdata.sim.scene import Scene, build_scene
from tests.helpers.sim_tasks import jar_task


@pytest.fixture(scope="module")
def jar_scene() -> Scene:
    """One jar scene per test module (reset it before use)."""
    return build_scene(jar_task())
