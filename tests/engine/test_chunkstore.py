"""The content-addressed chunk store: cuts match a plain-Python reading of the rolling hash, strings come back
byte for byte, an insertion changes only the chunks near it, and a damaged chunk is an error."""

from __future__ import annotations

import gzip
import hashlib
import random
from pathlib import Path

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from mgdata.errors import DatasetError
from mgdata.scenarios import chunkstore
from mgdata.scenarios.chunkstore import MASK_BITS, MAX_CHUNK, MIN_CHUNK, WINDOW, cut_points, get, put

M64 = (1 << 64) - 1


def _reference_cuts(data: bytes, mask_bits: int, lo: int, hi: int) -> list[int]:
    """The documented rule, byte by byte: H_i = sum of gear[b] over the last WINDOW bytes, mod 2**64."""
    gear = [int.from_bytes(hashlib.sha256(bytes([i])).digest()[:8], "little") for i in range(256)]
    cuts, last = [], 0
    for i in range(len(data)):
        h = sum(gear[b] for b in data[max(0, i - WINDOW + 1) : i + 1]) & M64
        end = i + 1
        if h >> (64 - mask_bits) == 0 and end - last >= lo:
            while end - last > hi:
                last += hi
                cuts.append(last)
            cuts.append(end)
            last = end
    while len(data) - last > hi:
        last += hi
        cuts.append(last)
    if last != len(data):
        cuts.append(len(data))
    return cuts


@settings(max_examples=25, deadline=None)
@given(data=st.binary(min_size=0, max_size=700))
def test_cuts_follow_the_reference_rule(data: bytes) -> None:
    # small constants so that short strings have several cuts (the rule is the same at any scale)
    with pytest.MonkeyPatch.context() as m:
        m.setattr(chunkstore, "MASK_BITS", 3)
        m.setattr(chunkstore, "MIN_CHUNK", 5)
        m.setattr(chunkstore, "MAX_CHUNK", 40)
        assert cut_points(data) == _reference_cuts(data, 3, 5, 40)


def test_strings_round_trip_and_an_insertion_changes_few_chunks(tmp_path: Path) -> None:
    rng = random.Random(7)
    a = rng.randbytes(3_000_000)
    b = a[:1_234_567] + b"inserted" + a[1_234_567:]
    ca, cb = put(tmp_path, a), put(tmp_path, b)
    assert get(tmp_path, ca) == a and get(tmp_path, cb) == b
    sizes = [y - x for x, y in zip([0, *cut_points(a)], cut_points(a), strict=False)]
    assert all(MIN_CHUNK <= s <= MAX_CHUNK for s in sizes[:-1])
    assert 2 ** MASK_BITS / 3 < len(a) / len(ca) < 3 * 2**MASK_BITS  # about one cut per 32 KiB
    assert len(set(cb) - set(ca)) <= 2  # the chunk holding the insertion (and at most its neighbour)
    stored = {p.name for p in tmp_path.rglob("*.gz")}
    assert stored == {f"{h}.gz" for h in {*ca, *cb}}
    assert put(tmp_path, a) == ca  # deterministic; nothing new written


def test_a_damaged_or_missing_chunk_is_an_error(tmp_path: Path) -> None:
    data = random.Random(1).randbytes(200_000)
    chunks = put(tmp_path, data)
    path = chunkstore.chunk_path(tmp_path, chunks[1])
    path.write_bytes(gzip.compress(b"other bytes"))
    with pytest.raises(DatasetError, match="SHA-256 differs from its name"):
        get(tmp_path, chunks)
    path.unlink()
    with pytest.raises(DatasetError, match="cannot read the chunk"):
        get(tmp_path, chunks)
