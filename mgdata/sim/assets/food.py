"""Food items: small solid primitives that fit inside a jar, bowl or container.

Frame: origin at the bottom centre, +Z up. Kinds: ``cherry`` (sphere), ``cookie`` (flat cylinder), ``candy``
(box), ``olive`` (ellipsoid), ``nugget`` (lying capsule). ``geometry`` keys: ``width`` (largest horizontal
extent, m) and ``height`` (m), so a family can check the item fits through a mouth and under a lid.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from mgdata.sim.assets.model import Geom, ObjectModel, with_masses

COLOURS = {
    "cherry": (0.62, 0.05, 0.10, 1.0),
    "cookie": (0.76, 0.55, 0.30, 1.0),
    "candy": (0.95, 0.45, 0.70, 1.0),
    "olive": (0.35, 0.45, 0.12, 1.0),
    "nugget": (0.85, 0.62, 0.25, 1.0),
}


def _shape(kind: str, rng: np.random.Generator) -> tuple[Geom, tuple[float, float, float], float]:
    """The item's geom, its bounding-box extents and its width (largest horizontal extent)."""
    if kind == "cherry":
        r = float(rng.uniform(0.010, 0.014))
        return Geom("body", "sphere", (r,), pos=(0.0, 0.0, r)), (2 * r, 2 * r, 2 * r), 2 * r
    if kind == "cookie":
        r, h = float(rng.uniform(0.014, 0.019)), float(rng.uniform(0.004, 0.006))
        return Geom("body", "cylinder", (r, h), pos=(0.0, 0.0, h)), (2 * r, 2 * r, 2 * h), 2 * r
    if kind == "candy":
        hx, hy, hz = (float(v) for v in rng.uniform(0.007, 0.012, size=3))
        geom = Geom("body", "box", (hx, hy, hz), pos=(0.0, 0.0, hz))
        return geom, (2 * hx, 2 * hy, 2 * hz), 2 * float(np.hypot(hx, hy))
    if kind == "olive":
        a, c = float(rng.uniform(0.008, 0.010)), float(rng.uniform(0.011, 0.014))
        return Geom("body", "ellipsoid", (a, a, c), pos=(0.0, 0.0, c)), (2 * a, 2 * a, 2 * c), 2 * a
    if kind == "nugget":
        r, h = float(rng.uniform(0.007, 0.009)), float(rng.uniform(0.006, 0.010))
        geom = Geom("body", "capsule", (r, h), pos=(0.0, 0.0, r), quat=(0.7071068, 0.0, 0.7071068, 0.0))
        return geom, (2 * (h + r), 2 * r, 2 * r), 2 * (h + r)
    raise ValueError(kind)


def food_builder(kind: str) -> Callable[[str, int, np.random.Generator], ObjectModel]:
    """The builder of one food kind (registered per kind in the library)."""

    def build(name: str, seed: int, rng: np.random.Generator) -> ObjectModel:
        geom, size, width = _shape(kind, rng)
        height = size[2]
        mass = float(rng.uniform(0.005, 0.025))
        return ObjectModel(
            name=name,
            category="food",
            seed=seed,
            params={"mass": mass, "width": width, "height": height},
            size=size,
            mass=mass,
            friction=0.8,
            rgba=COLOURS[kind],
            geometry={"width": width, "height": height, "kind": kind},
            geoms=with_masses((geom,), mass),
        )

    return build
