"""All-or-nothing updates of a dataset's files (the commit protocol).

Parquet and mp4 files cannot be appended in place, so appending an episode writes *new versions* of the
files it touches (data file, one video file per camera, episodes file, tasks, stats, info) into
``<root>/.mgdata/pending/``, fsyncs them, and then writes the manifest ``pending/COMMIT`` (atomically, by
rename): **that rename is the commit point**. The new versions are then renamed over the old ones and the
pending folder is removed.

After a crash: no manifest → the pending files are an uncommitted leftover and are deleted on the next
:func:`recover`; a manifest → the commit happened and :func:`recover` finishes the renames (roll forward).
Read-only tools (reader, validator) use :class:`FileView`, which sees the committed state in both cases
without changing anything.
"""

from __future__ import annotations

import contextlib
import fcntl
import hashlib
import json
import os
import shutil
from pathlib import Path

from mgdata.errors import DatasetError
from mgdata.lock import FileLock
from mgdata.record.layout import WORK_DIR

MANIFEST = "COMMIT"


def work_dir(root: Path) -> Path:
    return root / WORK_DIR


def pending_dir(root: Path) -> Path:
    return work_dir(root) / "pending"


def fsync_file(path: Path) -> None:
    """Flush ``path`` to disk."""
    fd = os.open(path, os.O_RDONLY)
    try:
        os.fsync(fd)
    finally:
        os.close(fd)


def sha256_file(path: Path) -> str:
    """Hex SHA-256 of a file's bytes (recorded per dataset file in ``info.json`` to detect corruption)."""
    digest = hashlib.sha256()
    with open(path, "rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()


def _fsync_dir(path: Path) -> None:
    with contextlib.suppress(OSError):  # some filesystems refuse directory fsync
        fsync_file(path)


def _read_manifest(root: Path) -> list[tuple[str, str]] | None:
    path = pending_dir(root) / MANIFEST
    if not path.exists():
        return None
    try:
        entries = json.loads(path.read_text())["files"]
        return [(str(rel), str(tmp)) for rel, tmp in entries]
    except (ValueError, KeyError, TypeError) as err:
        raise DatasetError(f"{path}: unreadable commit manifest ({err})") from err


class Transaction:
    """New versions of dataset files, installed together by :meth:`commit`.

    Example::

        tx = Transaction(root)
        tx.path("meta/info.json").write_text("{...}")
        tx.commit()
    """

    def __init__(self, root: Path) -> None:
        self.root = root
        self._dir = pending_dir(root)
        if self._dir.exists():
            shutil.rmtree(self._dir)
        self._dir.mkdir(parents=True)
        self._files: dict[str, Path] = {}

    def path(self, rel: str) -> Path:
        """Where to write the new version of ``rel`` (relative to the dataset root)."""
        if rel not in self._files:
            self._files[rel] = self._dir / f"{len(self._files):04d}.{Path(rel).name}"
        return self._files[rel]

    @property
    def files(self) -> dict[str, Path]:
        """Relative path → where its new version is being written."""
        return dict(self._files)

    def commit(self) -> None:
        """Make every written file durable, record the manifest (commit point), then install the files."""
        self.prepare()
        _install(self.root)

    def prepare(self) -> None:
        """Everything up to and including the commit point; :func:`recover` or :meth:`commit` installs."""
        for tmp in self._files.values():
            if not tmp.exists():
                raise DatasetError(f"internal: {tmp} was reserved but never written")
            fsync_file(tmp)
        manifest = self._dir / (MANIFEST + ".tmp")
        entries = [[rel, tmp.name] for rel, tmp in self._files.items()]
        manifest.write_text(json.dumps({"files": entries}))
        fsync_file(manifest)
        os.replace(manifest, self._dir / MANIFEST)
        _fsync_dir(self._dir)

    def abort(self) -> None:
        shutil.rmtree(self._dir, ignore_errors=True)


def _install(root: Path) -> None:
    entries = _read_manifest(root) or []
    pdir = pending_dir(root)
    touched: set[Path] = set()
    for rel, tmp in entries:
        src = pdir / tmp
        if src.exists():  # absent when a previous install got this far already
            dst = root / rel
            dst.parent.mkdir(parents=True, exist_ok=True)
            os.replace(src, dst)
            touched.add(dst.parent)
    for folder in sorted(touched):
        _fsync_dir(folder)
    shutil.rmtree(pdir)


def recover(root: Path) -> bool:
    """Finish a committed-but-uninstalled update, or drop an uncommitted one; True if one was finished."""
    pdir = pending_dir(root)
    if not pdir.exists():
        return False
    if _read_manifest(root) is not None:
        _install(root)
        return True
    shutil.rmtree(pdir)
    return False


class FileView:
    """Read-only view of a dataset's committed files (follows a pending manifest if there is one).

    Attributes:
        pending_commit: a committed update is not yet installed (a writer was killed mid-install).
        leftovers: uncommitted work left by an interrupted writer (ignored; removed on the next open).
    """

    def __init__(self, root: Path) -> None:
        self.root = root
        entries = _read_manifest(root)
        self.pending_commit = entries is not None
        self._map = {rel: pending_dir(root) / tmp for rel, tmp in entries or []}
        wdir = work_dir(root)
        self.leftovers = sorted(
            str(p.relative_to(root)) for p in (wdir.iterdir() if wdir.is_dir() else [])
            if p.name != "lock" and not (p == pending_dir(root) and self.pending_commit)
        )

    @property
    def writer_active(self) -> bool:
        """A writer holds the dataset's lock right now (its work area is in use, not a leftover)."""
        lock = work_dir(self.root) / "lock"
        if not lock.exists():
            return False
        with open(lock) as f:
            try:
                fcntl.flock(f, fcntl.LOCK_SH | fcntl.LOCK_NB)
            except BlockingIOError:
                return True
            fcntl.flock(f, fcntl.LOCK_UN)
        return False

    def path(self, rel: str) -> Path:
        tmp = self._map.get(rel)
        return tmp if tmp is not None and tmp.exists() else self.root / rel

    def exists(self, rel: str) -> bool:
        return self.path(rel).exists()

    def glob(self, pattern: str) -> list[str]:
        """Relative paths matching ``pattern`` (committed files plus pending installs), sorted."""
        found = {str(p.relative_to(self.root)) for p in self.root.glob(pattern)}
        found |= {rel for rel in self._map if Path(rel).match(pattern) and self.path(rel).exists()}
        return sorted(found)


class WriterLock:
    """An exclusive lock on ``<root>/.mgdata/lock`` so two writers never append to one dataset (a
    :class:`mgdata.lock.FileLock`: it dies with its process)."""

    def __init__(self, root: Path) -> None:
        work_dir(root).mkdir(parents=True, exist_ok=True)
        self._lock_dir = work_dir(root)
        message = f"{root}: the dataset is open for writing by another process"
        self._lock: FileLock | None = FileLock(work_dir(root) / "lock", message, DatasetError)

    def release(self) -> None:
        """Drop the lock and its file, and the work area if nothing else is in it."""
        if self._lock is not None:
            self._lock.release(unlink=True)
            self._lock = None
            with contextlib.suppress(OSError):
                self._lock_dir.rmdir()
