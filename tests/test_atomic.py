"""Atomic small-file writes and their clean-up after a kill."""

from __future__ import annotations

from pathlib import Path

from mgdata.atomic import remove_stale_temps, write_text_atomic


def test_stale_temp_files_of_a_killed_atomic_write_are_removed(tmp_path: Path) -> None:
    target = tmp_path / "state.json"
    write_text_atomic(target, "{}")
    (tmp_path / ".state.json.abc123.tmp").write_text("{\"half")  # what a kill -9 mid-write leaves
    (tmp_path / ".other.json.x.tmp").write_text("")
    remove_stale_temps(target)
    assert sorted(p.name for p in tmp_path.iterdir()) == [".other.json.x.tmp", "state.json"]
