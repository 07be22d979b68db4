"""The commit protocol: nothing is visible before the commit point, everything after it."""

from __future__ import annotations

import os
import signal
from pathlib import Path

import pytest

from mgdata.record.commit import FileView, Transaction, pending_dir, recover
from mgdata.record.synthetic import SYNTHETIC_SPEC
from mgdata.record.validate import validate_dataset
from mgdata.record.writer import DatasetWriter
from tests.helpers.record import SMALL, small_episodes, write_episodes


def _tx(root: Path, text: str) -> Transaction:
    tx = Transaction(root)
    tx.path("meta/info.json").write_text(text)
    tx.path("data/chunk-000/file-000.parquet").write_text(text * 2)
    return tx


def test_commit_installs_every_file(tmp_path: Path) -> None:
    _tx(tmp_path, "v1").commit()
    assert (tmp_path / "meta/info.json").read_text() == "v1"
    assert (tmp_path / "data/chunk-000/file-000.parquet").read_text() == "v1v1"
    assert not pending_dir(tmp_path).exists() and recover(tmp_path) is False


def test_before_the_commit_point_nothing_changes(tmp_path: Path) -> None:
    _tx(tmp_path, "v1").commit()
    _tx(tmp_path, "v2")  # files written, never committed (the writer died)
    view = FileView(tmp_path)
    assert not view.pending_commit and view.leftovers == [".mgdata/pending"]
    assert view.path("meta/info.json").read_text() == "v1"
    assert recover(tmp_path) is False and not pending_dir(tmp_path).exists()
    assert (tmp_path / "meta/info.json").read_text() == "v1"


def test_after_the_commit_point_everything_changes(tmp_path: Path) -> None:
    _tx(tmp_path, "v1").commit()
    tx = _tx(tmp_path, "v2")
    tx.prepare()  # the manifest is written; the writer dies before installing
    view = FileView(tmp_path)
    assert view.pending_commit and view.leftovers == []
    assert view.path("meta/info.json").read_text() == "v2"  # readers see the committed state
    assert (tmp_path / "meta/info.json").read_text() == "v1"
    assert view.glob("data/*/*.parquet") == ["data/chunk-000/file-000.parquet"]
    assert recover(tmp_path) is True
    assert (tmp_path / "data/chunk-000/file-000.parquet").read_text() == "v2v2"
    assert not FileView(tmp_path).pending_commit


def test_abort_discards(tmp_path: Path) -> None:
    tx = _tx(tmp_path, "v1")
    tx.abort()
    assert not (tmp_path / "meta").exists() and not pending_dir(tmp_path).exists()


def test_an_active_writer_is_told_apart_from_leftovers(small_dataset: Path) -> None:
    assert not FileView(small_dataset).writer_active
    with DatasetWriter.open(small_dataset):
        assert FileView(small_dataset).writer_active
        assert validate_dataset(small_dataset).notes == [
            "a writer is appending to this dataset right now; validated up to its last commit"]
    assert not FileView(small_dataset).writer_active and validate_dataset(small_dataset).notes == []


def test_ctrl_c_during_a_commit_lands_after_it(tmp_path: Path, monkeypatch) -> None:
    """A Ctrl-C that arrives while an episode is being committed neither splits the commit nor leaves the
    writer's memory behind the disk (``close`` would then write stale totals into info.json)."""
    real_commit = Transaction.commit

    def interrupted_commit(self: Transaction) -> None:
        os.kill(os.getpid(), signal.SIGINT)  # delivered while the commit runs
        real_commit(self)

    root = tmp_path / "ds"
    episodes = small_episodes()
    writer = DatasetWriter.create(root, SMALL, spec=SYNTHETIC_SPEC)
    write_episodes(writer, episodes[:1])
    monkeypatch.setattr(Transaction, "commit", interrupted_commit)
    with pytest.raises(KeyboardInterrupt):
        write_episodes(writer, episodes[1:2])
    monkeypatch.undo()
    assert writer.num_episodes == 2  # the episode committed, and memory knows it
    writer.close()
    report = validate_dataset(root)
    assert report.problems == [] and DatasetWriter.open(root).num_episodes == 2
