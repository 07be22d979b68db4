"""Feature statistics in LeRobot's format (min, max, mean, std, count, q01 … q99).

Per episode, numeric features are exact over the episode's frames, per dimension (quantiles as
``np.quantile``'s default linear method). Dataset-level numeric stats are merged from the episodes' stats
one episode at a time (:func:`merge_stats`, so appending an episode costs the same at episode 1 and
episode 10,000): count, min and max exactly, mean and std by the pairwise update of Chan et al. (equal to
the direct computation up to float rounding), and each quantile as the count-weighted mean of the
episodes' quantiles (an approximation: exact quantiles of a growing dataset need all of its values).
Images: from 256-bin histograms per channel, which are exact for uint8 and cheap to add up across
episodes, so dataset image stats stay exact; values are normalised to [0, 1] and shaped (3, 1, 1), and
``count`` is the number of frames, as LeRobot writes them.
"""

from __future__ import annotations

from collections.abc import Mapping

import cv2
import numpy as np

QUANTILES: tuple[tuple[str, float], ...] = (("q01", 0.01), ("q10", 0.10), ("q50", 0.50), ("q90", 0.90),
                                            ("q99", 0.99))
STAT_KEYS: tuple[str, ...] = ("min", "max", "mean", "std", "count", *tuple(k for k, _ in QUANTILES))

FeatureStats = dict[str, np.ndarray]


def rgb_histogram(image: np.ndarray) -> np.ndarray:
    """(3, 256) int64 per-channel histogram of an (H, W, 3) uint8 image."""
    return np.stack([cv2.calcHist([image], [c], None, [256], [0, 256]).ravel() for c in range(3)]).astype(
        np.int64)


def _lerp(a: np.ndarray, b: np.ndarray, t: np.ndarray) -> np.ndarray:
    """numpy's quantile interpolation, reproduced so histogram quantiles equal ``np.quantile``."""
    diff = b - a
    out = a + diff * t
    return np.where(t >= 0.5, b - diff * (1 - t), out)


def histogram_quantile(hist: np.ndarray, q: float) -> float:
    """The ``q`` quantile of the values 0..255 counted by ``hist`` (same as ``np.quantile`` on them)."""
    cum = np.cumsum(hist)
    n = int(cum[-1])
    pos = (n - 1) * q
    lo = int(np.floor(pos))
    hi = min(lo + 1, n - 1)
    v_lo = float(np.searchsorted(cum, lo, side="right"))
    v_hi = float(np.searchsorted(cum, hi, side="right"))
    return float(_lerp(np.float64(v_lo), np.float64(v_hi), np.float64(pos - lo)))


def image_stats(hist: np.ndarray, frames: int) -> FeatureStats:
    """Stats of an image feature from its (3, 256) histogram summed over ``frames`` frames."""
    values = np.arange(256, dtype=np.float64)
    n = hist.sum(axis=1).astype(np.float64)
    mean = (hist * values).sum(axis=1) / n
    var = (hist * (values[None, :] - mean[:, None]) ** 2).sum(axis=1) / n
    nonzero = hist > 0
    stats = {
        "min": np.array([np.flatnonzero(nonzero[c])[0] for c in range(3)], np.float64),
        "max": np.array([np.flatnonzero(nonzero[c])[-1] for c in range(3)], np.float64),
        "mean": mean,
        "std": np.sqrt(var),
    }
    for key, q in QUANTILES:
        stats[key] = np.array([histogram_quantile(hist[c], q) for c in range(3)])
    out = {k: (v / 255.0).reshape(3, 1, 1) for k, v in stats.items()}
    out["count"] = np.array([frames], np.int64)
    return {k: out[k] for k in STAT_KEYS}


def numeric_stats(values: np.ndarray) -> FeatureStats:
    """Stats of a numeric feature from its (T, width) values (bools count as 0/1)."""
    x = np.asarray(values, dtype=np.float64).reshape(len(values), -1)
    stats = {
        "min": x.min(axis=0),
        "max": x.max(axis=0),
        "mean": x.mean(axis=0),
        "std": x.std(axis=0),
        "count": np.array([len(x)], np.int64),
    }
    qs = np.quantile(x, [q for _, q in QUANTILES], axis=0)
    for (key, _), row in zip(QUANTILES, qs, strict=True):
        stats[key] = row
    return {k: stats[k] for k in STAT_KEYS}


def merge_stats(total: FeatureStats | None, episode: FeatureStats) -> FeatureStats:
    """Numeric dataset stats after one more episode, from the stats so far (``None``: no episode yet) and
    the episode's own (module docstring). Folding the episodes' stats in episode order always gives the
    same bytes, so a resumed writer and the validator reproduce the stored dataset stats exactly."""
    if total is None:
        return {k: np.asarray(episode[k]).copy() for k in STAT_KEYS}
    na, nb = float(total["count"][0]), float(episode["count"][0])
    n = na + nb
    mean_a, mean_b = np.asarray(total["mean"], np.float64), np.asarray(episode["mean"], np.float64)
    delta = mean_b - mean_a
    m2 = (np.asarray(total["std"], np.float64) ** 2 * na + np.asarray(episode["std"], np.float64) ** 2 * nb
          + delta**2 * (na * nb / n))
    out = {
        "min": np.minimum(total["min"], episode["min"]),
        "max": np.maximum(total["max"], episode["max"]),
        "mean": mean_a + delta * (nb / n),
        "std": np.sqrt(m2 / n),
        "count": np.array([int(na + nb)], np.int64),
    }
    for key, _ in QUANTILES:
        out[key] = (np.asarray(total[key], np.float64) * na + np.asarray(episode[key], np.float64) * nb) / n
    return {k: out[k] for k in STAT_KEYS}


def stats_to_json(stats: Mapping[str, FeatureStats]) -> dict[str, dict[str, list]]:
    """``{feature: {stat: nested list}}`` as written to ``meta/stats.json``."""
    return {key: {name: value.tolist() for name, value in fs.items()} for key, fs in stats.items()}


def stats_from_json(data: Mapping[str, Mapping[str, list]]) -> dict[str, FeatureStats]:
    return {key: {name: np.asarray(v) for name, v in fs.items()} for key, fs in data.items()}
