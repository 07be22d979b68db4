"""Open revolved vessels: cups (tapered tumblers), mugs and teacups (with a handle at +X), bowls, plates.

Frame: origin at the bottom centre, +Z up; handles stick out along +X. Collision is exact analytic convex
parts (``shapes.vessel_geoms``) plus capsules for handles; the visual is a smooth surface of revolution.
``geometry`` keys: ``bottom_radius``, ``rim_radius``, ``height``, ``wall``, ``bottom`` (inside floor height);
handled kinds add ``handle_center`` (x, z) and ``handle_radius``. Every vessel has a round ``cavity``.
"""

from __future__ import annotations

import numpy as np

from mgdata.sim.assets.model import Cavity, Geom, ObjectModel, with_masses
from mgdata.sim.assets.shapes import arc_capsules, vessel_geoms

SECTORS = 16
CERAMIC = ((0.93, 0.93, 0.90, 1.0), (0.80, 0.25, 0.20, 1.0), (0.20, 0.40, 0.70, 1.0), (0.95, 0.80, 0.35, 1.0),
           (0.35, 0.60, 0.45, 1.0), (0.60, 0.45, 0.70, 1.0))


def _vessel(name: str, category: str, seed: int, rng: np.random.Generator, outer: np.ndarray, wall: float,
            bottom: float, mass: float, friction: float, handle: tuple[float, float, float] | None = None,
            params: dict[str, float] | None = None) -> ObjectModel:
    """Assemble a vessel model from its outer profile; ``handle`` = (centre x, centre z, arc radius)."""
    rgba = CERAMIC[int(rng.integers(len(CERAMIC)))]
    hulls, visual = vessel_geoms(outer, wall, bottom, SECTORS)
    parts: tuple[Geom, ...] = hulls
    rim_r, height = float(outer[-1, 0]), float(outer[-1, 1])
    size_x = 2 * max(outer[:, 0])
    top = outer[-1] - outer[-2]  # the outer wall just below the rim, from vertical (rad; > 0 flares outwards)
    geometry: dict[str, object] = {"bottom_radius": float(outer[0, 0]), "rim_radius": rim_r, "height": height,
                                   "wall": wall, "bottom": bottom,
                                   "rim_slope": float(np.arctan2(top[0], top[1]))}
    if handle is not None:
        cx, cz, hr = handle
        parts += arc_capsules((cx, cz), hr, 0.005, -np.pi / 2, np.pi / 2, 4, "handle_")
        size_x = max(outer[:, 0]) + cx + hr + 0.005
        geometry.update(handle_center=(cx, cz), handle_radius=hr)
    inner_floor = float(np.interp(bottom, outer[:, 1], outer[:, 0])) - wall
    return ObjectModel(
        name=name, category=category, seed=seed, params=dict(params or {}),
        size=(float(size_x), float(2 * max(outer[:, 0])), height), mass=mass, friction=friction, rgba=rgba,
        geometry=geometry,
        geoms=(*with_masses(parts, mass), Geom("visual", "mesh", mesh=visual, role="visual")),
        cavity=Cavity("round", floor_z=bottom, rim_z=height, radius_floor=inner_floor,
                      radius_rim=rim_r - wall),
    )


def build_cup(name: str, seed: int, rng: np.random.Generator) -> ObjectModel:
    """A tapered tumbler: bottom radius 2.6–3.0 cm, rim 3.2–3.6 cm, 8–11 cm tall, 60–150 g."""
    rb, rt, h = rng.uniform(0.026, 0.030), rng.uniform(0.032, 0.036), rng.uniform(0.08, 0.11)
    mass = float(rng.uniform(0.06, 0.15))
    outer = np.array([[rb, 0.0], [rt, h]])
    return _vessel(name, "cup", seed, rng, outer, 0.003, 0.005, mass, 0.9,
                   params={"bottom_radius": rb, "rim_radius": rt, "height": h, "mass": mass})


def build_mug(name: str, seed: int, rng: np.random.Generator) -> ObjectModel:
    """A straight mug with a handle at +X: radius 3.6–4.1 cm, 8.5–10 cm tall, 200–350 g."""
    r, h = rng.uniform(0.036, 0.041), rng.uniform(0.085, 0.10)
    mass = float(rng.uniform(0.20, 0.35))
    outer = np.array([[r, 0.0], [r, h]])
    hr = h * 0.3
    return _vessel(name, "mug", seed, rng, outer, 0.004, 0.007, mass, 0.9, handle=(r, h * 0.5, hr),
                   params={"radius": r, "height": h, "mass": mass})


def build_teacup(name: str, seed: int, rng: np.random.Generator) -> ObjectModel:
    """A flared teacup with a small handle at +X: foot 2.4–2.8 cm, rim 4.2–4.8 cm, 5.5–7 cm tall."""
    rb, rt, h = rng.uniform(0.024, 0.028), rng.uniform(0.042, 0.048), rng.uniform(0.055, 0.07)
    mass = float(rng.uniform(0.10, 0.18))
    outer = np.array([[rb, 0.0], [rb + 0.45 * (rt - rb), 0.35 * h], [rb + 0.85 * (rt - rb), 0.75 * h],
                      [rt, h]])
    hx = float(rb + 0.7 * (rt - rb))
    return _vessel(name, "teacup", seed, rng, outer, 0.003, 0.005, mass, 0.9, handle=(hx, h * 0.55, h * 0.22),
                   params={"bottom_radius": rb, "rim_radius": rt, "height": h, "mass": mass})


def build_bowl(name: str, seed: int, rng: np.random.Generator) -> ObjectModel:
    """A round bowl: foot 3–4 cm, rim 6–8 cm, 5–7 cm tall, 150–350 g."""
    rb, rt, h = rng.uniform(0.03, 0.04), rng.uniform(0.06, 0.08), rng.uniform(0.05, 0.07)
    mass = float(rng.uniform(0.15, 0.35))
    z = np.linspace(0.0, 1.0, 5)
    outer = np.stack([rb + (rt - rb) * np.sqrt(z), h * z], axis=1)
    return _vessel(name, "bowl", seed, rng, outer, 0.004, 0.006, mass, 0.9,
                   params={"bottom_radius": rb, "rim_radius": rt, "height": h, "mass": mass})


def build_plate(name: str, seed: int, rng: np.random.Generator) -> ObjectModel:
    """A plate: rim radius 9–12 cm, 1.5–2 cm tall, flat centre of 60 % of the radius, 250–500 g."""
    rt, h = rng.uniform(0.09, 0.12), rng.uniform(0.015, 0.02)
    mass = float(rng.uniform(0.25, 0.5))
    outer = np.array([[0.6 * rt, 0.0], [0.62 * rt, 0.006], [rt, h]])
    return _vessel(name, "plate", seed, rng, outer, 0.004, 0.005, mass, 0.8,
                   params={"rim_radius": rt, "height": h, "mass": mass})
