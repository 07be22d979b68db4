"""One import package: the wheel holds ``mgdata`` only, with the mapped folders and the data inside, and works
installed in a fresh venv outside the checkout."""

from __future__ import annotations

import os
import subprocess
import sys
import sysconfig
import tomllib
import zipfile
from pathlib import Path

import pytest

from tests.helpers.repo import REPO


def _declared() -> tuple[list[str], dict[str, str]]:
    tool = tomllib.loads((REPO / "pyproject.toml").read_text())["tool"]["setuptools"]
    return tool["packages"], tool["package-dir"]


def test_every_code_folder_is_a_declared_package() -> None:
    packages, mapped = _declared()
    folders = {"mgdata": "mgdata", **{folder: name for name, folder in mapped.items()}}
    found = set()
    for folder, name in folders.items():
        for init in sorted((REPO / folder).rglob("__init__.py")):
            rel = init.parent.relative_to(REPO / folder).parts
            found.add(".".join((name, *rel)))
    code = {p for p in packages if not p.startswith(("mgdata.recipes", "mgdata.grasps.data"))}
    assert found == code


def _run(cmd: list[str], cwd: Path, env: dict[str, str], timeout: int = 1800) -> subprocess.CompletedProcess:
    run = subprocess.run(cmd, cwd=cwd, env=env, capture_output=True, text=True, timeout=timeout)
    assert run.returncode == 0, f"{cmd}: {run.stdout[-2000:]}{run.stderr[-2000:]}"
    return run


@pytest.mark.slow
@pytest.mark.timeout(3600)
def test_the_wheel_installs_and_runs_outside_the_checkout(tmp_path: Path) -> None:
    """Build the wheel from the tracked files, install it with ``--no-deps`` into a fresh venv (no system
    site-packages) whose only other path is this venv's site-packages (a ``.pth``: the dependencies, not
    mgdata, whose editable finder is a ``.pth`` hook that a plain path entry does not run), then use it from
    an empty folder."""
    src = tmp_path / "src"
    files = subprocess.run(["git", "ls-files", "-co", "--exclude-standard"], cwd=REPO, capture_output=True,
                           text=True, check=True).stdout.split()
    for name in files:
        if (REPO / name).is_file() and not name.startswith("datasets/"):
            (src / name).parent.mkdir(parents=True, exist_ok=True)
            (src / name).write_bytes((REPO / name).read_bytes())
    env = {k: v for k, v in os.environ.items() if k not in ("MGDATA_ROOT", "PYTHONPATH")}
    _run([sys.executable, "-m", "pip", "wheel", "-q", "--no-deps", "-w", str(tmp_path / "dist"), str(src)],
         tmp_path, env)
    (wheel,) = (tmp_path / "dist").glob("mgdata-*.whl")
    names = zipfile.ZipFile(wheel).namelist()
    assert {n.split("/")[0] for n in names} == {"mgdata", wheel.name.split("-py3")[0] + ".dist-info"}
    for expected in ("mgdata/recipes/jar.toml", "mgdata/recipes/specs/jar.toml",
                     "mgdata/grasps/data/jar.json", "mgdata/skeletons/jar.py",
                     "mgdata/teleop/operator_page.html",
                     "mgdata/teleop/so101/so101_kinematics.xml", "mgdata/annotator/app.py"):
        assert expected in names
    listing = subprocess.run(["unzip", "-l", str(wheel)], capture_output=True, text=True, check=True).stdout
    assert "mgdata/recipes/lid.toml" in listing and "mgdata/grasps/data/lid.json" in listing

    venv = tmp_path / "venv"
    _run([sys.executable, "-m", "venv", "--without-pip", str(venv)], tmp_path, env)
    python = venv / "bin" / "python"
    _run([sys.executable, "-m", "pip", "--python", str(python), "install", "-q", "--no-deps", str(wheel)],
         tmp_path, env)
    purelib = subprocess.run([str(python), "-c", "import sysconfig; print(sysconfig.get_paths()['purelib'])"],
                             capture_output=True, text=True, check=True).stdout.strip()
    (Path(purelib) / "zz_dependencies.pth").write_text(sysconfig.get_paths()["purelib"] + "\n")

    work = tmp_path / "elsewhere"
    work.mkdir()
    mgdata = str(venv / "bin" / "mgdata")
    where = _run([str(python), "-c", "import mgdata.paths as p; print(p.recipes_dir())"], work, env).stdout
    assert where.strip() == str(Path(purelib) / "mgdata" / "recipes")
    for name in ("skeletons", "teleop", "annotator"):
        gone = subprocess.run([str(python), "-c", f"import {name}"], cwd=work, env=env, capture_output=True,
                              text=True)
        assert gone.returncode != 0 and "ModuleNotFoundError" in gone.stderr
    assert "Usage: mgdata annotate" in _run([mgdata, "annotate", "--help"], work, env).stdout
    assert "Usage: mgdata teleop" in _run([mgdata, "teleop", "--help"], work, env).stdout
    assert "tasks pass the initial-state gate" in _run([mgdata, "tasks", "lid"], work, env).stdout
    env["LP_NUM_THREADS"] = "1"
    _run([mgdata, "generate", "--family", "jar", "--n", "2", "--out", str(work / "jar")], work, env)
    assert (work / "jar" / "meta" / "info.json").is_file()
    assert len(list((work / "jar" / "data").rglob("*.parquet"))) == 1
