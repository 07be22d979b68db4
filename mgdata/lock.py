"""One writer per output: an exclusive ``flock`` on a lock file, held for as long as a command writes.

The kernel drops a ``flock`` when its process ends, however it ends (``kill -9`` included), so a lock can
never be left stale: the file may stay behind, but the next command locks it again. Every command that
writes an output takes one: ``generate`` and ``render`` on their dataset (``<dataset>/.mgdata/lock``, through
:class:`mgdata.record.commit.WriterLock`), ``merge``, ``render``, ``scenarios build`` and ``eval`` on their
``--out`` folder (:func:`output_lock`: ``.<name>.lock`` beside it, so it also guards an output that does not
exist yet or is renamed into place at the end), ``grasps generate`` and ``grasps validate`` on each category
file they rewrite. A second writer is refused at once, with one error.

Example::

    with output_lock(Path("datasets/jar_merged"), "--out"):
        ...  # write datasets/jar_merged
"""

from __future__ import annotations

import contextlib
import fcntl
import os
from collections.abc import Iterator
from pathlib import Path
from typing import IO

from mgdata.errors import MgdataError, OutputError


class FileLock:
    """An exclusive, non-blocking ``flock`` on ``path`` (created if missing).

    Raises:
        OutputError (or ``error``): another process holds it (``message`` says which output).
    """

    def __init__(self, path: Path, message: str, error: type[MgdataError] = OutputError) -> None:
        self.path = Path(path)
        while True:
            f: IO[str] = open(self.path, "a")  # noqa: SIM115 (held open for the lock's lifetime)
            try:
                fcntl.flock(f, fcntl.LOCK_EX | fcntl.LOCK_NB)
            except BlockingIOError:
                f.close()
                raise error(message) from None
            # the holder before us may have unlinked the file after we opened it: lock the file on disk
            try:
                same = os.fstat(f.fileno()).st_ino == os.stat(self.path).st_ino
            except FileNotFoundError:
                same = False
            if same:
                self._file: IO[str] | None = f
                return
            f.close()

    def release(self, *, unlink: bool = False) -> None:
        """Drop the lock (``unlink``: also remove the file, while still holding it)."""
        if self._file is None:
            return
        if unlink:
            with contextlib.suppress(FileNotFoundError):
                self.path.unlink()
        fcntl.flock(self._file, fcntl.LOCK_UN)
        self._file.close()
        self._file = None


def lock_path(out: Path) -> Path:
    """The lock file of an output folder: ``.<name>.lock`` beside it."""
    out = Path(out)
    return out.parent / f".{out.name}.lock"


@contextlib.contextmanager
def output_lock(out: Path, option: str = "--out") -> Iterator[None]:
    """Hold the one-writer lock of the output folder ``out`` (module docstring) for the ``with`` block."""
    out = Path(out)
    try:
        out.parent.mkdir(parents=True, exist_ok=True)
        lock = FileLock(lock_path(out), f"{option} {out}: open for writing by another process (one writer "
                                        "per output; wait for it to finish or stop it)")
    except OSError as err:
        raise OutputError(f"{option} {out}: cannot create its lock file ({err.strerror or err})") from None
    try:
        yield
    finally:
        lock.release(unlink=True)
