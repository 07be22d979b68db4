"""A content-addressed chunk store: byte strings that share long runs are stored once per distinct chunk.

The compiled models of the locked scenarios are ~5.8 MB of MJB each and mostly the same bytes (the Panda's
meshes, the table, the shared object meshes and textures), shifted by whatever differs between scenes. Each
string is cut where a rolling hash of its last :data:`WINDOW` bytes has its top :data:`MASK_BITS` bits zero
(content-defined chunking), so a cut depends only on the bytes around it and an insertion or a changed
array moves the cuts near it only; chunks are :data:`MIN_CHUNK` … :data:`MAX_CHUNK` bytes (about 32 KiB on
average). A chunk is stored as ``<store>/<sha[:2]>/<sha>.gz`` (gzip level 6, mtime 0), named by the SHA-256
of its uncompressed bytes, written atomically; the string is the concatenation of its chunks in order::

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
_P = 0x9E3779B97F4A7C15  # odd multiplier of the polynomial hash (mod 2**64)
_GEAR = np.array(
    [int.from_bytes(hashlib.sha256(bytes([i])).digest()[:8], "little") for i in range(256)], dtype=np.uint64
)


def cut_points(data: bytes) -> list[int]:
    """End offsets of the chunks of ``data`` (the last is ``len(data)``; none for empty data)."""
    n = len(data)
    if n == 0:
        return []
    x = _GEAR[np.frombuffer(data, dtype=np.uint8)]
    with np.errstate(over="ignore"):
        # H_i = sum_{k<WINDOW} x_{i-k} P^k  (mod 2**64), from prefix sums of x_j P^-j
        powers = _powers(_P, n)
        inverse = _powers(pow(_P, -1, 1 << 64), n)
        prefix = np.cumsum(x * inverse, dtype=np.uint64)
        lagged = np.concatenate([np.zeros(WINDOW, np.uint64), prefix[:-WINDOW]]) if n > WINDOW else 0
        rolling = (prefix - lagged) * powers
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


def _powers(base: int, n: int) -> np.ndarray:
    """``base**i mod 2**64`` for i in 0 … n-1 (uint64; numpy's integer products wrap)."""
    out = np.full(n, base, dtype=np.uint64)
    out[0] = 1
    return np.cumprod(out, dtype=np.uint64)


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
