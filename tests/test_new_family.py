"""docs/new-family.md followed once: a family that lives only in ``tests/families/toy_lift`` (a skeleton and
a recipe, nothing under ``mgdata/``) is found through ``mgdata --root`` and gives a kept demonstration."""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

from mgdata.paths import grasps_dir, recipes_dir
from tests.helpers.repo import REPO

TOY = REPO / "tests" / "families" / "toy_lift"
MGDATA = [str(Path(sys.executable).with_name("mgdata"))]


def _root(tmp: Path) -> Path:
    """The user's root folder of docs/new-family.md: the shipped recipes and grasps, plus the new family."""
    root = tmp / "root"
    shutil.copytree(recipes_dir(), root / "recipes")
    shutil.copytree(TOY / "recipes", root / "recipes", dirs_exist_ok=True)
    shutil.copytree(TOY / "skeletons", root / "skeletons")
    (root / "grasps").symlink_to(grasps_dir())
    return root


def test_a_family_outside_mgdata_generates_a_kept_demo(tmp_path: Path) -> None:
    root = _root(tmp_path)
    env = {**{k: v for k, v in os.environ.items() if k != "MGDATA_ROOT"}, "LP_NUM_THREADS": "1"}
    out = tmp_path / "toy"
    run = subprocess.run([*MGDATA, "--root", str(root), "generate", "--family", "toy_lift", "--n", "1",
                          "--workers", "1", "--out", str(out)], capture_output=True, text=True, env=env,
                         timeout=600)
    assert run.returncode == 0, run.stdout + run.stderr
    info = json.loads((out / "meta" / "info.json").read_text())
    assert info["total_episodes"] == 1
    assert info["mgdata"]["generator"]["family"] == "toy_lift"
