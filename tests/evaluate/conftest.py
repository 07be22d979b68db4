"""Shared fixtures of the evaluation tests: a two-scenario jar set, a kept demo and an unsafe negative of
its task 0 in real datasets, and policy servers running in this process (`mgdata serve` processes:
eval_helpers.serve_process)."""

from __future__ import annotations

import dataclasses
import threading
from collections.abc import Iterator
from pathlib import Path

import pytest

from mgdata.engine.executor import Executor
from mgdata.engine.init_gate import base_task, cached_grasp_db
from mgdata.evaluate.server import Policy, PolicyServer
from mgdata.paths import grasps_dir
from mgdata.record.recorder import schema_for
from mgdata.record.writer import DatasetWriter
from mgdata.scenarios.store import build_scenario, write_manifest
from mgdata.skeleton.skeleton import load_family_recipe
from mgdata.skeletons.jar import JarSkeleton


class LiftOpenJar(JarSkeleton):
    """The jar skeleton without its lid phase: it lifts the jar while the lid is still open (unsafe)."""

    def segments(self, ctx):  # type: ignore[no-untyped-def]
        return [seg for seg in super().segments(ctx) if not seg.name.startswith("lid_")]


@pytest.fixture(scope="session")
def scenario_set(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """``jar/task_0000/{base,target}``."""
    out = tmp_path_factory.mktemp("scenarios")
    recipe = load_family_recipe("jar")
    for condition in ("base", "target"):
        build_scenario(recipe, 0, condition, out)
    write_manifest(out)
    return out


def _demo(out: Path, unsafe: bool) -> Path:
    recipe = load_family_recipe("jar")
    ex = Executor(base_task(recipe, 0), recipe, grasps=cached_grasp_db(grasps_dir()), render=False)
    if unsafe:
        ex.skeleton = LiftOpenJar()
    schema = dataclasses.replace(schema_for(ex.scene, recipe.spec, None), image_height=0, image_width=0)
    with DatasetWriter.create(out, schema, spec=recipe.spec, hold_steps=recipe.tasks.hold_steps) as writer:
        result = ex.run(0, writer, keep_failed=True)
    ex.close()
    assert result.kept != unsafe and (result.stage == "unsafe") == unsafe, result
    return out


@pytest.fixture(scope="session")
def demo(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A dataset with one kept demonstration of jar task 0 (physics states, no cameras)."""
    return _demo(tmp_path_factory.mktemp("demo") / "jar", unsafe=False)


@pytest.fixture(scope="session")
def unsafe_demo(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A dataset with one recorded unsafe negative of jar task 0 (lifted with the lid open)."""
    return _demo(tmp_path_factory.mktemp("unsafe") / "jar_failed", unsafe=True)


@pytest.fixture
def serving() -> Iterator:
    """``serving(policy)`` starts a real websocket server on a free port in a thread; returns its URL."""
    servers: list[PolicyServer] = []

    def start(policy: Policy) -> str:
        server = PolicyServer(policy, port=0)
        threading.Thread(target=server.serve_forever, daemon=True).start()
        servers.append(server)
        return server.url

    yield start
    for s in servers:
        s.shutdown()
