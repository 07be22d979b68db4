"""Resume checks what it appends to (issue 26 §3): a dataset whose files no longer match the checksums in
``info.json`` is refused by every writer that would append to it, by ``info``, ``render`` and ``merge``,
with one error naming the file and nothing written; ``mgdata validate --repair`` copies the intact episodes
into a new dataset that validates and that ``generate`` resumes."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

from mgdata.errors import DatasetError
from mgdata.record.integrity import check_intact, damaged_files
from mgdata.record.reader import DatasetReader
from mgdata.record.synthetic import SYNTHETIC_SPEC, synthetic_episode, synthetic_schema
from mgdata.record.validate import validate_dataset
from mgdata.record.writer import DatasetWriter
from tests.helpers.generate import jar_recipe

MGDATA = str(Path(sys.executable).parent / "mgdata")


def mgdata(*args: object) -> subprocess.CompletedProcess:
    return subprocess.run([MGDATA, *map(str, args)], capture_output=True, text=True, timeout=600,
                          env=os.environ | {"LP_NUM_THREADS": "1"})


def one_error(proc: subprocess.CompletedProcess, *fragments: str) -> str:
    assert proc.returncode == 2, proc.stdout + proc.stderr
    assert "Traceback" not in proc.stderr
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: "), proc.stderr
    for fragment in fragments:
        assert fragment in lines[0], lines[0]
    return lines[0]


def files(root: Path) -> dict[str, bytes]:
    return {str(p.relative_to(root)): p.read_bytes() for p in sorted(root.rglob("*")) if p.is_file()}


def synthetic(root: Path, episodes: int = 3) -> Path:
    """A dataset of ``episodes`` short synthetic episodes, one per data/episodes file."""
    schema = synthetic_schema(cameras=("front", "wrist"), size=32)
    with DatasetWriter.create(root, schema, spec=SYNTHETIC_SPEC, episodes_per_file=1) as writer:
        for k in range(episodes):
            ep = synthetic_episode(schema, length=12, seed=k, draw_index=k)
            for frame in ep.frames():
                writer.add_frame(frame)
            writer.end_episode(ep.meta)
    return root


def truncate(path: Path, size: int = 1000) -> None:
    with open(path, "r+b") as f:
        f.truncate(size)


def test_an_intact_dataset_passes_and_every_damage_is_named(tmp_path: Path) -> None:
    root = synthetic(tmp_path / "ds")
    check_intact(root)
    data = root / "data/chunk-000/file-001.parquet"
    assert data.exists()
    truncate(data)
    (root / "videos/observation.images.wrist/chunk-000/file-000.mp4").unlink()
    assert [(d.rel, d.problem.split()[0]) for d in damaged_files(root)] == [
        ("data/chunk-000/file-001.parquet", "content"),
        ("videos/observation.images.wrist/chunk-000/file-000.mp4", "missing")]
    with pytest.raises(DatasetError, match=r"file-001.parquet: content differs .*\(and 1 more damaged files\)"
                       r"; nothing was written\. .*mgdata validate --repair"):
        check_intact(root)


def test_a_writer_does_not_append_to_a_damaged_dataset(tmp_path: Path) -> None:
    root = synthetic(tmp_path / "ds")
    truncate(root / "data/chunk-000/file-002.parquet")
    before = files(root)
    with pytest.raises(DatasetError, match=r"file-002\.parquet: content differs"):
        DatasetWriter.open(root)
    assert files(root) == before and not (root / ".mgdata").exists()  # nothing written, no lock left


def test_info_render_and_merge_refuse_a_damaged_dataset(tmp_path: Path) -> None:
    root = synthetic(tmp_path / "ds")
    assert mgdata("info", root).returncode == 0
    truncate(root / "meta/episodes/chunk-000/file-000.parquet")
    before = files(root)
    one_error(mgdata("info", root), "meta/episodes/chunk-000/file-000.parquet: content differs")
    one_error(mgdata("render", root, "--out", tmp_path / "r"), "file-000.parquet: content differs",
              "nothing was rendered")
    one_error(mgdata("merge", root, "--out", tmp_path / "m"), "file-000.parquet: content differs",
              "nothing was merged")
    assert files(root) == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["ds"]


def test_repair_copies_the_intact_episodes(tmp_path: Path) -> None:
    root = synthetic(tmp_path / "ds", episodes=4)
    intact = DatasetReader(root)
    truncate(root / "data/chunk-000/file-001.parquet")            # episode 1
    (root / "meta/episodes/chunk-000/file-003.parquet").write_bytes(b"junk")  # episode 3
    out = tmp_path / "fixed"
    proc = mgdata("validate", "--repair", root, "--out", out)
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.strip() == f"wrote {out}: 2 intact episodes copied; dropped 1, 3 (2 damaged files)"
    assert validate_dataset(out).problems == []
    fixed = DatasetReader(out)
    assert [r.meta.seed for r in fixed.records()] == [intact.record(k).meta.seed for k in (0, 2)]
    for new, old in ((0, 0), (1, 2)):
        a, b = fixed.episode(new), intact.episode(old)
        for column in ("state", "action", "labels", "dfa_state", "violated", "success", "timestamp"):
            assert (getattr(a, column) == getattr(b, column)).all(), column
        assert (fixed.frames(new, "front") == intact.frames(old, "front")).all()
    one_error(mgdata("validate", "--repair", root, "--out", out), "already exists")
    one_error(mgdata("validate", "--repair", root), "--repair and --out go together")



@pytest.mark.slow  # two small generate runs: ~75 s here
def test_generate_refuses_to_resume_onto_damage_and_resumes_the_repaired_dataset(tmp_path: Path) -> None:
    """The issue's case: a finished dataset's data file truncated to 1,000 bytes, then generate asked for
    one more episode: one error naming the file, exit 2, nothing written; after --repair it resumes."""
    recipe = jar_recipe(tmp_path / "recipe")
    out = tmp_path / "jar"
    args = ("generate", "--family", "jar", "--recipe", recipe, "--tasks", "0", "--workers", "1")
    first = mgdata(*args, "--n", 1, "--out", out)
    assert first.returncode == 0, first.stdout + first.stderr
    data = out / "data/chunk-000/file-000.parquet"
    truncate(data)
    before = files(out)
    one_error(mgdata(*args, "--n", 2, "--out", out), f"{data}: content differs", "nothing was written")
    assert files(out) == before
    fixed = tmp_path / "fixed"
    repaired = mgdata("validate", "--repair", out, "--out", fixed)
    assert repaired.returncode == 0, repaired.stderr
    assert "0 intact episodes copied; dropped 0" in repaired.stdout, repaired.stdout
    again = mgdata(*args, "--n", 1, "--out", fixed)
    assert again.returncode == 0, again.stdout + again.stderr
    assert validate_dataset(fixed).problems == []
    assert DatasetReader(fixed).num_episodes == 1
