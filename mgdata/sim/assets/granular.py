"""Particle models: ``liquid/water_NN`` (50–100 spheres of 5–6 mm) and ``dust/layer_NN`` (visual specks).

Liquid frame: the placement point is a point on the floor of the container cavity the liquid fills; the
spheres are packed into that cavity when the scene is built. Dust frame: the placement point is the centre of
the dusty patch on the surface it lies on; ``geometry`` gives the patch's ``half_x``/``half_y`` (m).
"""

from __future__ import annotations

import numpy as np

from mgdata.sim.assets.model import ObjectModel, Particles

WATER_RGBA = (0.25, 0.55, 0.95, 0.85)
DUST_RGBA = (0.47, 0.42, 0.36, 1.0)
WATER_DENSITY = 1000.0


def build_liquid(name: str, seed: int, rng: np.random.Generator) -> ObjectModel:
    """A liquid of 50–100 spheres (radius 5–6 mm, water density)."""
    count = int(rng.integers(50, 101))
    radius = float(rng.uniform(0.005, 0.006))
    mass = WATER_DENSITY * 4.0 / 3.0 * np.pi * radius**3
    return ObjectModel(
        name=name, category="liquid", seed=seed, params={"count": count, "radius": radius},
        size=(2 * radius, 2 * radius, 2 * radius), mass=count * mass, friction=0.1, rgba=WATER_RGBA,
        geometry={"count": count, "radius": radius}, geoms=(),
        particles=Particles("liquid", count, radius, mass=mass),
    )


def build_dust(name: str, seed: int, rng: np.random.Generator) -> ObjectModel:
    """A dusty patch of 30–60 flat specks (radius 4–6 mm) over a 6–12 cm rectangle."""
    count = int(rng.integers(30, 61))
    radius = float(rng.uniform(0.004, 0.006))
    half_x, half_y = (float(v) for v in rng.uniform(0.03, 0.06, size=2))
    layout = rng.uniform([-half_x, -half_y], [half_x, half_y], size=(count, 2))
    return ObjectModel(
        name=name, category="dust", seed=seed,
        params={"count": count, "radius": radius, "half_x": half_x, "half_y": half_y},
        size=(2 * half_x, 2 * half_y, 0.001), mass=0.0, friction=0.0, rgba=DUST_RGBA,
        geometry={"count": count, "radius": radius, "half_x": half_x, "half_y": half_y}, geoms=(),
        particles=Particles("dust", count, radius, layout=layout),
    )
