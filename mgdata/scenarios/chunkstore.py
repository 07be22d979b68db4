"""A content-addressed chunk store: byte strings that share long runs are stored once per distinct chunk.

The compiled models of the locked scenarios are ~5.8 MB of MJB each and mostly the same bytes (the Panda's
meshes, the table, the shared object meshes and textures), shifted by whatever differs between scenes. Each
string is cut where a rolling hash of its last :data:`WINDOW` bytes has its top :data:`MASK_BITS` bits zero
(content-defined chunking, :func:`cut_points`), so a cut depends only on the bytes around it and an
insertion or a changed array moves the cuts near it only; chunks are :data:`MIN_CHUNK` … :data:`MAX_CHUNK`
bytes (about 32 KiB on average). A chunk is stored as ``<store>/<sha[:2]>/<sha>.gz`` (gzip level 6,
mtime 0), named by the SHA-256 of its uncompressed bytes and written atomically; the string is the
concatenation of its chunks in order::

    data = b"".join(gzip.decompress((store / h[:2] / f"{h}.gz").read_bytes()) for h in chunks)

Cutting is deterministic (the hash's constants derive from SHA-256, not a random generator), so the same
string gives the same chunks in any process.

Example::

    chunks = put(Path("scenarios/chunks"), mjb)
    assert get(Path("scenarios/chunks"), chunks) == mjb
"""

from __future__ import annotations

import gzip
import hashlib
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from mgdata.atomic import write_bytes_atomic
from mgdata.errors import DatasetError

WINDOW = 48  # bytes the rolling hash sees
MASK_BITS = 15  # a cut where the hash's top 15 bits are zero: ~1 in 32 KiB positions
MIN_CHUNK, MAX_CHUNK = 8 << 10, 256 << 10  # bytes
_GEAR = np.array(
    [int.from_bytes(hashlib.sha256(bytes([i])).digest()[:8], "little") for i in range(256)], dtype=np.uint64
)


def cut_points(data: bytes) -> list[int]:
    """End offsets of the chunks of ``data`` (the last is ``len(data)``; none for empty data).

    The rolling hash after byte ``i`` is the moving sum ``H_i = sum(gear[b] for b in data[i-WINDOW+1 : i+1])
    mod 2**64`` of a fixed random 64-bit value per byte value (three vector passes over the string); byte
    ``i`` ends a chunk candidate where ``H_i``'s top :data:`MASK_BITS` bits are zero. Walking the candidates
    in order, one less than :data:`MIN_CHUNK` after the last cut is skipped, and a gap longer than
    :data:`MAX_CHUNK` is cut every :data:`MAX_CHUNK` bytes.
    """
    n = len(data)
    if n == 0:
        return []
    prefix = np.cumsum(_GEAR[np.frombuffer(data, dtype=np.uint8)], dtype=np.uint64)  # wraps mod 2**64
    rolling = prefix.copy()
    rolling[WINDOW:] -= prefix[:-WINDOW]
    candidates = np.flatnonzero((rolling >> np.uint64(64 - MASK_BITS)) == 0) + 1
    cuts: list[int] = []
    last = 0
    for c in candidates.tolist():
        if c - last < MIN_CHUNK:
            continue
        while c - last > MAX_CHUNK:
            last += MAX_CHUNK
            cuts.append(last)
        cuts.append(c)
        last = c
    while n - last > MAX_CHUNK:
        last += MAX_CHUNK
        cuts.append(last)
    if last != n:
        cuts.append(n)
    return cuts


def chunk_path(store: Path, sha: str) -> Path:
    return Path(store) / sha[:2] / f"{sha}.gz"


def put(store: Path, data: bytes) -> list[str]:
    """Store ``data``'s chunks that ``store`` lacks; returns the SHA-256 of each chunk, in order."""
    shas = []
    start = 0
    for end in cut_points(data):
        chunk = data[start:end]
        sha = hashlib.sha256(chunk).hexdigest()
        path = chunk_path(store, sha)
        if not path.is_file():  # a concurrent writer of the same chunk writes the same bytes
            write_bytes_atomic(path, gzip.compress(chunk, compresslevel=6, mtime=0))
        shas.append(sha)
        start = end
    return shas


def get(store: Path, chunks: Sequence[str]) -> bytes:
    """The string made of ``chunks``; :class:`DatasetError` if one is missing or its content differs."""
    parts = []
    for sha in chunks:
        path = chunk_path(store, sha)
        try:
            part = gzip.decompress(path.read_bytes())
        except (OSError, EOFError, gzip.BadGzipFile) as err:
            raise DatasetError(f"{path}: cannot read the chunk ({err})") from None
        if hashlib.sha256(part).hexdigest() != sha:
            raise DatasetError(f"{path}: the chunk's SHA-256 differs from its name")
        parts.append(part)
    return b"".join(parts)
