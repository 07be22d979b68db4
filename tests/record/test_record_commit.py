"""The commit protocol: nothing is visible before the commit point, everything after it."""

from __future__ import annotations

from pathlib import Path

from mgdata.record.commit import FileView, Transaction, pending_dir, recover
from mgdata.record.validate import validate_dataset
from mgdata.record.writer import DatasetWriter


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
