"""docs/new-family.md followed once: a family that lives only in ``tests/families/toy_lift`` (a skeleton and
a recipe, nothing under ``mgdata/``) is found through ``mgdata --root`` and gives a kept demonstration."""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

from tests.helpers.repo import REPO, family_root, generate_in_root

TOY = REPO / "tests" / "families" / "toy_lift"


def test_a_family_outside_mgdata_generates_a_kept_demo(tmp_path: Path) -> None:
    out = tmp_path / "toy"
    run = generate_in_root(family_root(tmp_path, "toy_lift"), "toy_lift", 1, out)
    assert run.returncode == 0, run.stdout + run.stderr
    info = json.loads((out / "meta" / "info.json").read_text())
    assert info["total_episodes"] == 1
    assert info["mgdata"]["generator"]["family"] == "toy_lift"


def test_a_family_from_another_distribution_is_found_by_its_entry_points(tmp_path: Path) -> None:
    """The same family packaged as a distribution (``mytoys``) declaring ``mgdata.families`` and
    ``mgdata.recipes`` entry points: found without ``--root``."""
    site = tmp_path / "site"
    package = site / "mytoys"
    shutil.copytree(TOY / "recipes", package / "recipes")
    (package / "__init__.py").write_text("")
    (package / "recipes" / "__init__.py").write_text("")
    shutil.copy(TOY / "skeletons" / "toy_lift.py", package / "toy_lift.py")
    info = site / "mytoys-1.0.dist-info"
    info.mkdir()
    (info / "METADATA").write_text("Metadata-Version: 2.1\nName: mytoys\nVersion: 1.0\n")
    (info / "entry_points.txt").write_text('[mgdata.families]\ntoy_lift = mytoys.toy_lift\n\n'
                                           '[mgdata.recipes]\nmytoys = mytoys.recipes\n')
    env = {**{k: v for k, v in os.environ.items() if k != "MGDATA_ROOT"}, "PYTHONPATH": str(site)}
    code = ("from mgdata.skeleton.skeleton import available_skeletons, load_family_recipe\n"
            "from mgdata.tasks.recipe import family_recipes\n"
            "recipe = load_family_recipe('toy_lift')\n"
            "print(recipe.skeleton, 'toy_lift' in available_skeletons(), 'toy_lift' in family_recipes())\n")
    run = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env, timeout=120,
                         cwd=tmp_path)
    assert run.returncode == 0, run.stderr
    assert run.stdout.split() == ["toy_lift", "True", "True"]
