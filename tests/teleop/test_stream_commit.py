"""The raw leader stream is committed in the same transaction as its episode: a writer that dies after the
commit point leaves both (rolled forward on the next open), one that dies before it leaves neither."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from mgdata.errors import DatasetError
from mgdata.record.commit import Transaction
from mgdata.record.synthetic import SYNTHETIC_SPEC, synthetic_episode, synthetic_schema
from mgdata.record.validate import validate_dataset
from mgdata.record.writer import DatasetWriter
from mgdata.teleop.stream import LeaderStream, stream_path, stream_rel

SCHEMA = synthetic_schema(cameras=("front",), size=32)


def _stream() -> LeaderStream:
    rng = np.random.default_rng(0)
    return LeaderStream("gello", "{}", "jar", 0, 0, np.linspace(0, 1, 9), rng.integers(0, 4096, (9, 8)),
                        np.arange(0, 9, 3), np.zeros(3, bool), np.zeros(3, bool))


def _stage(writer: DatasetWriter, tmp_path: Path) -> Path:
    stager = writer.stager(tmp_path / "staged")
    ep = synthetic_episode(SCHEMA, 12, seed=1)
    for frame in ep.frames():
        stager.add_frame(frame)
    stager.end_episode(ep.meta)
    return stager.path


class _Died(BaseException):
    """The writer process dies here."""


def _append_and_die(root: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch, after_commit_point: bool
                    ) -> bytes:
    data = _stream().to_bytes()
    writer = DatasetWriter.create(root, SCHEMA, spec=SYNTHETIC_SPEC)
    staged = _stage(writer, tmp_path)

    def dying_commit(tx: Transaction) -> None:
        assert stream_rel(0) in tx.files  # the stream is one of the transaction's files
        if after_commit_point:
            tx.prepare()  # the manifest (with the stream in it) is written, nothing installed
        raise _Died

    monkeypatch.setattr(Transaction, "commit", dying_commit)
    with pytest.raises(_Died):
        writer.append_staged(staged, extra=lambda ep: {stream_rel(ep): data})
    monkeypatch.undo()
    writer.close()
    return data


def test_death_after_the_commit_point_keeps_episode_and_stream(tmp_path: Path,
                                                              monkeypatch: pytest.MonkeyPatch) -> None:
    root = tmp_path / "ds"
    data = _append_and_die(root, tmp_path, monkeypatch, after_commit_point=True)
    assert not stream_path(root, 0).exists()  # not installed yet
    assert validate_dataset(root).episodes == 1  # committed: readers see it through the manifest
    with DatasetWriter.open(root) as writer:  # rolls forward
        assert writer.num_episodes == 1
    assert stream_path(root, 0).read_bytes() == data
    assert LeaderStream.load(stream_path(root, 0)).ticks.shape == (9, 8)
    assert validate_dataset(root).ok


def test_death_before_the_commit_point_leaves_neither(tmp_path: Path,
                                                      monkeypatch: pytest.MonkeyPatch) -> None:
    root = tmp_path / "ds"
    _append_and_die(root, tmp_path, monkeypatch, after_commit_point=False)
    with DatasetWriter.open(root) as writer:  # drops the uncommitted files
        assert writer.num_episodes == 0
    assert not (root / "meta" / "teleop").exists()
    assert validate_dataset(root).ok


def test_an_extra_file_never_overwrites_a_dataset_file(tmp_path: Path) -> None:
    with DatasetWriter.create(tmp_path / "ds", SCHEMA, spec=SYNTHETIC_SPEC) as writer:
        staged = _stage(writer, tmp_path)
        with pytest.raises(DatasetError, match=r"meta/info\.json already exists"):
            writer.append_staged(staged, extra=lambda ep: {"meta/info.json": b"{}"})
        assert writer.num_episodes == 0
    assert validate_dataset(tmp_path / "ds").ok
