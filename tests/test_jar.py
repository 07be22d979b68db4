"""The jar family end to end: base tasks, kept demonstrations measured with raw MuJoCo (the hold at rest in
the goal, the grip, the wrist camera), determinism, a forced violation, the CLI, and resuming after a real
SIGKILL."""

from __future__ import annotations

import itertools
import json
import math
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import mujoco
import numpy as np
import pytest

from mgdata.engine.executor import Executor
from mgdata.engine.init_gate import base_task
from mgdata.grasps.db import GraspDB
from mgdata.paths import grasps_dir
from mgdata.record.episode import MemorySink
from mgdata.record.reader import DatasetReader
from mgdata.record.video import decode
from mgdata.sim.assets import get_model
from mgdata.sim.cameras import WRIST, WRIST_BODY_GEOM
from mgdata.sim.controller import JointController
from mgdata.sim.scene import Scene
from mgdata.skeleton import segment as s
from mgdata.skeletons.jar import JarSkeleton
from mgdata.tasks.base import draw_task
from mgdata.tasks.recipe import load_recipe
from tests.helpers.generate import jar_recipe

MGDATA = [str(Path(sys.executable).parent / "mgdata")]


@pytest.fixture(scope="module")
def recipe():  # type: ignore[no-untyped-def]
    return load_recipe("jar")


@pytest.fixture(scope="module")
def grasps() -> GraspDB:
    return GraspDB.load_dir(grasps_dir())



def two_camera_recipe(tmp: Path) -> Path:
    """The shipped jar recipe with two 64-pixel cameras (fast to render and encode)."""
    return jar_recipe(tmp, cameras=("front", "wrist"), image_size=64)


def test_base_tasks_follow_the_layout_rules(recipe) -> None:  # type: ignore[no-untyped-def]
    tasks = [draw_task(recipe, k) for k in range(recipe.tasks.count)]
    assert len(tasks) == 26
    assert [draw_task(recipe, k) for k in range(26)] == tasks  # deterministic
    jar_rule, goal_rule = recipe.layout.role("jar"), recipe.layout.goal
    for task in tasks:
        jar, food = task.object("jar"), task.object("food")
        (x0, x1), (y0, y1) = jar_rule.region
        assert x0 <= jar.pos[0] <= x1 and y0 <= jar.pos[1] <= y1
        facing = math.atan2(jar.pos[1], jar.pos[0])  # the hinge (local −X) faces the robot
        assert abs(jar.yaw - facing) <= math.radians(jar_rule.yaw.jitter_deg) + 1e-9
        gx, gy, gz = task.goal.pos
        (x0, x1), (y0, y1) = goal_rule.region
        assert x0 <= gx <= x1 and y0 <= gy <= y1 and gz == pytest.approx(goal_rule.height[0])
        d = math.hypot(gx - jar.pos[0], gy - jar.pos[1])
        assert goal_rule.distance[0] - 1e-9 <= d <= goal_rule.distance[1] + 1e-9
        geo = get_model(jar.model).geometry
        assert get_model(food.model).geometry["width"] < 2 * geo["mouth_radius"]
        assert (food.pos[0], food.pos[1]) == (jar.pos[0], jar.pos[1])
        assert task.prompt.startswith("Close the lid of the hinged jar holding the ")
        assert task.prompt.endswith("then carry the closed jar into the green goal sphere on the table.")
        assert task.articulation["jar"] == jar_rule.open


class RawProbe(JointController):
    """The executor's controller, measuring the jar, fingers and wrist camera with raw MuJoCo after every
    control step (``states[t - 1]`` describes the state of frame ``t``), independently of mgdata's
    predicates and gate."""

    def __init__(self, scene: Scene) -> None:
        super().__init__(scene)
        m = scene.model
        self.jar = scene.object_body("jar")
        geo = scene.object_model("jar").geometry
        self.centre_local = np.array([0.0, 0.0, scene.objects["jar"].size[2] / 2.0])  # bounding-box centre
        self.hinge = m.jnt_qposadr[m.joint("jar/lid_hinge").id]
        self.open_angle = geo["open_angle"]
        self.jar_geoms = set(scene.object_geom_ids("jar").tolist())
        self.fingers = [set(np.flatnonzero(m.geom_bodyid == m.body(b).id).tolist())
                        for b in ("left_finger", "right_finger")]
        self.table = set(np.flatnonzero(m.geom_bodyid == m.body("table").id).tolist())
        self.camera, self.cam_body = m.camera(WRIST).id, m.geom(WRIST_BODY_GEOM).id
        rigid = {m.body("hand").id, m.body("link7").id}  # the camera's own body and the flange it bolts to
        self.others = [g for g in range(m.ngeom) if m.geom_bodyid[g] not in rigid
                       and (m.geom_contype[g] or m.geom_conaffinity[g] or g in self.table)]
        self.states: list[dict] = []

    def step(self) -> None:
        super().step()
        m, d = self.scene.model, self.scene.data
        pairs = [(int(c.geom1), int(c.geom2), float(c.dist)) for c in d.contact[:d.ncon]] if d.ncon else []

        def touching(a: set, b: set) -> list[float]:
            return [dist for g1, g2, dist in pairs if (g1 in a and g2 in b) or (g2 in a and g1 in b)]

        fingers = [touching(f, self.jar_geoms) for f in self.fingers]
        clear = min(mujoco.mj_geomDistance(m, d, self.cam_body, g, 0.05, None) for g in self.others)
        self.states.append({
            "centre": d.xpos[self.jar] + d.xmat[self.jar].reshape(3, 3) @ self.centre_local,
            "lid_fraction": float(d.qpos[self.hinge]) / self.open_angle,
            "fingers_touch": all(fingers), "penetration": -min([0.0, *fingers[0], *fingers[1]]),
            "table_contact": bool(touching(self.table, self.jar_geoms)),
            "hand_T_jar": np.linalg.inv(_pose(d, m.body("hand").id)) @ _pose(d, self.jar),
            "camera_z": float(d.cam_xpos[self.camera][2]), "camera_clearance": float(clear),
        })


def _pose(d: mujoco.MjData, body: int) -> np.ndarray:
    T = np.eye(4)
    T[:3, :3], T[:3, 3] = d.xmat[body].reshape(3, 3), d.xpos[body]
    return T


def _probed_run(recipe, grasps, task: int, skeleton=None):  # type: ignore[no-untyped-def]
    ex = Executor(base_task(recipe, task), recipe, grasps=grasps, render=False)
    probe = RawProbe(ex.scene)
    ex.use_controller(probe)
    if skeleton is not None:
        ex.skeleton = skeleton
    sink = MemorySink()
    try:
        result = ex.run(0, sink)
        ex.scene.reset()
        camera_start = float(ex.scene.data.cam_xpos[probe.camera][2])
        goal, radius = np.asarray(ex.task.goal.pos), ex.task.goal.radius
    finally:
        ex.close()
    return result, sink, probe.states, camera_start, goal, radius


@pytest.fixture(scope="module")
def demos(recipe, grasps):  # type: ignore[no-untyped-def]
    """Kept demonstrations of three base tasks, with raw measurements of every state."""
    return [_probed_run(recipe, grasps, task) for task in (0, 1, 2)]


def test_kept_demos_end_with_the_closed_jar_held_at_rest_in_the_goal(recipe, demos) -> None:  # type: ignore[no-untyped-def]
    hold, dt = recipe.tasks.hold_steps, 0.05
    for result, sink, states, _, goal, radius in demos:
        frames, meta = sink.episodes[0]
        assert result.kept and meta.kept and meta.success and len(states) == len(frames) - 1
        assert all(t is None for t in meta.t_violation.values()) and not any(f.violated.any() for f in frames)
        last = states[-hold:]  # the last hold_steps frames
        assert all(f.success for f in frames[-hold:])
        assert all(np.array_equal(f.action, frames[-1].action) for f in frames[-hold - 1:])  # commanded still
        assert frames[-1].action[7] == 1.0  # gripper closed
        for st in last:
            assert np.linalg.norm(st["centre"] - goal) < radius, "jar centre outside the goal sphere"
            assert st["lid_fraction"] <= 0.05  # the lid is shut
            assert st["fingers_touch"] and not st["table_contact"]
        speeds = [np.linalg.norm(b["centre"] - a["centre"]) / dt for a, b in itertools.pairwise(last)]
        assert max(speeds) <= recipe.tasks.rest_linear_speed, f"jar still moving: {max(speeds):.4f} m/s"
        # the motion really ended before the window: the last command change comes before it
        actions = [f.action for f in frames]
        changes = [i for i in range(1, len(actions)) if not np.array_equal(actions[i], actions[i - 1])]
        assert len(frames) - 1 - changes[-1] > hold


def test_a_jar_demonstration_is_reproducible(recipe, grasps, demos) -> None:  # type: ignore[no-untyped-def]
    ex = Executor(base_task(recipe, 0), recipe, grasps=grasps, render=False)
    sink2 = MemorySink()
    res2 = ex.run(0, sink2)
    ex.close()
    res, sink = demos[0][:2]
    assert res.kept and res.stage is None and res.verdict
    assert res.t_engage is not None and all(t is None for t in res.t_violation.values())
    frames, meta = sink.episodes[0]
    assert meta.kept and meta.success and meta.grasp_id == res.grasp_id and meta.draw_index == 0
    assert len(frames) == res.steps + 1 and all(f.success for f in frames[-recipe.tasks.hold_steps:])
    assert not any(f.violated.any() for f in frames)
    # the same seed gives the same episode, bit for bit
    assert res2.steps == res.steps and res2.seed == res.seed
    for a, b in zip(frames, sink2.episodes[0][0], strict=True):
        assert np.array_equal(a.state, b.state) and np.array_equal(a.action, b.action)
        assert np.array_equal(a.labels, b.labels) and np.array_equal(a.dfa_state, b.dfa_state)


def test_wrist_camera_never_goes_below_the_table_or_into_geometry(demos) -> None:  # type: ignore[no-untyped-def]
    """Every state of the kept demos: the eye above the table top (z = 0) and the camera's body (the eye sits
    on its front face) clear of every geometry but the hand it is bolted to."""
    for _, _, states, camera_start, _, _ in demos:
        assert camera_start > 0.0
        assert min(st["camera_z"] for st in states) > 0.0
        assert min(st["camera_clearance"] for st in states) > 0.0


class _LiftAndHold(JarSkeleton):
    """The jar skeleton up to the lift, then 5 s (100 control steps) holding the lifted jar still."""

    def segments(self, ctx):  # type: ignore[no-untyped-def]
        segs = list(super().segments(ctx))
        lift = [seg.name for seg in segs].index("lift")
        return [*segs[:lift + 1], s.hold("hold_5s", steps=100, gripper="close")]


def test_grasped_jar_does_not_slip_or_sink_into_the_fingers(recipe, grasps) -> None:  # type: ignore[no-untyped-def]
    """Grip quality (recipes/sim.toml [gripper]): slip of the jar in the hand frame over a 5 s hold <= 3 mm,
    finger-jar penetration (``data.contact.dist``) < 1 mm at every step of the attempt."""
    for task in (0, 3):
        result, _, states, _, _, _ = _probed_run(recipe, grasps, task, _LiftAndHold())
        assert result.stage == "goal_not_reached" and result.segment == "settle"  # every segment ran
        held = states[-(100 + recipe.tasks.settle_steps):]  # the 5 s hold, then the settling steps
        assert all(st["fingers_touch"] and not st["table_contact"] for st in held)
        slip = np.linalg.norm(held[100]["hand_T_jar"][:3, 3] - held[0]["hand_T_jar"][:3, 3])
        assert slip <= 0.003, f"task {task}: the jar slipped {slip * 1000:.2f} mm in 5 s"
        assert max(st["penetration"] for st in states) < 0.001


def test_missing_grasps_fail_with_a_hint(recipe) -> None:  # type: ignore[no-untyped-def]
    ex = Executor(base_task(recipe, 0), recipe, grasps=GraspDB({}), render=False)
    res = ex.run(0, MemorySink())
    ex.close()
    assert res.stage == "no_grasp" and "mgdata grasps generate" in (res.reason or "") and res.steps == 0


class _LiftOpenJar(JarSkeleton):
    """The jar skeleton without its lid phase: it lifts the jar while the lid is still open."""

    def segments(self, ctx):  # type: ignore[no-untyped-def]
        return [seg for seg in super().segments(ctx) if not seg.name.startswith("lid_")]


def test_lifting_the_open_jar_is_rejected_at_the_violating_step(recipe, grasps):  # type: ignore[no-untyped-def]
    ex = Executor(base_task(recipe, 0), recipe, grasps=grasps, render=False)
    ex.skeleton = _LiftOpenJar()
    sink = MemorySink()
    res = ex.run(0, sink, keep_failed=True)
    ex.close()
    assert res.stage == "unsafe" and not res.kept and res.segment == "lift"
    t_v = res.t_violation["jar_stays_until_closed"]
    assert t_v is not None and res.t_violation["jar_not_dropped"] is None
    assert "jar_stays_until_closed violated at step" in (res.reason or "")
    frames, meta = sink.episodes[0]
    names = recipe.spec.proposition_names
    on, closed = names.index("jar_on_support"), names.index("jar_closed")
    first_bad = next(t for t, f in enumerate(frames) if not f.labels[on] and not f.labels[closed])
    assert t_v == first_bad == res.steps == len(frames) - 1  # the attempt ended at that very step
    assert frames[t_v].violated[0] and not frames[t_v - 1].violated[0]
    assert meta.failure_stage == "unsafe" and not meta.kept and not meta.verdict


def _generate(out: Path, recipe_file: Path, n: int, *extra: str) -> subprocess.CompletedProcess:
    cmd = [*MGDATA, "generate", "--family", "jar", "--n", str(n), "--out", str(out), "--recipe",
           str(recipe_file), "--tasks", "0-3", *extra]
    return subprocess.run(cmd, capture_output=True, text=True, timeout=600)


def _files(root: Path) -> dict[str, bytes]:
    return {str(p.relative_to(root)): p.read_bytes() for p in sorted(root.rglob("*"))
            if p.is_file() and ".mgdata" not in p.parts}


def test_generate_cli_writes_a_valid_dataset(tmp_path: Path) -> None:
    """The bare command on the shipped recipe (five 256² cameras), two demonstrations."""
    out = tmp_path / "jar"
    cmd = [*MGDATA, "generate", "--family", "jar", "--n", "2", "--out", str(out)]
    proc = subprocess.run(cmd, capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    assert "target reached" in proc.stdout and "kept" in proc.stdout
    check = subprocess.run([*MGDATA, "validate", str(out)], capture_output=True, text=True, timeout=300)
    assert check.returncode == 0, check.stdout + check.stderr
    reader = DatasetReader(out)
    assert reader.num_episodes == 2
    metas = [reader.record(i).meta for i in range(2)]
    assert all(m.kept and m.verdict and m.family == "jar" for m in metas)
    assert [(m.task_id, m.draw_index) for m in metas] == [(0, 0), (1, 0)]
    # a second run with the same target has nothing to do and leaves the dataset untouched
    assert reader.schema.cameras == ("front", "left", "right", "shoulder", "wrist")
    assert reader.schema.image_height == 256
    # the preview: every camera plus the label panel in a 3 × 2 grid, one video frame per recorded step
    movie = tmp_path / "preview.mp4"
    shown = subprocess.run([*MGDATA, "preview", str(out), "--episodes", "1", "--out", str(movie)],
                           capture_output=True, text=True, timeout=300)
    assert shown.returncode == 0, shown.stderr
    grid = decode(movie, 0, reader.record(1).length, reader.schema.fps)
    assert grid.shape == (reader.record(1).length, 512, 768, 3)
    front = reader.frames(1, "front")
    assert np.abs(grid[:, :256, :256].astype(int) - front.astype(int)).mean() < 6.0  # re-encoded picture
    before = _files(out)
    again = subprocess.run(cmd, capture_output=True, text=True, timeout=600)
    assert again.returncode == 0 and _files(out) == before
    # resuming with another seed would mix seeds: refused with one line, nothing touched
    other = subprocess.run([*cmd, "--seed", "7"], capture_output=True, text=True, timeout=600)
    assert other.returncode == 2 and "seed=0" in other.stderr and "seed=7" in other.stderr
    assert _files(out) == before


def test_bad_input_is_one_clear_error(tmp_path: Path) -> None:
    cmd = [*MGDATA, "generate", "--family", "nosuch", "--n", "1", "--out", str(tmp_path / "x")]
    proc = subprocess.run(cmd, capture_output=True, text=True, timeout=120)
    assert proc.returncode == 2
    assert "no recipe for family 'nosuch'" in proc.stderr and "Traceback" not in proc.stderr
    proc = _generate(tmp_path / "y", two_camera_recipe(tmp_path), 1, "--tasks", "0-40")
    assert proc.returncode == 2 and "do not exist" in proc.stderr


def _children(pid: int) -> list[int]:
    out = []
    for stat in Path("/proc").glob("[0-9]*/stat"):
        try:
            fields = stat.read_text().rsplit(")", 1)[1].split()
        except OSError:
            continue
        if int(fields[1]) == pid:
            out.append(int(stat.parent.name))
    return out


def _alive(pid: int) -> bool:
    try:
        return Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0] != "Z"
    except OSError:
        return False


def test_resume_after_sigkill_continues_without_gaps(tmp_path: Path) -> None:
    """Kill -9 a two-worker run mid-episode, resume with one worker: the dataset is byte-identical to an
    uninterrupted one-worker run (so neither the kill nor the worker count changes a single byte)."""
    recipe_file = two_camera_recipe(tmp_path)
    whole = tmp_path / "whole"
    assert _generate(whole, recipe_file, 3).returncode == 0
    out = tmp_path / "killed"
    cmd = [*MGDATA, "generate", "--family", "jar", "--n", "3", "--out", str(out), "--recipe",
           str(recipe_file), "--tasks", "0-3", "--workers", "2"]
    proc = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    info = out / "meta" / "info.json"
    deadline = time.monotonic() + 300
    while time.monotonic() < deadline:  # wait for the first committed episode; kill during the next one
        # (at once: workers run ahead, so the remaining appends can all land within a fraction of a second)
        if info.exists() and json.loads(info.read_text()).get("total_episodes", 0) >= 1:
            break
        time.sleep(0.01)
    workers = _children(proc.pid)
    os.kill(proc.pid, signal.SIGKILL)
    proc.wait()
    deadline = time.monotonic() + 10
    while any(_alive(w) for w in workers) and time.monotonic() < deadline:
        time.sleep(0.05)
    assert workers and not any(_alive(w) for w in workers), "worker processes outlived the killed run"
    first = json.loads(info.read_text())["total_episodes"]
    assert 1 <= first < 3
    resumed = _generate(out, recipe_file, 3)
    assert resumed.returncode == 0, resumed.stdout + resumed.stderr
    reader = DatasetReader(out)
    metas = [reader.record(i).meta for i in range(reader.num_episodes)]
    keys = [(m.task_id, m.draw_index) for m in metas]
    assert len(keys) == 3 and len(set(keys)) == 3
    assert subprocess.run([*MGDATA, "validate", str(out)], capture_output=True, timeout=300).returncode == 0
    # the interrupted-and-resumed dataset is the uninterrupted one, byte for byte
    assert _files(out) == _files(whole)


def test_keep_failed_puts_labelled_negatives_in_a_separate_dataset(tmp_path: Path) -> None:
    recipe_file = two_camera_recipe(tmp_path)
    # a lid that starts below vertical falls shut while the scene settles: the lid-push target cannot exist
    recipe_file.write_text(recipe_file.read_text().replace("open = 1.0", "open = 0.5"))
    out = tmp_path / "jar"
    proc = _generate(out, recipe_file, 1, "--keep-failed", "--max-attempts", "2")
    assert proc.returncode == 1 and "max attempts reached" in proc.stdout, proc.stdout + proc.stderr
    assert DatasetReader(out).num_episodes == 0
    negatives = DatasetReader(out.with_name("jar_failed"))
    metas = [negatives.record(i).meta for i in range(negatives.num_episodes)]
    assert [(m.task_id, m.draw_index) for m in metas] == [(0, 0), (1, 0)]
    assert all(not m.kept and m.failure_stage == "target_fail" and "past vertical" in m.failure_reason
               for m in metas)
    assert negatives.episode(0).labels.shape[1] == 4  # the labels are stored with the negatives too


def test_ctrl_c_stops_cleanly_and_keeps_what_was_committed(tmp_path: Path) -> None:
    out = tmp_path / "jar"
    cmd = [*MGDATA, "generate", "--family", "jar", "--n", "20", "--out", str(out), "--recipe",
           str(two_camera_recipe(tmp_path)), "--workers", "2"]
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    info = out / "meta" / "info.json"
    deadline = time.monotonic() + 300
    while time.monotonic() < deadline and not (
            info.exists() and json.loads(info.read_text()).get("total_episodes", 0) >= 1):
        time.sleep(0.05)
    os.kill(proc.pid, signal.SIGINT)
    stdout, stderr = proc.communicate(timeout=120)
    assert proc.returncode == 1, stdout + stderr
    assert "interrupted" in stdout and "Traceback" not in stderr
    check = subprocess.run([*MGDATA, "validate", str(out)], capture_output=True, text=True, timeout=300)
    assert check.returncode == 0, check.stdout
    assert 1 <= DatasetReader(out).num_episodes < 20
