"""``mgdata grasps generate | validate | list`` through the real console script."""

from __future__ import annotations

import subprocess
import sys
from dataclasses import replace
from pathlib import Path

from mgdata.grasps.db import Grasp, GraspDB
from mgdata.sim.assets import model_names

MGDATA = str(Path(sys.executable).parent / "mgdata")


def _run(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run([MGDATA, "grasps", *args], capture_output=True, text=True, timeout=600)


def test_generate_validate_list(tmp_path: Path) -> None:
    gen = _run("generate", "jar/hinged_05", "--dir", str(tmp_path))
    assert gen.returncode == 0, gen.stderr
    db = GraspDB.load_dir(tmp_path)
    assert db.keys == ("jar/hinged_05",) and len(db.grasps("jar/hinged_05")) == 24
    assert all(g.status == "unvalidated" for g in db.grasps("jar/hinged_05"))
    val = _run("validate", "--dir", str(tmp_path))
    assert val.returncode == 0, val.stderr
    assert "of 24 grasps valid" in val.stdout
    checked = GraspDB.load_dir(tmp_path).grasps("jar/hinged_05")
    assert all(g.status in ("valid", "invalid") for g in checked)
    assert all("lifted" in g.detail or "unreachable" in g.detail for g in checked)
    # each side direction comes in two rolls; the one that puts the wrist camera's body under the table top is
    # rejected (in collision), the other must hold: every direction keeps a valid grasp
    assert len({g.id.rsplit("_", 1)[0] for g in checked if g.status == "valid"}) >= 11
    listed = _run("list", "--dir", str(tmp_path))
    assert "jar/hinged_05" in listed.stdout and "24" in listed.stdout
    # regenerating keeps annotated grasps and replaces generated ones; a generated grasp whose stored pose is
    # the generator's keeps its result, one whose pose differs comes back at the generator's pose, unchecked;
    # one stored a rounding step off (the last stored digit of a quaternion) is the same grasp: it stays as
    # stored, result and all (a file written by another run of the generator's arithmetic)
    annotated = checked[0].__class__("mine", (0.0, 0.0, 0.06), (1.0, 0.0, 0.0, 0.0), "side", "annotated")
    moved = replace(checked[0], pos=(checked[0].pos[0], checked[0].pos[1], checked[0].pos[2] + 0.01))
    nudged = replace(checked[1], quat=(checked[1].quat[0] + 1e-8, *checked[1].quat[1:]))
    edited = GraspDB.load_dir(tmp_path).with_object("jar/hinged_05", [annotated, moved, nudged, *checked[2:]])
    edited.write_dir(tmp_path)
    stored = GraspDB.load_dir(tmp_path).grasps("jar/hinged_05")[2]
    assert stored.quat != checked[1].quat
    assert _run("generate", "jar/hinged_05", "--dir", str(tmp_path)).returncode == 0
    again = GraspDB.load_dir(tmp_path).grasps("jar/hinged_05")
    assert again[0].id == "mine" and len(again) == 25
    assert (again[1].id, again[1].pos, again[1].status) == (checked[0].id, checked[0].pos, "unvalidated")
    assert again[2] == stored and again[2].status == checked[1].status
    result = [(g.id, g.status, g.detail) for g in again[2:]]
    assert result == [(g.id, g.status, g.detail) for g in checked[1:]]


def test_generate_drops_generated_grasps_the_generator_no_longer_makes(tmp_path: Path) -> None:
    # A plate's rim is too steep for a pinch from above (it slides off): a DB written by an older generator
    # that made one loses it on regenerating, the plate's edge pinches come instead, and an annotated grasp
    # stays. A model with no candidate at all (a dust layer: visual specks) loses its entry, and the
    # category's file goes with its last one.
    stale = Grasp("rim_000_r0", (0.11, 0.0, 0.02), (0.0, 0.7071068, 0.7071068, 0.0), "top_down", "generated")
    mine = Grasp("mine", (0.0, 0.0, 0.03), (0.0, 1.0, 0.0, 0.0), "top_down", "annotated")
    GraspDB({"plate/flat_00": (stale,), "plate/flat_01": (stale, mine)}).write_dir(tmp_path)
    gen = _run("generate", "plate/flat_0[01]", "--dir", str(tmp_path))
    assert gen.returncode == 0, gen.stderr
    db = GraspDB.load_dir(tmp_path)
    plain, annotated = ([g.id for g in db.grasps(k)] for k in ("plate/flat_00", "plate/flat_01"))
    assert plain and all(i.startswith("edge_") for i in plain)
    assert annotated == ["mine", *plain]
    GraspDB({"dust/layer_00": (stale,)}).write_dir(tmp_path)
    gen = _run("generate", "dust/layer_00", "--dir", str(tmp_path))
    assert gen.returncode == 0 and "dust/layer_00: no candidate grasps" in gen.stdout
    assert not (tmp_path / "dust.json").exists()


def test_bad_patterns_are_one_line_errors(tmp_path: Path) -> None:
    proc = _run("generate", "nothing/*", "--dir", str(tmp_path))
    assert proc.returncode == 2 and "matches no object model" in proc.stderr
    assert "Traceback" not in proc.stderr
    (tmp_path / "jar.json").write_text("{oops")
    proc = _run("list", "--dir", str(tmp_path))
    assert proc.returncode == 2 and "jar.json: not valid JSON" in proc.stderr


def test_report_counts_coverage_per_category(tmp_path: Path) -> None:
    def grasp(gid: str, status: str) -> Grasp:
        return Grasp(gid, (0.0, 0.0, 0.05), (0.0, 1.0, 0.0, 0.0), "top_down", "generated").with_status(status)

    db = GraspDB({}).with_object("box/carton_00", [grasp("a", "valid"), grasp("b", "invalid")])
    db = db.with_object("box/carton_01", [grasp("a", "invalid"), grasp("b", "unvalidated")])
    db.write_dir(tmp_path)
    proc = _run("report", "box", "bowl", "--dir", str(tmp_path))
    assert proc.returncode == 0, proc.stderr
    rows = {line.split("│")[1].strip(): [c.strip() for c in line.split("│")[2:-1]]
            for line in proc.stdout.splitlines() if line.startswith("│")}
    n_box, n_bowl = len(model_names("box")), len(model_names("bowl"))
    assert rows["box"] == [f"1 / {n_box}", "0", "1", "3", "4"]
    assert rows["bowl"] == [f"0 / {n_bowl}", "0", "0", "0", "0"]
    assert rows["all"] == [f"1 / {n_box + n_bowl}", "0", "1", "3", "4"]
    # three valid grasps make an object well covered
    db.with_object("box/carton_01", [grasp(g, "valid") for g in "xyz"]).write_dir(tmp_path)
    out = _run("report", "box", "--dir", str(tmp_path)).stdout
    rows = {line.split("│")[1].strip(): [c.strip() for c in line.split("│")[2:-1]]
            for line in out.splitlines() if line.startswith("│")}
    assert rows["box"] == [f"2 / {n_box}", "1", "4", "5", "5"]
    bad = _run("report", "bowls", "--dir", str(tmp_path))
    assert bad.returncode == 2 and "unknown object category 'bowls'" in bad.stderr
    assert "Traceback" not in bad.stderr
