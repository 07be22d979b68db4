"""The input holes of issue 8 §5, through the real ``mgdata`` command: each bad input ends as one literal
``error:`` line naming the problem, exit status 2, no traceback, and nothing already written is lost.
Inputs refused before any work runs go through the real entry point in this process (``mgdata_here``);
the rest (workers, kills, full disks, another user, the environment) run as ``mgdata`` processes."""

from __future__ import annotations

import json
import multiprocessing as mp
import os
import shutil
import signal
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path

import pytest

from mgdata.errors import GraspDBError, WorkerError
from mgdata.generate.workers import AttemptPool, WorkerConfig
from mgdata.paths import grasps_dir, recipes_dir
from mgdata.record.video import VideoSettings
from mgdata.tasks.recipe import family_recipes
from tests.helpers.cli import mgdata_here

MGDATA = [str(Path(sys.executable).parent / "mgdata")]
SPEC = recipes_dir() / "specs" / "jar.toml"


def mgdata(*args: str | Path, env: dict[str, str] | None = None, timeout: int = 300,
           user: int | None = None) -> subprocess.CompletedProcess:
    return subprocess.run([*MGDATA, *map(str, args)], capture_output=True, text=True, timeout=timeout,
                          env=None if env is None else os.environ | env, user=user)


def one_error(proc: subprocess.CompletedProcess, *fragments: str, status: int = 2) -> str:
    """The single ``error:`` line of a refused command (asserting status, no traceback, the fragments)."""
    assert proc.returncode == status, proc.stdout + proc.stderr
    assert "Traceback" not in proc.stderr + proc.stdout
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: "), proc.stderr
    for fragment in fragments:
        assert fragment in lines[0], lines[0]
    return lines[0]


def small_recipe(folder: Path, *edits: tuple[str, str], spec: Path = SPEC) -> Path:
    """The shipped jar recipe with two 64-pixel cameras (fast), with ``edits`` applied, as
    ``folder/jar.toml``."""
    text = (recipes_dir() / "jar.toml").read_text().replace('spec = "specs/jar.toml"', f'spec = "{spec}"')
    edits = (('cameras = ["front", "left", "right", "shoulder", "wrist"]', 'cameras = ["front", "wrist"]'),
             ("image_size = 256", "image_size = 64"), *edits)
    for old, new in edits:
        assert old in text, old
        text = text.replace(old, new, 1)
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / "jar.toml"
    path.write_text(text)
    return path


def generate(out: Path, recipe: Path, n: int = 1, *extra: str, here: bool = False,
             **kw) -> subprocess.CompletedProcess:
    """``mgdata generate`` of jar task 0 (``here``: in this process, for input refused up front)."""
    run = mgdata_here if here else mgdata
    return run("generate", "--family", "jar", "--n", str(n), "--out", out, "--recipe", recipe, "--tasks", "0",
               "--workers", "1", *extra, **kw)


def files(root: Path) -> dict[str, bytes]:
    return {str(p.relative_to(root)): p.read_bytes() for p in sorted(root.rglob("*")) if p.is_file()}


@pytest.fixture(scope="module")
def demo(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path]:
    """A one-episode dataset (recipe, dataset) whose --out path holds rich markup: ``a[/x]b``."""
    base = tmp_path_factory.mktemp("demo")
    recipe = small_recipe(base / "recipe")
    out = base / "a[/x]b"
    proc = generate(out, recipe)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    assert f"dataset: {out} (1 of 1 kept episodes; 1 new from 1 attempts)" in proc.stdout  # printed literally
    return recipe, out


@pytest.fixture
def demo_copy(demo: tuple[Path, Path], tmp_path: Path) -> tuple[Path, Path]:
    recipe, out = demo
    shutil.copytree(out, tmp_path / "ds")
    return recipe, tmp_path / "ds"


# --- inputs are checked in the main process; the worker pool fails fast ----------------------------------

@pytest.fixture
def corrupt_grasps(tmp_path: Path) -> Path:
    folder = tmp_path / "grasps"
    shutil.copytree(grasps_dir(), folder)
    text = (folder / "jar.json").read_text()
    (folder / "jar.json").write_text(text[: len(text) // 2])
    return folder


def test_corrupt_grasp_file_with_two_workers_is_one_error(tmp_path: Path, corrupt_grasps: Path) -> None:
    project = tmp_path / "project"
    shutil.copytree(recipes_dir(), project / "recipes")
    shutil.copytree(corrupt_grasps, project / "grasps")
    out = tmp_path / "out"
    start = time.monotonic()
    proc = mgdata("generate", "--family", "jar", "--n", "2", "--workers", "2", "--out", out,
                  env={"MGDATA_ROOT": str(project)}, timeout=120)  # it hung forever before
    one_error(proc, str(project / "grasps" / "jar.json"))
    assert time.monotonic() - start < 60 and not out.exists()  # refused before anything was created


def test_worker_start_up_error_reaches_the_main_process(tmp_path: Path, corrupt_grasps: Path) -> None:
    """Bypassing the main-process checks: the workers' own start-up error ends the run (no respawn loop)."""
    config = WorkerConfig(recipes_dir() / "jar.toml", corrupt_grasps, tmp_path / "stage", 0, False,
                          VideoSettings())
    with AttemptPool(config, workers=2) as pool:
        pool.submit(0, 0)
        with pytest.raises(GraspDBError, match=r"jar\.json"):
            pool.next_done()


def test_a_worker_that_dies_ends_the_run(tmp_path: Path) -> None:
    config = WorkerConfig(recipes_dir() / "jar.toml", grasps_dir(), tmp_path / "stage", 0, False,
                          VideoSettings())
    with AttemptPool(config, workers=2) as pool:
        pool.submit(0, 0)
        deadline = time.monotonic() + 60
        while not mp.active_children() and time.monotonic() < deadline:
            time.sleep(0.05)
        for child in mp.active_children():
            os.kill(child.pid, signal.SIGKILL)
        with pytest.raises(WorkerError, match=r"a worker process died.*run the same command again"):
            pool.next_done()


# --- the recipe is checked whole before any dataset exists ----------------------------------------------

def test_misspelled_variation_knob_is_named_literally(tmp_path: Path) -> None:
    recipe = small_recipe(tmp_path / "r", ("lift_height = [0.05", "lift_heigth = [0.05"))
    out = tmp_path / "out"
    one_error(generate(out, recipe, here=True),
              "[variation] unknown key 'lift_heigth'; did you mean 'lift_height'?")
    assert not out.exists()


def test_missing_params_key_is_named(tmp_path: Path) -> None:
    recipe = small_recipe(tmp_path / "r", ("close_steps = 12", ""))
    one_error(generate(tmp_path / "out", recipe, here=True), "[params] missing key(s) 'close_steps'")
    assert not (tmp_path / "out").exists()


def test_wrong_types_in_the_recipe(tmp_path: Path) -> None:
    recipe = small_recipe(tmp_path / "r", ('cameras = ["front", "wrist"]', "cameras = 5"))
    one_error(generate(tmp_path / "out", recipe, here=True), "[tasks] cameras = 5: expected a subset of")
    recipe = small_recipe(tmp_path / "r2", ("carry_speed = 0.5", 'carry_speed = "fast"'))
    one_error(generate(tmp_path / "out", recipe, here=True),
              "carry_speed = 'fast': expected a number in [0.01, 1]")


def test_layout_no_draw_can_meet_is_one_line(tmp_path: Path) -> None:
    # the jar's region is 1 mm wide and the table's far edge: no draw places it
    recipe = small_recipe(tmp_path / "r", ("region = { x = [0.45, 0.58], y = [-0.15, 0.15] }",
                                           "region = { x = [1.30, 1.301], y = [0.0, 0.001] }"))
    one_error(generate(tmp_path / "out", recipe, here=True), "no draw of task 0 meets the layout rules")
    assert not (tmp_path / "out").exists()


def test_spec_formula_beyond_the_limits_is_refused_by_generate(tmp_path: Path) -> None:
    spec = tmp_path / "spec.toml"
    deep = "(" * 200 + "jar_upright" + ")" * 200
    spec.write_text(SPEC.read_text().replace('formula = "G jar_upright"', f'formula = "G {deep}"'))
    one_error(generate(tmp_path / "out", small_recipe(tmp_path / "r", spec=spec), here=True),
              "levels of nesting")
    assert not (tmp_path / "out").exists()


def test_family_name_with_markup_is_printed_literally() -> None:
    line = one_error(mgdata_here("generate", "--family", "a[/x]", "--n", "1"), "no recipe for family 'a[/x]'")
    # settings files such as sim.toml are no family recipes
    assert line.endswith(f"(family recipes: {', '.join(family_recipes())})")
    assert "sim" not in family_recipes() and "jar" in family_recipes()


@pytest.mark.parametrize("workers", ["0", "-1"])
def test_workers_below_one_is_refused(workers: str) -> None:
    proc = mgdata_here("generate", "--n", "1", "--workers", workers)
    one_error(proc, f"--workers must be at least 1, got {workers}")


# --- --out that cannot be written -------------------------------------------------------------------------

@pytest.mark.parametrize(("make", "fragment"), [
    (lambda tmp: (tmp / "file").write_text("x") and tmp / "file", "is a file, not a folder"),
    (lambda tmp: Path("/proc/mgdata-out"), "cannot create the folder"),
    (lambda tmp: Path("/dev/null/x"), "cannot create the folder (Not a directory)"),
])
def test_out_that_cannot_be_a_folder(tmp_path: Path, make, fragment: str) -> None:  # type: ignore[no-untyped-def]
    out = make(tmp_path)
    one_error(generate(out, small_recipe(tmp_path / "r"), here=True), f"--out {out}: {fragment}")


@pytest.fixture
def tmpfs(tmp_path: Path) -> Iterator[Path]:
    """A 192 KiB tmpfs (smaller than one small episode with its staging), unmounted afterwards."""
    mnt = tmp_path / "mnt"
    mnt.mkdir()
    if subprocess.run(["mount", "-t", "tmpfs", "-o", "size=192k", "tmpfs", str(mnt)],
                      capture_output=True).returncode != 0:
        pytest.skip("cannot mount a tmpfs here (needs root)")
    try:
        yield mnt
    finally:
        subprocess.run(["umount", "-l", str(mnt)], check=True)


def test_read_only_out(tmp_path: Path, tmpfs: Path) -> None:
    subprocess.run(["mount", "-o", "remount,ro", str(tmpfs)], check=True)
    one_error(generate(tmpfs / "ds", small_recipe(tmp_path / "r")), f"--out {tmpfs / 'ds'}: cannot create")
    one_error(generate(tmpfs, small_recipe(tmp_path / "r")), f"--out {tmpfs}: no permission to write")


def test_out_without_permission(tmp_path: Path) -> None:
    if os.geteuid() != 0:
        pytest.skip("needs root to run the command as another user")
    try:
        subprocess.run([sys.executable, "-c", "pass"], user=65534, capture_output=True, check=True)
    except (OSError, subprocess.CalledProcessError):
        pytest.skip("this interpreter cannot be run by an unprivileged user")
    cache = tmp_path / "cache"
    cache.mkdir(mode=0o777)
    os.chmod(tmp_path, 0o755)
    env = {"MGDATA_CACHE": str(cache)}
    proc = generate(tmp_path / "ds", small_recipe(tmp_path / "r"), env=env, user=65534)
    one_error(proc, "cannot create the folder (Permission denied)")


def test_disk_full_is_one_error_and_the_attempt_is_not_counted(tmp_path: Path, tmpfs: Path) -> None:
    recipe = small_recipe(tmp_path / "r")
    out = tmpfs / "ds"
    one_error(generate(out, recipe), "No space left on device", "run the same command again to resume")
    info = json.loads((out / "meta/info.json").read_text())
    assert info["total_episodes"] == 0 and not info["mgdata"]["attempts"]  # the failed attempt is not counted
    state = out / "meta/mgdata_generate.json"
    assert not state.exists() or json.loads(state.read_text())["next_draw"] in ({}, {"0": 0})
    subprocess.run(["mount", "-o", "remount,size=16m", str(tmpfs)], check=True)
    again = generate(out, recipe)  # room again: the same command resumes, the draw is attempted again
    assert again.returncode == 0, again.stdout + again.stderr
    assert "1 new from 1 attempts" in again.stdout
    info = json.loads((out / "meta/info.json").read_text())
    assert info["total_episodes"] == 1 and info["mgdata"]["attempts"] == 1  # yield 100 %, not 50 %
    assert mgdata("validate", out).returncode == 0


# --- resume: the identity lives in info.json; a stale state file is repaired -------------------------------

def test_resume_with_another_recipe_after_deleting_the_state_file(tmp_path: Path,
                                                                 demo_copy: tuple[Path, Path]) -> None:
    _, out = demo_copy
    (out / "meta/mgdata_generate.json").unlink()
    before = files(out)
    other = small_recipe(tmp_path / "other", ("carry_speed = 0.5", "carry_speed = 0.4"))
    one_error(generate(out, other, 2, here=True), str(out / "meta/info.json"), "inputs_digest=")
    assert files(out) == before  # nothing touched, nothing mixed


def test_stale_state_after_kill_before_save_is_repaired(demo_copy: tuple[Path, Path]) -> None:
    """A kill -9 after the last episode's commit but before the state's save leaves the state of the
    attempt before; the re-run (target already reached) repairs it."""
    recipe, out = demo_copy
    path = out / "meta/mgdata_generate.json"
    good = json.loads(path.read_text())
    assert good["next_draw"] == {"0": 1} and good["attempts"] == 1
    path.write_text(json.dumps(good | {"next_draw": {}, "attempts": 0}))
    proc = generate(out, recipe)
    assert proc.returncode == 0 and "target already reached" in proc.stdout, proc.stdout + proc.stderr
    assert json.loads(path.read_text()) == good


# --- the other commands -----------------------------------------------------------------------------------

def test_metrics_on_unreadable_records(tmp_path: Path) -> None:
    binary = tmp_path / "r.jsonl"
    binary.write_bytes(b"\xff\xfe{}\n")
    one_error(mgdata_here("metrics", binary), f"{binary}: not a UTF-8 text file")
    one_error(mgdata_here("metrics", tmp_path), f"{tmp_path}: is a folder")


@pytest.mark.parametrize(("key", "value"), [("total_episodes", "x"), ("fps", "20"), ("features", []),
                                            ("total_frames", None), ("splits", 1)])
def test_info_with_wrong_typed_fields(demo_copy: tuple[Path, Path], key: str, value: object) -> None:
    _, out = demo_copy
    path = out / "meta/info.json"
    path.write_text(json.dumps(json.loads(path.read_text()) | {key: value}))
    one_error(mgdata_here("info", out), f"{path}: {key} = {value!r} has the wrong type")
    check = mgdata_here("validate", out)  # a corrupt dataset is an invalid one: exit 1 with its problem
    assert check.returncode == 1 and "has the wrong type" in check.stdout and "Traceback" not in check.stderr


def test_preview_of_a_camera_free_dataset_names_render(demo_copy: tuple[Path, Path], tmp_path: Path) -> None:
    """A state view (no videos) has nothing to tile: one error line that says how to get pictures."""
    _, out = demo_copy
    state = tmp_path / "state"
    assert mgdata_here("export", out, state, "--format", "state").returncode == 0
    result = mgdata_here("preview", state, "--out", tmp_path / "p.mp4")
    one_error(result, "no cameras (camera-free) to preview")
    assert not (tmp_path / "p.mp4").exists()


def test_validate_exit_codes(demo_copy: tuple[Path, Path], tmp_path: Path) -> None:
    _, out = demo_copy
    assert mgdata_here("validate", out).returncode == 0
    one_error(mgdata_here("validate", tmp_path / "nothing"), "no such dataset folder")


def test_sweep_other_commands(tmp_path: Path) -> None:
    """Found by the hostile sweep: each was a traceback or a silent success."""
    one_error(mgdata_here("generate", "--n", "1", "--recipe", tmp_path), f"recipe {tmp_path}: cannot be read")
    one_error(mgdata_here("generate", "--n", "1", "--tasks", "3-1"), "--tasks '3-1': expected 'all' or ids")
    one_error(mgdata_here("preview", tmp_path / "nothing"), "no such dataset folder")
    one_error(mgdata_here("grasps", "list", "--dir", tmp_path / "nothing"), "no such grasp database folder")
