"""Grasp DB: round trip, validation errors naming file and key, atomic writes, schema.json agreement."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from mgdata.errors import GraspDBError
from mgdata.grasps.db import APPROACH_HINTS, SOURCES, STATUSES, Grasp, GraspDB, write_file
from mgdata.paths import grasps_dir


def _grasp(gid: str = "side_00", **kw: object) -> Grasp:
    base = dict(pos=(0.0, 0.01, 0.05), quat=(0.5, 0.5, -0.5, 0.5), approach="side", source="generated")
    base.update(kw)
    return Grasp(gid, **base)  # type: ignore[arg-type]


def _write_raw(path: Path, doc: object) -> Path:
    path.write_text(json.dumps(doc))
    return path


def _g0(doc: dict) -> dict:
    return doc["objects"]["jar/hinged_00"]["grasps"][0]


def _valid_doc() -> dict:
    return {
        "schema_version": 1,
        "objects": {
            "jar/hinged_00": {
                "grasps": [
                    {"id": "a", "pos": [0, 0, 0.1], "quat_wxyz": [0, 1, 0, 0], "approach": "top_down",
                     "source": "annotated"}
                ]
            }
        },
    }


def test_round_trip_keeps_everything(tmp_path: Path) -> None:
    jar = [_grasp("s0"), _grasp("s1").with_status("valid", "lift 10 cm")]
    db = GraspDB({}).with_object("jar/hinged_00", jar)
    db = db.with_object("cup/mug_01", [_grasp("t0", approach="top_down", source="annotated")])
    written = db.write_dir(tmp_path)
    assert sorted(p.name for p in written) == ["cup.json", "jar.json"]
    back = GraspDB.load_dir(tmp_path)
    assert back.keys == ("cup/mug_01", "jar/hinged_00")
    assert back.grasps("jar/hinged_00")[1].status == "valid"
    assert back.grasps("jar/hinged_00")[1].detail == "lift 10 cm"
    assert [g.id for g in back.grasps("jar/hinged_00", status="unvalidated")] == ["s0"]
    for key in db.keys:
        for a, b in zip(db.grasps(key), back.grasps(key), strict=True):
            assert np.allclose(a.matrix(), b.matrix(), atol=1e-6)
    # Writing the loaded DB again gives byte-identical files (deterministic output).
    again = tmp_path / "again"
    back.write_dir(again)
    for p in written:
        assert (again / p.name).read_bytes() == p.read_bytes()


def test_matrix_follows_documented_convention() -> None:
    # quat (0, 1, 0, 0): 180° about X, so the gripper's +Z (approach) points down in the object frame.
    g = _grasp(quat=(0.0, 1.0, 0.0, 0.0), pos=(0.1, 0.2, 0.3))
    m = g.matrix()
    assert np.allclose(m[:3, 2], [0, 0, -1])
    assert np.allclose(m[:3, 3], [0.1, 0.2, 0.3])


@pytest.mark.parametrize(
    ("mutate", "fragment"),
    [
        (lambda d: d.update(schema_version=7), "schema_version 7"),
        (lambda d: d.update(objects=[]), "'objects' must be an object"),
        (lambda d: d["objects"].update({"nocategory": {"grasps": []}}), "'category/model'"),
        (lambda d: d["objects"].update({"cup/x": {"grasps": []}}), "does not match file jar.json"),
        (lambda d: _g0(d).pop("pos"), "missing key 'pos'"),
        (lambda d: _g0(d).update(pos=[0, 0]), "grasps[0].pos"),
        (lambda d: _g0(d).update(quat_wxyz=[1, 1, 0, 0]), "unit quaternion"),
        (lambda d: _g0(d).update(approach="diagonal"), "'diagonal'"),
        (lambda d: _g0(d).update(source="magic"), "'magic'"),
        (lambda d: _g0(d).update(validation={"status": "ok"}), "validation"),
        (lambda d: d["objects"]["jar/hinged_00"]["grasps"].append(
            dict(d["objects"]["jar/hinged_00"]["grasps"][0])), "appears twice"),
    ],
)
def test_bad_files_give_one_clear_error(tmp_path: Path, mutate, fragment: str) -> None:
    doc = _valid_doc()
    mutate(doc)
    path = _write_raw(tmp_path / "jar.json", doc)
    with pytest.raises(GraspDBError) as err:
        GraspDB.load([path])
    assert str(path) in str(err.value)
    assert fragment in str(err.value)


def test_not_json_and_unknown_model(tmp_path: Path) -> None:
    bad = tmp_path / "jar.json"
    bad.write_text("{ not json")
    with pytest.raises(GraspDBError, match="not valid JSON"):
        GraspDB.load([bad])
    db = GraspDB.load([_write_raw(bad, _valid_doc())])
    with pytest.raises(GraspDBError, match=r"'jar/missing'.*jar/hinged_00"):
        db.grasps("jar/missing")


def test_atomic_write_leaves_old_file_on_failure(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    path = tmp_path / "jar.json"
    write_file(path, {"jar/hinged_00": [_grasp("old")]})
    before = path.read_bytes()

    def boom(src: str, dst: str) -> None:
        raise OSError("disk full")

    monkeypatch.setattr("mgdata.atomic.os.replace", boom)
    with pytest.raises(OSError):
        write_file(path, {"jar/hinged_00": [_grasp("new")]})
    assert path.read_bytes() == before
    assert [p.name for p in tmp_path.iterdir()] == ["jar.json"]  # no temp file left behind


def test_schema_json_agrees_with_validator() -> None:
    schema = json.loads((grasps_dir() / "schema.json").read_text())
    grasp = schema["$defs"]["grasp"]
    assert tuple(grasp["properties"]["approach"]["enum"]) == APPROACH_HINTS
    assert tuple(grasp["properties"]["source"]["enum"]) == SOURCES
    assert tuple(grasp["properties"]["validation"]["properties"]["status"]["enum"]) == STATUSES
    assert set(grasp["required"]) == {"id", "pos", "quat_wxyz", "approach", "source"}


def test_shipped_grasp_files_load() -> None:
    db = GraspDB.load_dir(grasps_dir())
    for key in db.keys:
        assert db.grasps(key), f"{key} has an empty grasp list"


_unit = st.floats(-1, 1, allow_nan=False)


@settings(max_examples=60, deadline=None)
@given(pos=st.tuples(_unit, _unit, _unit), q=st.tuples(_unit, _unit, _unit, _unit))
def test_any_pose_round_trips(tmp_path_factory: pytest.TempPathFactory, pos, q) -> None:
    norm = math.sqrt(sum(v * v for v in q))
    if norm < 1e-3:
        return
    quat = tuple(v / norm for v in q)
    g = _grasp(pos=pos, quat=quat)
    d = tmp_path_factory.mktemp("rt")
    GraspDB({}).with_object("jar/hinged_00", [g]).write_dir(d)
    back = GraspDB.load_dir(d).grasps("jar/hinged_00")[0]
    assert np.allclose(back.matrix(), g.matrix(), atol=1e-5)


def test_frame_round_trips_and_files_without_frames_are_unchanged(tmp_path: Path) -> None:
    # the jar's shipped file is written byte for byte as it is (no 'frame' key where none is set)
    shipped = grasps_dir() / "jar.json"
    GraspDB.load([shipped]).write_dir(tmp_path)
    assert (tmp_path / "jar.json").read_bytes() == shipped.read_bytes()
    drawer = _grasp("handle_r0", frame="drawer")
    GraspDB({}).with_object("cabinet/drawer_00", [drawer, _grasp("root")]).write_dir(tmp_path)
    raw = json.loads((tmp_path / "cabinet.json").read_text())["objects"]["cabinet/drawer_00"]["grasps"]
    assert raw[0]["frame"] == "drawer" and "frame" not in raw[1]
    back = GraspDB.load_dir(tmp_path).grasps("cabinet/drawer_00")
    assert [g.frame for g in back] == ["drawer", ""]
    raw[0]["frame"] = "cab/drawer"
    doc = {"schema_version": 1, "objects": {"cabinet/drawer_00": {"grasps": raw}}}
    _write_raw(tmp_path / "cabinet.json", doc)
    with pytest.raises(GraspDBError, match=r"grasps\[0\]\.frame"):
        GraspDB.load_dir(tmp_path)
