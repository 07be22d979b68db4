"""Exact statistics: histogram-based image stats equal numpy's over the raw pixels."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from mgdata.record.stats import (
    QUANTILES,
    histogram_quantile,
    image_stats,
    merge_stats,
    numeric_stats,
    rgb_histogram,
)

images = arrays(np.uint8, st.tuples(st.integers(1, 4), st.integers(1, 9), st.integers(1, 9), st.just(3)),
                elements=st.integers(0, 255))


@settings(max_examples=60, deadline=None)
@given(st.lists(st.integers(0, 255), min_size=1, max_size=300), st.floats(0, 1))
def test_histogram_quantile_equals_numpy(values: list[int], q: float) -> None:
    hist = np.bincount(values, minlength=256)
    assert histogram_quantile(hist, q) == np.quantile(np.asarray(values, np.float64), q)


@settings(max_examples=40, deadline=None)
@given(images)
def test_image_stats_equal_pixel_stats(frames: np.ndarray) -> None:
    hist = sum(rgb_histogram(np.ascontiguousarray(f)) for f in frames)
    got = image_stats(hist, len(frames))
    pixels = frames.reshape(-1, 3).astype(np.float64) / 255.0
    assert got["count"].tolist() == [len(frames)]
    for key, fn in [("min", np.min), ("max", np.max), ("mean", np.mean), ("std", np.std)]:
        np.testing.assert_allclose(got[key][:, 0, 0], fn(pixels, axis=0), rtol=1e-12, atol=1e-12)
    for key, q in QUANTILES:
        np.testing.assert_allclose(got[key][:, 0, 0], np.quantile(pixels * 255.0, q, axis=0) / 255.0,
                                   rtol=1e-12, atol=1e-12)
        assert got[key].shape == (3, 1, 1)


def test_numeric_stats_shapes_and_values() -> None:
    x = np.random.default_rng(0).normal(size=(50, 8)).astype(np.float32)
    s = numeric_stats(x)
    assert all(v.shape == (8,) for k, v in s.items() if k != "count")
    assert s["count"].tolist() == [50]
    np.testing.assert_allclose(s["q50"], np.median(x.astype(np.float64), axis=0))
    b = numeric_stats(np.array([[True], [False], [True], [True]]))
    assert b["mean"].tolist() == [0.75] and b["min"].tolist() == [0.0] and b["max"].tolist() == [1.0]


@settings(max_examples=60, deadline=None)
@given(st.lists(arrays(np.float32, st.tuples(st.integers(1, 30), st.just(3)),
                       elements=st.floats(-100, 100, width=32)), min_size=1, max_size=6))
def test_merged_stats_equal_the_stats_of_all_frames(episodes: list[np.ndarray]) -> None:
    """Folding per-episode stats (what an append does) gives numpy's count, min, max, mean and std over all
    frames, and each quantile as the count-weighted mean of the episodes' quantiles."""
    merged = None
    for ep in episodes:
        merged = merge_stats(merged, numeric_stats(ep))
    assert merged is not None
    every = np.concatenate(episodes).astype(np.float64)
    assert merged["count"].tolist() == [len(every)]
    np.testing.assert_array_equal(merged["min"], every.min(axis=0))
    np.testing.assert_array_equal(merged["max"], every.max(axis=0))
    np.testing.assert_allclose(merged["mean"], every.mean(axis=0), rtol=1e-9, atol=1e-9)
    np.testing.assert_allclose(merged["std"], every.std(axis=0), rtol=1e-7, atol=1e-7)
    n = np.array([len(ep) for ep in episodes], np.float64)
    for key, q in QUANTILES:
        want = n @ np.stack([np.quantile(ep.astype(np.float64), q, axis=0) for ep in episodes]) / n.sum()
        np.testing.assert_allclose(merged[key], want, rtol=1e-9, atol=1e-9)


@settings(max_examples=60, deadline=None)
@given(st.dictionaries(st.text(min_size=1, max_size=12), st.text(max_size=8), max_size=12),
       st.dictionaries(st.text(max_size=6), st.integers() | st.text(max_size=5) | st.none(), max_size=4))
def test_info_json_is_written_as_json_dumps_writes_it(sums: dict[str, str], other: dict) -> None:
    """``dump_json`` writes the checksum block of info.json by hand (fast); the bytes are json.dumps's."""
    import json

    from mgdata.record.metafiles import dump_json

    info = {"codebase_version": "v3.0", **other, "mgdata": {"format": 1, "sha256": sums, "after": [1, 2]}}
    assert dump_json(info) == json.dumps(info, indent=4, ensure_ascii=False, allow_nan=False) + "\n"
