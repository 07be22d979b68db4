"""Fixtures of the Layer 2 skeleton-helper tests: a real attempt context on a cabinet base task (the scene,
the planner and the grasps an attempt sees)."""

from __future__ import annotations

import pytest

from mgdata.engine.executor import Executor
from mgdata.engine.init_gate import base_task
from mgdata.grasps.db import GraspDB
from mgdata.paths import grasps_dir
from mgdata.skeleton.context import Context
from mgdata.skeleton.skeleton import load_family_recipe
from tests.helpers.attempt_context import fresh_context


@pytest.fixture(scope="package")
def cabinet_executor() -> Executor:
    recipe = load_family_recipe("cabinet")
    return Executor(base_task(recipe, 0), recipe, grasps=GraspDB.load_dir(grasps_dir()), render=False)


@pytest.fixture
def ctx(cabinet_executor: Executor) -> Context:
    """A fresh attempt context (draw 1) on the reset cabinet scene."""
    return fresh_context(cabinet_executor, 1)
