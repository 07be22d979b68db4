"""Procedural textures, generated in code from a seed (no image files, nothing downloaded).

Every texture is a tileable (periodic) RGB image built from band-limited noise: white noise from
``numpy.random.default_rng(seed)`` filtered in the Fourier domain, so it wraps at the edges and repeats
without seams. Surfaces of the room (table, floor, walls) are coloured images; object textures are grey
"finish" images (values around 0.8–1.0) that MuJoCo multiplies with each geom's own colour, so a model keeps
its colour and gains a surface.

Same kind, size and seed → the same bytes (tested). Example::

    img = texture("wood", 256, seed=3, colour=(0.62, 0.47, 0.32))   # (256, 256, 3) uint8
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

RGB = tuple[float, float, float]


def noise(size: int, rng: np.random.Generator, scale: float, *, stretch: float = 1.0) -> np.ndarray:
    """Periodic smooth noise (size, size), zero mean, unit standard deviation.

    ``scale`` is the feature size as a fraction of the image; ``stretch`` > 1 elongates features along the
    image's x axis (wood grain, brushed metal).
    """
    white = rng.standard_normal((size, size))
    fy = np.fft.fftfreq(size)[:, None]
    fx = np.fft.fftfreq(size)[None, :] * stretch
    radius = np.sqrt(fx * fx + fy * fy) * size * scale
    field = np.real(np.fft.ifft2(np.fft.fft2(white) * np.exp(-0.5 * radius * radius)))
    std = float(field.std())
    return (field - field.mean()) / (std if std > 0 else 1.0)


def _to_image(grey: np.ndarray, colour: RGB) -> np.ndarray:
    rgb = np.clip(grey[..., None] * np.asarray(colour, dtype=np.float64), 0.0, 1.0)
    return np.round(rgb * 255.0).astype(np.uint8)


def _wood(size: int, rng: np.random.Generator) -> np.ndarray:
    """Grain along x: growth rings bent by low-frequency noise, plus fine fibres."""
    warp = noise(size, rng, 0.25, stretch=6.0)
    y = np.arange(size)[:, None] / size
    rings = 0.5 + 0.5 * np.sin(2.0 * np.pi * (9.0 * y + 0.35 * warp))
    fibres = noise(size, rng, 0.004, stretch=20.0)
    return 0.80 + 0.16 * rings ** 2 + 0.04 * fibres


def _planks(size: int, rng: np.random.Generator) -> np.ndarray:
    """Laminate floor: four staggered planks per tile, each its own shade and grain, dark joints."""
    grain = _wood(size, rng)
    rows = 4
    row = (np.arange(size)[:, None] * rows) // size
    offset = (row % 2) * (size // 2)
    x = (np.arange(size)[None, :] + offset) % size
    plank = row * 2 + (x >= size // 2)
    shade = 0.86 + 0.14 * rng.random(2 * rows)
    img = grain * shade[plank]
    joint = ((np.arange(size)[:, None] * rows) % size < 2) | ((x % (size // 2)) < 2)
    return np.where(joint, 0.55, img)


def _plaster(size: int, rng: np.random.Generator) -> np.ndarray:
    return 0.93 + 0.035 * noise(size, rng, 0.06) + 0.015 * noise(size, rng, 0.01)


def _ceramic(size: int, rng: np.random.Generator) -> np.ndarray:
    """Glaze: nearly even, faint speckles."""
    speckle = rng.random((size, size)) < 0.004
    return np.where(speckle, 0.80, 0.97 + 0.02 * noise(size, rng, 0.08))


def _brushed(size: int, rng: np.random.Generator) -> np.ndarray:
    return 0.90 + 0.07 * noise(size, rng, 0.003, stretch=40.0)


def _plastic(size: int, rng: np.random.Generator) -> np.ndarray:
    return 0.95 + 0.03 * noise(size, rng, 0.03)


def _cardboard(size: int, rng: np.random.Generator) -> np.ndarray:
    """Paper fibres and darker flecks."""
    flecks = noise(size, rng, 0.005) > 2.2
    return np.where(flecks, 0.72, 0.90 + 0.05 * noise(size, rng, 0.02) + 0.03 * noise(size, rng, 0.004))


def _fabric(size: int, rng: np.random.Generator) -> np.ndarray:
    """Open-cell foam / cloth: a fine weave with dark pores."""
    i = np.arange(size)
    wave = np.sin(2 * np.pi * i * 24 / size)
    weave = 0.5 + 0.25 * (wave[:, None] + wave[None, :])
    pores = noise(size, rng, 0.008) > 1.6
    return np.where(pores, 0.62, 0.86 + 0.10 * weave)


def _food(size: int, rng: np.random.Generator) -> np.ndarray:
    """Mottled, as a baked or fresh surface."""
    return 0.86 + 0.08 * noise(size, rng, 0.05) + 0.04 * noise(size, rng, 0.012)


KINDS: dict[str, Callable[[int, np.random.Generator], np.ndarray]] = {
    "wood": _wood, "planks": _planks, "plaster": _plaster, "ceramic": _ceramic, "metal": _brushed,
    "plastic": _plastic, "cardboard": _cardboard, "fabric": _fabric, "food": _food,
}
"""Texture kinds by name: grey images in [0, 1] before colouring."""


def texture(kind: str, size: int, seed: int, colour: RGB = (1.0, 1.0, 1.0)) -> np.ndarray:
    """A tileable (size, size, 3) uint8 image of ``kind`` (:data:`KINDS`) in ``colour``."""
    if kind not in KINDS:
        raise ValueError(f"unknown texture kind {kind!r}; kinds: {', '.join(KINDS)}")
    rng = np.random.default_rng([seed, size, *kind.encode()])
    return _to_image(KINDS[kind](size, rng), colour)
