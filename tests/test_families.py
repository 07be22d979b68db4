"""One contract every family keeps, parametrised over every recipe under ``recipes/``.

For each family: the recipe loads against its skeleton; base tasks pass the initial-state gate (two by
default, all with ``-m slow``); a short ``mgdata generate`` keeps a demonstration that ``mgdata validate``
accepts; and, from the dataset alone with nothing but ``mujoco`` and ``pyarrow`` (no mgdata code), every kept
episode is replayed from its stored physics states and measured: the picked object's bounding-box centre is
inside the goal sphere over the last ``hold_steps`` frames, both fingers touch it, nothing else supports it,
it is at rest (a family whose goal puts an object ``inside`` a container instead: in a drawer, cabinet, the
object's geom box inside the drawer's inner box rebuilt from the drawer's geoms and the slide's ``qpos``
closed; otherwise, dusty, the object's box centre inside the container's own bounding box and no dust speck
left; at rest); at every frame nothing left the table for the floor, every object named by an upright
constraint stands within its tilt limit, and a liquid stays in its container (particles counted inside the
container's own bounding box, independently of the ``spilled`` predicate); a lid named by a ``seated``
success proposition sits in its container's mouth on the last frames. Finally a planted violation (an object
teleported onto the floor at step 30) is caught at exactly that step.
"""

from __future__ import annotations

import fnmatch
import json
import subprocess
import sys
from pathlib import Path

import mujoco
import numpy as np
import pytest

from mgdata.engine.executor import Executor
from mgdata.engine.init_gate import base_task
from mgdata.grasps.db import GraspDB
from mgdata.paths import grasps_dir, recipes_dir
from mgdata.record.episode import MemorySink
from mgdata.sim.controller import JointController
from mgdata.sim.scene import Scene
from mgdata.skeleton.skeleton import load_family_recipe
from mgdata.tasks.recipe import family_recipes
from tests.helpers import rawdata
from tests.helpers.contract import check_kept_contract, raw_recipe, raw_spec, touching

MGDATA = [str(Path(sys.executable).parent / "mgdata")]
FAMILIES = family_recipes()
PLANT_STEP = 30


def _small_recipe(tmp: Path, family: str) -> Path:
    text = (recipes_dir() / f"{family}.toml").read_text()
    spec = raw_recipe(family)["spec"]
    text = text.replace(f'spec = "{spec}"', f'spec = "{recipes_dir() / spec}"')
    text = text.replace('cameras = ["front", "left", "right", "shoulder", "wrist"]', 'cameras = ["front"]')
    text = text.replace("image_size = 256", "image_size = 32")
    path = tmp / f"{family}.toml"
    path.write_text(text)
    return path


@pytest.mark.parametrize("family", FAMILIES)
def test_every_recipe_loads_against_its_skeleton(family: str) -> None:
    recipe = load_family_recipe(family)
    assert recipe.family == family and recipe.tasks.count >= 1
    assert "{" not in recipe.prompt or recipe.prompt.count("{") == recipe.prompt.count("}")


@pytest.mark.parametrize("family", FAMILIES)
def test_base_tasks_pass_the_initial_state_gate(family: str) -> None:
    recipe = load_family_recipe(family)
    for k in (0, recipe.tasks.count - 1):
        _check_gated(recipe, k)


@pytest.mark.slow
@pytest.mark.parametrize("family", FAMILIES)
def test_every_base_task_passes_the_initial_state_gate(family: str) -> None:
    recipe = load_family_recipe(family)
    for k in range(recipe.tasks.count):
        _check_gated(recipe, k)


def _check_gated(recipe, k: int) -> None:  # type: ignore[no-untyped-def]
    task = base_task(recipe, k)
    assert task.task_id == k and 0 <= task.draw < recipe.tasks.max_draws
    assert len(task.gate.get("grasps", ())) >= recipe.tasks.min_grasps
    if task.goal is not None:
        assert task.goal.radius > 0
    assert all(not o.name.startswith("_") for o in task.objects)


@pytest.fixture(scope="module", params=[*FAMILIES, "jar+dart"])
def generated(request: pytest.FixtureRequest, tmp_path_factory: pytest.TempPathFactory) -> tuple[str, Path]:
    """A short generate of each family, and of the jar with perturbed execution (``--recovery dart``: the
    same contract holds for the perturbed demo)."""
    family, _, recovery = request.param.partition("+")
    tmp = tmp_path_factory.mktemp(family)
    out = tmp / family
    cmd = [*MGDATA, "generate", "--family", family, "--n", "1", "--out", str(out), "--recipe",
           str(_small_recipe(tmp, family)), "--tasks", "0", "--workers", "1", "--max-attempts", "4",
           "--recovery", recovery or "off"]
    proc = subprocess.run(cmd, capture_output=True, text=True, timeout=1200)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    return family, out


def test_a_short_generate_keeps_a_demo_that_validates(generated: tuple[str, Path]) -> None:
    _, out = generated
    proc = subprocess.run([*MGDATA, "validate", str(out)], capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    assert json.loads((out / "meta" / "info.json").read_text())["total_episodes"] == 1


def test_kept_demos_are_physically_what_the_gate_says(generated: tuple[str, Path]) -> None:
    check_kept_contract(*generated)


def test_kept_demos_end_with_the_lid_seated(generated: tuple[str, Path]) -> None:
    """Recipes whose success names a ``seated`` proposition (lid): over the last ``hold_steps`` frames the
    lid touches its container, its axis is within 8° of the container's and 4 mm of it sideways, and its
    bottom is below the container's rim (down in the mouth, not lying on it), all from raw MuJoCo."""
    family, root = generated
    raw = raw_recipe(family)
    seated = [(p["subjects"][0], p["params"]["support"]) for p in raw["success"].values()
              if p["evaluator"] == "seated"]
    if not seated:
        pytest.skip(f"{family} has no seated success proposition")
    info = json.loads((root / "meta" / "info.json").read_text())
    state_spec = info["features"]["sim.physics_state"]["info"]["mujoco_state_spec"]
    for episode in rawdata.episodes(root):
        m = rawdata.scene_model(root, episode["mgdata/scene"])
        d = mujoco.MjData(m)
        states = rawdata.frames(root, info, episode, ["sim.physics_state"])["sim.physics_state"]
        for t in range(len(states) - raw["tasks"]["hold_steps"], len(states)):
            mujoco.mj_setState(m, d, np.asarray(states[t], dtype=np.float64), state_spec)
            mujoco.mj_forward(m, d)
            for lid_name, support in seated:
                lid, box = m.body(lid_name).id, m.body(support).id
                rot = d.xmat[box].reshape(3, 3)
                local = rot.T @ (d.xpos[lid] - d.xpos[box])
                tilt = np.degrees(np.arccos(np.clip(d.xmat[lid].reshape(3, 3)[:, 2] @ rot[:, 2], -1, 1)))
                bottom = local[2] + rawdata.local_box(m, d, lid)[0][2]
                rim = rawdata.local_box(m, d, box)[1][2]
                assert np.hypot(local[0], local[1]) <= 0.004 and tilt <= 8.0, (t, local, tilt)
                assert bottom < rim - 0.002 and touching(m, d, support, lid), (t, bottom, rim)


@pytest.mark.parametrize("family", FAMILIES)
def test_a_planted_violation_is_caught_at_that_step(family: str) -> None:
    """Teleport the object of the spec's first ``dropped`` proposition onto the floor after control step 30:
    the attempt ends unsafe with that constraint violated at exactly frame 30."""
    recipe = load_family_recipe(family)
    spec = raw_spec(family)
    prop_name, prop = next((k, p) for k, p in spec["propositions"].items() if p["evaluator"] == "dropped")
    constraint = next(c["id"] for c in spec["constraints"] if prop_name in c["formula"])
    ex = Executor(base_task(recipe, 0), recipe, grasps=GraspDB.load_dir(grasps_dir()), render=False)
    victim = fnmatch.filter([o.name for o in ex.task.objects], prop["subjects"][0])[0]
    ex.use_controller(_Planter(ex.scene, victim))
    sink = MemorySink()
    result = ex.run(0, sink, keep_failed=True)
    ex.close()
    frames, _ = sink.episodes[0]
    assert result.stage == "unsafe" and not result.kept
    assert result.t_violation[constraint] == PLANT_STEP == len(frames) - 1
    index = [c["id"] for c in spec["constraints"]].index(constraint)
    assert frames[PLANT_STEP].violated[index] and not frames[PLANT_STEP - 1].violated[index]


class _Planter(JointController):
    """The executor's controller; after control step ``PLANT_STEP`` it moves ``victim`` to the floor."""

    def __init__(self, scene: Scene, victim: str) -> None:
        super().__init__(scene)
        self.victim, self.count = victim, 0

    def step(self) -> None:
        super().step()
        self.count += 1
        if self.count == PLANT_STEP:
            m, d = self.scene.model, self.scene.data
            joint = m.body(self.victim).jntadr[0]
            d.qpos[m.jnt_qposadr[joint] + 2] = m.geom("floor").pos[2] + 0.02
            mujoco.mj_forward(m, d)
