"""``--per-task`` quotas and ``--family all``: the cursor passes over full tasks; the dataset does not
depend on the number of workers; the suite resumes as a whole."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from mgdata.generate.resume import DrawCursor
from mgdata.generate.run import GenerateJob, generate
from mgdata.record.reader import DatasetReader
from tests.helpers.cli import mgdata_here
from tests.helpers.generate import low_yield_recipe
from tests.helpers.record import dataset_files

MGDATA = [str(Path(sys.executable).parent / "mgdata")]


def test_the_cursor_passes_over_full_tasks_and_keeps_the_order_of_the_others() -> None:
    cursor = DrawCursor((3, 1, 2))
    assert [cursor.take(skip={1}) for _ in range(4)] == [(3, 0), (2, 0), (3, 1), (2, 1)]
    assert cursor.take() == (1, 0)
    assert cursor.take(skip={1, 2, 3}) is None and cursor.peek(skip={3, 2, 1}) is None


@settings(max_examples=80, deadline=None)
@given(st.lists(st.integers(0, 9), min_size=1, max_size=5, unique=True), st.data())
def test_running_ahead_of_the_quota_adds_only_skippable_attempts(tasks: list[int],
                                                                 data: st.DataObject) -> None:
    """A cursor that learns late that a task is full (workers run ahead) makes the attempts of the exact one
    plus some of the full task's, which the run then drops: the others come in the same order."""
    full_after = {t: data.draw(st.integers(0, 4)) for t in tasks}  # draws of a task until it is full
    exact, late = DrawCursor(tuple(tasks)), DrawCursor(tuple(tasks))
    lag = data.draw(st.integers(0, 3))
    exact_seq, late_seq = [], []
    for _ in range(25):
        full = {t for t in tasks if exact.next_draw[t] >= full_after[t]}
        if (nxt := exact.take(skip=full)) is not None:
            exact_seq.append(nxt)
        known = {t for t in tasks if late.next_draw[t] >= full_after[t] + lag}
        if (nxt := late.take(skip=known)) is not None:
            late_seq.append(nxt)
    kept = [a for a in late_seq if a[1] < full_after[a[0]]]
    n = min(len(kept), len(exact_seq))
    assert kept[:n] == exact_seq[:n]


def test_per_task_and_n_exclude_each_other_and_all_takes_no_recipe(tmp_path: Path) -> None:
    for args, message in ((["--per-task", "2", "--n", "3"], "exclude each other"),
                          (["--family", "all", "--recipe", str(tmp_path / "x.toml")], "--recipe"),
                          (["--per-task", "0"], "--per-task must be at least 1")):
        proc = mgdata_here("generate", "--out", tmp_path / "o", *args)  # refused up front: in this process
        assert proc.returncode == 2 and proc.stderr.startswith("error: ") and message in proc.stderr, \
            (args, proc.stderr)
        assert "Traceback" not in proc.stderr
    assert not (tmp_path / "o").exists()


@pytest.mark.slow
def test_per_task_quota_is_met_and_independent_of_workers(tmp_path: Path) -> None:
    recipe = low_yield_recipe(tmp_path)
    outs = []
    for workers in (1, 2):
        out = tmp_path / f"w{workers}"
        summary = generate(GenerateJob(family="jar", n=1, out=out, tasks=(0, 1), per_task=2, workers=workers,
                                       recipe=recipe, max_attempts=16))
        assert summary.stopped == "target reached" and summary.target == 4, summary
        outs.append(out)
    metas = [r.meta for r in DatasetReader(outs[0]).records()]
    assert sorted(m.task_id for m in metas) == [0, 0, 1, 1]
    assert dataset_files(outs[0]) == dataset_files(outs[1])


@pytest.mark.slow
def test_family_all_builds_one_dataset_per_family_and_resumes(tmp_path: Path) -> None:
    cmd = [*MGDATA, "generate", "--family", "all", "--per-task", "1", "--tasks", "0", "--workers", "1",
           "--out", str(tmp_path / "suite")]
    first = subprocess.run(cmd, capture_output=True, text=True, timeout=900)
    assert first.returncode == 0, first.stdout + first.stderr
    assert "jar" in first.stdout and "1/1" in first.stdout and "failure stages" in first.stdout
    assert DatasetReader(tmp_path / "suite" / "jar").num_episodes == 1
    again = subprocess.run(cmd, capture_output=True, text=True, timeout=900)
    assert again.returncode == 0 and "already" in again.stdout, again.stdout + again.stderr  # (wrapped cell)
    assert DatasetReader(tmp_path / "suite" / "jar").num_episodes == 1
