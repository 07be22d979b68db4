"""Demonstrations with perturbed execution (DART, ``[recovery] mode = "dart"``), checked against raw MuJoCo:
the recorded actions are the plan's targets, the executed commands are the plan plus the recorded smooth
offsets, the stored states replay bit for bit from the executed commands (and not from the labels), and
the draws reproduce from the attempt's seed."""

from __future__ import annotations

import dataclasses
import json
import re
import shutil
import subprocess
import sys
from pathlib import Path

import mujoco  # after mgdata (conftest imports it first: it sets MUJOCO_GL)
import numpy as np
import pyarrow.parquet as pq
import pytest

from mgdata.engine.executor import Executor
from mgdata.engine.init_gate import base_task
from mgdata.errors import RecipeError
from mgdata.grasps.db import GraspDB
from mgdata.paths import grasps_dir, recipes_dir
from mgdata.record.episode import MemorySink
from mgdata.record.physics import STATE_SPEC
from mgdata.skeleton.skeleton import load_family_recipe
from mgdata.tasks.recipe import with_recovery
from mgdata.tasks.recovery import parse_recovery
from tests.helpers import tamper

MGDATA = [str(Path(sys.executable).parent / "mgdata")]

TASK, DRAW = 2, 1


def _attempt(mode: str) -> tuple:
    recipe = with_recovery(load_family_recipe("jar"), mode)
    ex = Executor(base_task(recipe, TASK), recipe, grasps=GraspDB.load_dir(grasps_dir()), render=False)
    sink = MemorySink()
    result = ex.run(DRAW, sink, keep_failed=True)
    ex.close()
    (frames, meta), mjb = sink.episodes[0], sink.scenes[0]
    return result, frames, meta, mjb, recipe


@pytest.fixture(scope="module")
def plain() -> tuple:
    return _attempt("off")


@pytest.fixture(scope="module")
def dart() -> tuple:
    return _attempt("dart")


@pytest.fixture(scope="module")
def replan() -> tuple:
    return _attempt("replan")


def _stack(frames: list, key: str) -> np.ndarray:
    return np.stack([getattr(f, key) for f in frames])


def test_a_perturbed_jar_demo_is_kept_and_its_offsets_are_bounded(dart: tuple) -> None:
    result, frames, meta, _, recipe = dart
    assert result.kept, (result.stage, result.reason)
    offset = np.abs(_stack(frames, "executed_action") - _stack(frames, "action"))
    assert np.all(offset[:, 7] == 0)  # the gripper command is never perturbed
    amplitude = recipe.recovery.amplitude
    assert amplitude / 4 < offset[:, :7].max() <= amplitude + 1e-6
    assert meta.variation["perturbation"]["mode"] == "dart"


def test_the_executed_command_is_the_plan_plus_the_recorded_smooth_offsets(dart: tuple) -> None:
    """Recomputed from the recorded draws with the docstring's formula (not the code's): inside each
    perturbed segment executed − action = A/2 · (u sin²(πs) + v sin(πs) sin(2πs)); elsewhere they are
    equal."""
    _, frames, meta, _, recipe = dart
    executed, action = _stack(frames, "executed_action"), _stack(frames, "action")
    expected = np.zeros((len(frames), 7))
    draws = meta.variation["perturbation"]["segments"]
    assert len(draws) >= 3
    for d in draws:
        s = np.arange(1, d["steps"] + 1) / d["steps"]
        u, v = np.array(d["u"]), np.array(d["v"])
        assert np.all(np.abs(u) <= 1) and np.all(np.abs(v) <= 1)
        expected[d["start"]:d["start"] + d["steps"]] = recipe.recovery.amplitude / 2 * (
            np.sin(np.pi * s)[:, None] ** 2 * u + (np.sin(np.pi * s) * np.sin(2 * np.pi * s))[:, None] * v)
    inside = np.any(expected != 0, axis=1)
    assert np.allclose(executed[:, :7] - action[:, :7], expected, atol=2e-6)
    assert np.array_equal(executed[~inside], action[~inside])


def test_the_labels_are_the_plans_targets_while_the_arm_is_pushed_off(plain: tuple, dart: tuple) -> None:
    """The first perturbed segment is planned from the same start with the same seed either way: its
    recorded actions are the plain demo's, bit for bit, while the measured joints leave them."""
    first = dart[2].variation["perturbation"]["segments"][0]
    span = slice(first["start"], first["start"] + first["steps"])
    assert np.array_equal(_stack(plain[1], "action")[span], _stack(dart[1], "action")[span])
    pushed = np.abs(_stack(plain[1], "state")[span, :7] - _stack(dart[1], "state")[span, :7]).max()
    assert pushed > 0.1 * dart[4].recovery.amplitude
    assert all(f.executed_action is None or np.array_equal(f.executed_action, f.action) for f in plain[1])


@pytest.mark.parametrize("mode", ["dart", "replan"])
def test_the_states_replay_from_the_executed_command_and_not_from_the_labels(
        mode: str, request: pytest.FixtureRequest) -> None:
    """Raw MuJoCo on the stored scene: frame t's state, the arm's controls set to executed[t] (clipped to
    the actuators' ranges), stepped for one control period, gives frame t + 1's state exactly; the label
    instead of the executed command does not."""
    _, frames, _, mjb, _ = request.getfixturevalue(mode)
    model = mujoco.MjModel.from_binary_path("scene.mjb", {"scene.mjb": mjb})
    substeps = round(0.05 / model.opt.timestep)
    arm = [mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_ACTUATOR, f"actuator{i}") for i in range(1, 8)]
    lo, hi = model.actuator_ctrlrange[arm, 0], model.actuator_ctrlrange[arm, 1]
    data, nxt = mujoco.MjData(model), mujoco.MjData(model)
    size = mujoco.mj_stateSize(model, STATE_SPEC)
    diverged_with_labels = 0
    for t in range(len(frames) - 1):
        mujoco.mj_setState(model, nxt, frames[t + 1].physics_state, STATE_SPEC)
        command = np.clip(frames[t].executed_action[:7].astype(np.float64), lo, hi)
        assert np.array_equal(nxt.ctrl[arm], command), t
        for label in (False, True):
            mujoco.mj_setState(model, data, frames[t].physics_state, STATE_SPEC)
            data.ctrl[:] = nxt.ctrl
            if label:
                data.ctrl[arm] = np.clip(frames[t].action[:7].astype(np.float64), lo, hi)
            for _ in range(substeps):
                mujoco.mj_step(model, data)
            got = np.empty(size)
            mujoco.mj_getState(model, data, got, STATE_SPEC)
            same = np.array_equal(got, frames[t + 1].physics_state)
            if label:
                diverged_with_labels += not same
            else:
                assert same, t
    assert diverged_with_labels > (len(frames) // 4 if mode == "dart" else 10)


@pytest.mark.parametrize("mode", ["dart", "replan"])
def test_perturbations_reproduce_from_the_seed(mode: str, request: pytest.FixtureRequest) -> None:
    first, again = request.getfixturevalue(mode), _attempt(mode)
    assert again[2].variation == first[2].variation
    for key in ("state", "action", "executed_action", "physics_state"):
        assert np.array_equal(_stack(again[1], key), _stack(first[1], key)), key


def test_a_pushed_demo_is_replanned_from_where_the_push_left_the_arm(replan: tuple) -> None:
    """Perturb and replan: inside each recorded push executed − action = A · u · sin²(π/2 · j / m) (the
    actions stay the plan's targets); outside the pushes they are equal; the first replanned target starts
    where the push left the command (within one step of the plan's pace), and the replanned path is what
    the demonstration then shows: its actions leave the original plan's, which the labels of the push
    followed."""
    result, frames, meta, _, recipe = replan
    assert result.kept, (result.stage, result.reason)
    executed, action = _stack(frames, "executed_action"), _stack(frames, "action")
    pushes = meta.variation["perturbation"]["segments"]
    assert meta.variation["perturbation"]["mode"] == "replan" and len(pushes) >= 2
    expected = np.zeros((len(frames), 7))
    for p in pushes:
        m = p["steps"]
        assert m == recipe.recovery.push_steps and p["replanned_steps"] > 0
        ramp = np.sin(np.pi / 2 * np.arange(1, m + 1) / m) ** 2
        expected[p["start"]:p["start"] + m] = recipe.recovery.amplitude * ramp[:, None] * np.array(p["u"])
        end = p["start"] + m  # the first replanned target
        assert np.abs(action[end, :7] - executed[end - 1, :7]).max() < 0.05, p
        assert np.abs(action[end, :7] - action[end - 1, :7]).max() > 0.5 * np.abs(expected[end - 1]).max()
    assert np.allclose(executed[:, :7] - action[:, :7], expected, atol=2e-6)
    assert np.array_equal(executed[:, 7], action[:, 7])


def test_bad_recovery_settings_are_one_clear_error() -> None:
    with pytest.raises(RecipeError, match="mode = 'replay'"):
        parse_recovery({"mode": "replay"}, "r.toml: [recovery]")
    with pytest.raises(RecipeError, match=r"amplitude = 0\.5"):
        parse_recovery({"mode": "dart", "amplitude": 0.5}, "r.toml: [recovery]")
    with pytest.raises(RecipeError, match="unknown key"):
        parse_recovery({"amplitud": 0.01}, "r.toml: [recovery]")
    assert dataclasses.asdict(parse_recovery({}, "r")) == {"mode": "off", "amplitude": 0.03, "push_steps": 10}
    with pytest.raises(RecipeError, match="push_steps = 0"):
        parse_recovery({"mode": "replan", "push_steps": 0}, "r.toml: [recovery]")


@pytest.fixture(scope="module")
def perturbed_dataset(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """``mgdata generate --recovery dart`` of one camera-free jar demo."""
    tmp = tmp_path_factory.mktemp("dart")
    text = (recipes_dir() / "jar.toml").read_text()
    text = re.sub(r'(?m)^spec = "(.*)"', lambda m: f'spec = "{recipes_dir() / m.group(1)}"', text)
    text = re.sub(r"(?m)^cameras = .*$", "cameras = []", text)
    (tmp / "jar.toml").write_text(text)
    out = tmp / "jar"
    proc = subprocess.run([*MGDATA, "generate", "--family", "jar", "--n", "1", "--tasks", "0", "--workers",
                           "1", "--recipe", str(tmp / "jar.toml"), "--recovery", "dart", "--out", str(out)],
                          capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    return out


def _validate(root: Path) -> subprocess.CompletedProcess:
    return subprocess.run([*MGDATA, "validate", str(root)], capture_output=True, text=True, timeout=600)


def test_validate_audits_the_executed_commands(perturbed_dataset: Path, tmp_path: Path) -> None:
    info = json.loads((perturbed_dataset / "meta/info.json").read_text())
    assert info["mgdata"]["recovery"] == {"mode": "dart", "amplitude": 0.03, "push_steps": 10}
    assert info["features"]["sim.executed_action"]["shape"] == [8]
    assert info["mgdata"]["generator"]["inputs_digest"].endswith("/recovery=dart")
    assert _validate(perturbed_dataset).returncode == 0
    shown = subprocess.run([*MGDATA, "info", str(perturbed_dataset)], capture_output=True, text=True,
                           timeout=600)
    assert "recovery    dart, amplitude 0.03 rad" in shown.stdout, shown.stdout
    cases = {  # a forger's edit (stats and checksums brought up to date) -> what validate must say
        "not stepped with it": lambda v: v.__setitem__((5, 0), v[5, 0] + 0.001),
        "executed gripper command": lambda v: v.__setitem__((5, 7), 1.0 - v[5, 7]),
        "more than the recorded amplitude": lambda v: v.__setitem__((40, 1), v[40, 1] + 0.05),
    }
    for expected, change in cases.items():
        forged = tmp_path / expected.replace(" ", "_")
        shutil.copytree(perturbed_dataset, forged)
        tamper.edit_column(forged, "sim.executed_action", 0, change)
        proc = _validate(forged)
        assert proc.returncode != 0 and expected in proc.stdout + proc.stderr, (expected, proc.stdout)


def test_training_views_drop_the_executed_command(perturbed_dataset: Path, tmp_path: Path) -> None:
    """What a policy learns from is the label (``action``); the executed command is simulator data."""
    out = tmp_path / "state"
    proc = subprocess.run([*MGDATA, "export", str(perturbed_dataset), str(out), "--format", "state"],
                          capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    features = json.loads((out / "meta/info.json").read_text())["features"]
    assert "sim.executed_action" not in features and "action" in features
    table = pq.read_table(next(out.glob("data/*/*.parquet")), columns=["action"])
    source = pq.read_table(next(perturbed_dataset.glob("data/*/*.parquet")), columns=["action"])
    assert table.column("action").equals(source.column("action"))
