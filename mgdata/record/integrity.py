"""A dataset's files against the SHA-256 checksums its ``info.json`` records (``mgdata.sha256``).

Every commit records the checksum of each file it writes, so a file changed afterwards (a truncated copy, a
bad disk, a hand edit) no longer matches. Every command that appends to a dataset or reads one to make
another checks first and stops on damage with one error naming the file, before writing anything:
``generate`` and ``render`` resuming (:meth:`mgdata.record.writer.DatasetWriter.open`), ``render``'s source,
``merge``'s shards; ``info`` checks too. ``mgdata validate --repair DATASET --out NEW`` copies the intact
episodes into a new dataset (:mod:`mgdata.record.repair`). The check reads every byte once: ~1 s per GB
here (``benchmarks/bench_integrity.py``).

Example::

    check_intact(Path("datasets/jar"))    # DatasetError: datasets/jar/data/chunk-000/file-000.parquet: …
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from mgdata.errors import DatasetError
from mgdata.record import layout
from mgdata.record.commit import FileView, sha256_file
from mgdata.record.metafiles import read_info


@dataclass(frozen=True)
class Damage:
    """A recorded file that is missing or whose bytes differ from its recorded checksum."""

    rel: str
    problem: str


def damaged_files(root: Path) -> list[Damage]:
    """Every file ``info.json`` records a checksum for that is missing or differs, in path order (the
    committed state: a pending commit's new versions count)."""
    if not Path(root).is_dir():
        raise DatasetError(f"{root}: no such dataset folder")
    view = FileView(Path(root))
    recorded = read_info(view.path(layout.INFO_PATH))["mgdata"].get("sha256") or {}
    found = []
    for rel, digest in sorted(recorded.items()):
        path = view.path(rel)
        if not path.is_file():
            found.append(Damage(rel, "missing"))
        elif sha256_file(path) != digest:
            found.append(Damage(rel, f"content differs from the SHA-256 recorded in {layout.INFO_PATH}"))
    return found


def check_intact(root: Path, doing: str = "nothing was written") -> None:
    """Raise :class:`DatasetError` naming the first damaged file of the dataset at ``root`` (and how many
    there are), with the way to recover; ``doing`` says what the command did about it."""
    root = Path(root)
    damage = damaged_files(root)
    if not damage:
        return
    more = f" (and {len(damage) - 1} more damaged files)" if len(damage) > 1 else ""
    raise DatasetError(f"{root / damage[0].rel}: {damage[0].problem}{more}; {doing}. Copy the intact "
                       f"episodes into a new dataset with: mgdata validate --repair {root} --out NEW")
