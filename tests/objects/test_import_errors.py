"""Bad files and bad entries: one ``error:`` line, exit status 2, nothing written.

The refusals run in this process (:func:`tests.helpers.cli.mgdata_here`: they stop before any coacd or
simulation work); one case runs as a real ``mgdata`` process.
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

from tests.helpers.cli import mgdata_here
from tests.helpers.textured import box_triangles, textured_box, write_obj

NAME = "block/scanned_00"


@pytest.fixture
def root(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    """An empty root, named through the environment (``--root`` would set it for the rest of the run)."""
    from mgdata.sim.assets.library import forget_user_objects

    path = tmp_path / "root"
    path.mkdir()
    monkeypatch.setenv("MGDATA_ROOT", str(path))
    monkeypatch.setenv("MGDATA_CACHE", str(tmp_path / "cache"))
    forget_user_objects()
    yield path
    forget_user_objects()


def refused(root: Path, *args: str | Path) -> str:
    """Run ``mgdata objects import ARGS``; assert one error line, exit 2, an untouched root; the line."""
    run = mgdata_here("objects", "import", *args)
    assert run.returncode == 2, run.stdout + run.stderr
    lines = run.stderr.splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: "), run.stderr
    assert list(root.iterdir()) == [], list(root.rglob("*"))
    return lines[0]


def test_a_missing_texture_is_refused(root: Path, tmp_path: Path) -> None:
    src = textured_box(tmp_path / "src", image=False)
    line = refused(root, src, "--name", NAME, "--mass", "0.15")
    assert "names texture" in line and "box.png" in line and "does not exist" in line


def test_a_mesh_without_texture_coordinates_is_refused(root: Path, tmp_path: Path) -> None:
    verts, faces, _ = box_triangles((0.04, 0.06, 0.08))
    src = write_obj(tmp_path / "bare.obj", verts, faces, None)
    assert "has no texture" in refused(root, src, "--name", NAME, "--mass", "0.15")


def test_an_empty_mesh_is_refused(root: Path, tmp_path: Path) -> None:
    src = tmp_path / "empty.obj"
    src.write_text("v 0 0 0\nv 0.05 0 0\nv 0 0.05 0\n")
    assert "has no faces" in refused(root, src, "--name", NAME, "--mass", "0.15")
    (tmp_path / "nothing.obj").write_text("")
    refused(root, tmp_path / "nothing.obj", "--name", NAME, "--mass", "0.15")


def test_an_open_mesh_is_refused(root: Path, tmp_path: Path) -> None:
    """Open = some edge is not shared by exactly two faces (coacd needs an inside to decompose)."""
    src = textured_box(tmp_path / "src", drop_faces=2)  # one side of the box missing
    line = refused(root, src, "--name", NAME, "--mass", "0.15")
    assert "is not closed" in line and "4 edges in one face only" in line


@pytest.mark.parametrize(("args", "words"), [
    (("--scale", "10"), "largest side must be 1-50 cm"),     # 40 x 60 x 80 cm
    (("--scale", "0.1"), "largest side must be 1-50 cm"),    # 4 x 6 x 8 mm
    (("--mass", "40"), "out of range 0.005-3 kg"),
    (("--mass", "0.001"), "out of range 0.005-3 kg"),
    (("--mass", "2.9", "--scale", "0.3"), "kg/m³, out of range"),  # 1.2 x 1.8 x 2.4 cm of 2.9 kg
    (("--friction", "5"), "friction 5 is out of range"),
    (("--scale", "-1"), "must be positive"),
])
def test_an_absurd_scale_mass_or_friction_is_refused(root: Path, tmp_path: Path, args: tuple[str, ...],
                                                      words: str) -> None:
    src = textured_box(tmp_path / "src")
    argv = ["--name", NAME, "--mass", "0.15", *args]
    assert words in refused(root, src, *argv)


def test_a_bad_name_or_a_procedural_one_is_refused(root: Path, tmp_path: Path) -> None:
    src = textured_box(tmp_path / "src")
    assert "must be 'category/model'" in refused(root, src, "--name", "Block", "--mass", "0.15")
    assert "in the asset library already" in refused(root, src, "--name", "mug/handled_00", "--mass", "0.15")


def test_a_missing_file_is_refused_by_a_real_mgdata_process(root: Path, tmp_path: Path) -> None:
    env = {**os.environ, "MGDATA_ROOT": str(root)}
    run = subprocess.run([str(Path(sys.executable).with_name("mgdata")), "objects", "import",
                          str(tmp_path / "none.glb"), "--name", NAME, "--mass", "0.2"], capture_output=True,
                         text=True, env=env, timeout=120)
    assert run.returncode == 2 and run.stderr.count("\n") == 1 and "does not exist" in run.stderr
    assert list(root.iterdir()) == []


def write_entry(root: Path, body: str) -> Path:
    folder = root / "objects" / "block"
    folder.mkdir(parents=True, exist_ok=True)
    (folder / "m.obj").write_text("v 0 0 0\n")
    (folder / "scanned_00.toml").write_text(body)
    return folder / "scanned_00.toml"


@pytest.mark.parametrize(("body", "words"), [
    ('category = "block"\nmesh = "m.obj"\nmass = 0.1\ncolour = "red"\n', "unknown key 'colour'"),
    ('category = "block"\nmesh = "m.obj"\nmass = "heavy"\n', "mass = 'heavy': expected a number"),
    ('category = "block"\nmass = 0.1\n', "missing key 'mesh'"),
    ('category = "mug"\nmesh = "m.obj"\nmass = 0.1\n', "is not its folder's name 'block'"),
    ('category = "block"\nmesh = "gone.obj"\nmass = 0.1\n', "mesh = 'gone.obj': no such file"),
    ('category = "block"\nmesh = \n', "not valid TOML"),
])
def test_a_malformed_entry_is_one_line_naming_file_and_key(root: Path, body: str, words: str) -> None:
    entry = write_entry(root, body)
    for argv in (("objects", "list"), ("grasps", "generate", "block/*")):
        run = mgdata_here(*argv)
        assert run.returncode == 2, run.stdout + run.stderr
        assert run.stderr.startswith(f"error: {entry}: ") and run.stderr.count("\n") == 1, run.stderr
        assert words in run.stderr


def test_an_existing_entry_is_kept_unless_replaced(root: Path, tmp_path: Path) -> None:
    entry = write_entry(root, 'category = "block"\nmesh = "m.obj"\nmass = 0.1\n')
    before = entry.read_bytes()
    run = mgdata_here("objects", "import", textured_box(tmp_path / "src"), "--name", NAME, "--mass", "0.15")
    assert run.returncode == 2 and "exists already" in run.stderr and "pass --replace" in run.stderr
    assert entry.read_bytes() == before


def test_an_entry_without_texture_whose_mesh_embeds_none_is_refused(root: Path, tmp_path: Path) -> None:
    folder = root / "objects" / "block"
    folder.mkdir(parents=True)
    verts, faces, _ = box_triangles((0.04, 0.06, 0.08))
    write_obj(folder / "scanned_00.obj", verts, faces, None)
    entry = folder / "scanned_00.toml"
    entry.write_text('category = "block"\nmesh = "scanned_00.obj"\nmass = 0.15\n')
    run = mgdata_here("objects", "list")
    assert run.returncode == 2 and run.stderr == (
        f'error: {entry}: texture: missing, and mesh scanned_00.obj embeds no image (add texture = "<image '
        'file>")\n'), run.stderr
