"""``--shard i/N`` + ``mgdata merge``: the merged shards are the single run's dataset, byte for byte."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

from mgdata.errors import DatasetError
from mgdata.generate.merge import merge_shards
from mgdata.generate.run import GenerateJob, failed_path, generate
from tests.helpers.cli import mgdata_here
from tests.helpers.generate import low_yield_recipe
from tests.helpers.record import dataset_files

MGDATA = [str(Path(sys.executable).parent / "mgdata")]


def test_shard_needs_a_quota_and_a_valid_index(tmp_path: Path) -> None:
    for args, message in ((["--shard", "0/2"], "--shard needs --per-task"),
                          (["--shard", "2/2", "--per-task", "1"], "0 <= i < N"),
                          (["--shard", "x", "--per-task", "1"], "expected i/N")):
        proc = mgdata_here("generate", "--out", tmp_path / "o", *args)  # refused up front: in this process
        assert proc.returncode == 2 and message in proc.stderr and "Traceback" not in proc.stderr, proc.stderr
    proc = subprocess.run([*MGDATA, "merge", str(tmp_path / "nosuch"), "--out", str(tmp_path / "m")],
                          capture_output=True, text=True, timeout=120)  # and once as a real process
    assert proc.returncode == 2 and "no such dataset folder" in proc.stderr
    assert not (tmp_path / "o").exists() and not (tmp_path / "m").exists()


@pytest.mark.slow
def test_merged_shards_equal_one_run(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    recipe = low_yield_recipe(tmp_path)
    common = {"family": "jar", "n": 1, "tasks": (0, 1, 2), "per_task": 2, "recipe": recipe,
              "keep_failed": True}
    whole = tmp_path / "whole"
    assert generate(GenerateJob(out=whole, **common)).stopped == "target reached"
    shards = []
    for i in range(2):
        out = tmp_path / f"shard{i}"
        assert generate(GenerateJob(out=out, shard=(i, 2), **common)).stopped == "target reached"
        shards.append(out)
    merged = tmp_path / "merged"
    assert merge_shards(shards, merged) == 6
    assert dataset_files(merged) == dataset_files(whole)
    assert dataset_files(failed_path(merged)) == dataset_files(failed_path(whole))
    with pytest.raises(DatasetError, match=r"overlap|shares tasks"):
        merge_shards([shards[0], shards[0]], tmp_path / "twice")

    # Stopped between its two renames (negatives in place, the dataset not yet): the re-run completes it.
    again = tmp_path / "again"
    real_replace = os.replace

    def stop_before_out(src: os.PathLike, dst: os.PathLike) -> None:
        if Path(dst) == again:
            raise KeyboardInterrupt
        real_replace(src, dst)

    monkeypatch.setattr("mgdata.generate.merge.os.replace", stop_before_out)
    with pytest.raises(KeyboardInterrupt):
        merge_shards(shards, again)
    assert failed_path(again).exists() and not again.exists()
    monkeypatch.undo()
    assert merge_shards(shards, again) == 6
    assert dataset_files(again) == dataset_files(whole)
    assert dataset_files(failed_path(again)) == dataset_files(failed_path(whole))
    assert not list(tmp_path.glob("*.partial"))
