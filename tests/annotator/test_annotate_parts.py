"""The annotator's parts without a browser: object list, placements, approach hint, store, worker, CLI
errors, and the live checks against quantities computed here from the geometry and the robot's reach."""

from __future__ import annotations

import itertools
import math
import threading
import time

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from typer.testing import CliRunner

from mgdata.annotator.catalog import Catalog
from mgdata.annotator.config import load_annotate_config
from mgdata.annotator.live import LiveChecker
from mgdata.annotator.objectscene import ObjectScene
from mgdata.annotator.placements import recipe_placements
from mgdata.annotator.store import GraspStore
from mgdata.annotator.worker import LatestWorker
from mgdata.errors import AssetError
from mgdata.grasps.config import load_grasp_config
from mgdata.grasps.db import Grasp, GraspDB, approach_hint, write_file
from mgdata.motion import Pose
from mgdata.sim.assets import get_model, model_names
from mgdata.tasks.base import draw_task
from mgdata.tasks.recipe import load_recipe


# ----------------------------------------------------------------------------------------- object list
def test_family_objects_are_the_models_its_recipe_names() -> None:
    cat = Catalog.build(family="jar")
    assert set(cat.keys) == set(model_names("jar")) | set(model_names("food"))
    assert list(cat.keys) == sorted(cat.keys)
    assert Catalog.build(family="jar", category="jar").keys == tuple(model_names("jar"))
    assert not any(k.startswith(("liquid/", "dust/")) for k in Catalog.build().keys)


def test_unknown_keys_and_categories_are_refused() -> None:
    cat = Catalog.build(category="jar")
    for bad in ("../../etc/passwd", "jar/hinged_99", "cup/tumbler_00", "jar/../cup"):
        with pytest.raises(AssetError):
            cat.index(bad)
    with pytest.raises(AssetError, match="unknown object category"):
        Catalog.build(category="nope")
    assert cat.search("HINGED_1") == tuple(k for k in model_names("jar") if "hinged_1" in k)


def test_cli_rejects_bad_input_with_one_line() -> None:
    from mgdata.cli import _register_all, app

    _register_all()
    for args, word in ((["annotate", "--category", "nope"], "category"),
                       (["annotate", "--family", "nope"], "nope"),
                       (["annotate", "--category", "jar", "--object", "jar/hinged_99"], "hinged_99")):
        result = CliRunner().invoke(app, args)
        assert result.exit_code != 0 and isinstance(result.exception, AssetError | Exception)
        assert word in str(result.exception)


# ------------------------------------------------------------------------------------------- placements
def test_recipe_placements_come_from_the_family_base_tasks() -> None:
    live = load_annotate_config().live
    chosen = recipe_placements("jar", "jar", live)
    real = {(round(p.pos[0], 9), round(p.pos[1], 9), round(p.yaw, 9))
            for t in (draw_task(load_recipe("jar"), k) for k in range(26)) for p in t.objects
            if p.model.startswith("jar/")}
    assert len(chosen) == live.placements
    for p in chosen:
        assert (round(p.pos[0], 9), round(p.pos[1], 9), round(p.yaw, 9)) in real
        assert p.pos[2] == 0.0  # standing on the table top
    defaults = recipe_placements("jar", "cup", live)  # the jar recipe never places a cup
    assert [p.pos[1] for p in defaults] == list(live.default_y)
    assert recipe_placements(None, "jar", live) == defaults


# ------------------------------------------------------------------------------------------ approach hint
@settings(max_examples=200, deadline=None)
@given(st.lists(st.floats(-1, 1), min_size=4, max_size=4).filter(lambda q: sum(v * v for v in q) > 0.01))
def test_approach_hint_follows_the_angle_from_straight_down(q: list[float]) -> None:
    quat = np.asarray(q) / np.linalg.norm(q)
    z = Pose(np.zeros(3), quat).rotation()[:, 2]  # the gripper's approach axis
    angle = math.degrees(math.acos(float(np.clip(-z[2], -1.0, 1.0))))
    if abs(angle - 60.0) < 1e-6 or abs(angle - 120.0) < 1e-6:
        return
    expected = "top_down" if angle < 60.0 else "bottom_up" if angle > 120.0 else "side"
    assert approach_hint(tuple(quat)) == expected


# ------------------------------------------------------------------------------------------------ store
def test_store_adds_and_deletes_only_annotated_grasps(tmp_path) -> None:
    generated = Grasp("side_000_r0", (0.01, 0.0, 0.05), (0.5, 0.5, 0.5, 0.5), "side", "generated", "valid")
    write_file(tmp_path / "jar.json", {"jar/hinged_00": [generated], "jar/hinged_01": [generated]})
    store = GraspStore(tmp_path)
    down = (0.0, 1.0, 0.0, 0.0)  # 180° about x: the approach points down
    a = store.add("jar/hinged_00", (0.0, 0.0, 0.1), down, "guided")
    b = store.add("jar/hinged_00", (0.0, 0.0, 0.12), down, "free", "valid", "lifted")
    assert (a.id, a.approach, a.source, b.id, b.status) == ("guided_00", "top_down", "annotated", "free_01",
                                                            "valid")
    on_disk = GraspDB.load_dir(tmp_path)
    assert [g.id for g in on_disk.grasps("jar/hinged_00")] == ["side_000_r0", "guided_00", "free_01"]
    assert on_disk.grasps("jar/hinged_01") == (generated,)
    assert store.delete_last("jar/hinged_00") == b
    assert store.delete_last("jar/hinged_00") == a
    assert store.delete_last("jar/hinged_00") is None  # the generated grasp stays
    assert GraspDB.load_dir(tmp_path).grasps("jar/hinged_00") == (generated,)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["jar.json"]
    assert store.resume_index(("jar/hinged_00", "jar/hinged_01")) == 0


# ----------------------------------------------------------------------------------------------- worker
def test_worker_always_finishes_the_newest_request_and_never_queues() -> None:
    done: list[int] = []
    started: list[int] = []
    finished = threading.Event()

    def job(request: int, stale) -> int | None:
        started.append(request)
        for _ in range(20):  # 20 ms of work, giving up once something newer waits
            if stale():
                return None
            time.sleep(0.001)
        return request

    def on_result(d) -> None:
        done.append(d.result)
        if d.result == 199:
            finished.set()

    worker = LatestWorker(job, on_result)
    try:
        for i in range(200):
            worker.submit(i)
            time.sleep(0.0005)
        last = time.monotonic()
        assert finished.wait(5.0)
        waited = time.monotonic() - last
    finally:
        worker.close()
    assert done[-1] == 199
    assert len(done) <= 5, f"{len(done)} superseded requests still ran to the end"
    assert waited < 0.5, f"the newest request finished {waited:.2f} s after it came: a backlog was worked off"
    assert len(started) < 200
    assert all(a < b for a, b in itertools.pairwise(done))


# ------------------------------------------------------------------------------------------- live checks
@pytest.fixture(scope="module")
def jar_checker() -> LiveChecker:
    live, check = load_annotate_config().live, load_grasp_config().check
    placements = recipe_placements("jar", "jar", live)
    return LiveChecker(ObjectScene.build("jar/hinged_03", placements[0], live), placements, live, check)


def _side(z: float, depth_past_axis: float = 0.0) -> Pose:
    """A horizontal grasp from −Y through the jar's axis at height z, fingers closing along X."""
    rot = np.stack([[0.0, 0.0, 1.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]], axis=1)  # x, y, z columns
    return Pose.from_pos_mat(np.array([0.0, depth_past_axis, z]), rot)


def test_width_badge_measures_the_jar(jar_checker: LiveChecker) -> None:
    geo = get_model("jar/hinged_03").geometry
    v = jar_checker.check(_side(0.07))
    width = v.badge("width")
    assert width.level == "green"
    measured = float(width.reason.split(" cm")[0]) / 100.0
    assert abs(measured - 2.0 * geo["outer_radius"]) < 0.003  # the jar's diameter, from its own parameters
    above = jar_checker.check(_side(geo["total_height"] + 0.05))
    assert above.badge("width").level == "red" and above.level == "red"  # fingers close on air


def test_live_checks_flag_unreachable_and_colliding_poses(jar_checker: LiveChecker) -> None:
    good = jar_checker.check(_side(0.07))
    assert good.level in ("green", "amber") and good.clear[0], [b.reason for b in good.badges]
    far = Pose(np.array([0.0, -1.2, 0.07]), _side(0.07).quat)  # 1.2 m from the jar: beyond the Panda's reach
    v = jar_checker.check(far)
    assert v.badge("reach").level == "red" and v.level == "red"
    sunk = jar_checker.check(Pose(np.array([0.0, -0.04, -0.02]), _side(0.0).quat))  # hand 2 cm into the table
    assert sunk.level == "red" and not any(sunk.clear)
    assert sunk.badge("arm").level == "red" or sunk.badge("reach").level == "red"


def test_a_stale_check_gives_up(jar_checker: LiveChecker) -> None:
    assert jar_checker.check(_side(0.07), stale=lambda: True) is None


# ----------------------------------------------------------------------------------------------- export
def test_export_writes_transforms_and_success_flags(tmp_path) -> None:
    from mgdata.annotator.export import export_grasps

    w, x, y, z = 0.5, 0.5, 0.5, 0.5  # 120° about (1, 1, 1): x -> y -> z -> x
    ok = Grasp("a", (0.01, 0.02, 0.03), (w, x, y, z), "side", "annotated", "valid")
    bad = Grasp("b", (0.0, 0.0, 0.1), (0.0, 1.0, 0.0, 0.0), "top_down", "generated", "invalid")
    path = export_grasps(GraspDB({"jar/hinged_00": (ok, bad)}), ["jar/hinged_00", "cup/tumbler_00"],
                         tmp_path / "export" / "jar.npz")
    data = np.load(path)  # no pickle needed
    assert list(data["ids"]) == ["a", "b"] and list(data["keys"]) == ["jar/hinged_00"] * 2
    assert list(data["success"]) == [True, False] and list(data["validated"]) == [True, True]
    expected = np.eye(4)
    expected[:3, :3] = [[0, 0, 1], [1, 0, 0], [0, 1, 0]]  # columns: images of x, y, z
    expected[:3, 3] = (0.01, 0.02, 0.03)
    assert np.allclose(data["transforms"][0], expected)
    assert np.allclose(data["transforms"][1][:3, 2], (0.0, 0.0, -1.0))  # approach straight down
