"""Box-like solids: cardboard boxes, sponges, chopping boards, trays.

Frame: origin at the bottom centre, +Z up, X the long side. All are exact box primitives (seen and
colliding). ``geometry`` keys: ``half_extents`` (x, y, z half sizes, m); trays add ``wall`` and ``bottom``
and have a box ``cavity``.
"""

from __future__ import annotations

import numpy as np

from mgdata.sim.assets.model import Cavity, Geom, ObjectModel, with_masses
from mgdata.sim.assets.shapes import box_shell_geoms

CARDBOARD = ((0.72, 0.56, 0.38, 1.0), (0.85, 0.30, 0.25, 1.0), (0.25, 0.50, 0.75, 1.0),
             (0.90, 0.85, 0.70, 1.0))
WOOD = ((0.76, 0.60, 0.42, 1.0), (0.66, 0.48, 0.30, 1.0), (0.85, 0.72, 0.52, 1.0))


def _solid(name: str, category: str, seed: int, half: np.ndarray, mass: float, friction: float,
           rgba: tuple[float, float, float, float], params: dict[str, float],
           extra: tuple[Geom, ...] = ()) -> ObjectModel:
    hx, hy, hz = (float(v) for v in half)
    body = Geom("body", "box", (hx, hy, hz), pos=(0.0, 0.0, hz))
    return ObjectModel(
        name=name, category=category, seed=seed, params=params, size=(2 * hx, 2 * hy, 2 * hz), mass=mass,
        friction=friction, rgba=rgba, geometry={"half_extents": (hx, hy, hz)},
        geoms=(*with_masses((body,), mass), *extra),
    )


def build_box(name: str, seed: int, rng: np.random.Generator) -> ObjectModel:
    """A closed carton: 5–10 cm wide, 5–8 cm deep, 6–15 cm tall, 80–400 g."""
    half = np.array([rng.uniform(0.025, 0.05), rng.uniform(0.025, 0.04), rng.uniform(0.03, 0.075)])
    mass = float(rng.uniform(0.08, 0.4))
    rgba = CARDBOARD[int(rng.integers(len(CARDBOARD)))]
    return _solid(name, "box", seed, half, mass, 0.8, rgba, {"hx": half[0], "hy": half[1], "hz": half[2],
                                                              "mass": mass})


def build_sponge(name: str, seed: int, rng: np.random.Generator) -> ObjectModel:
    """A kitchen sponge (yellow foam with a green scrub layer): 8–10 × 5–7 × 2.5–3.5 cm, 15–35 g."""
    half = np.array([rng.uniform(0.04, 0.05), rng.uniform(0.025, 0.035), rng.uniform(0.0125, 0.0175)])
    mass = float(rng.uniform(0.015, 0.035))
    scrub = Geom("scrub", "box", (half[0] + 0.0005, half[1] + 0.0005, 0.002), pos=(0.0, 0.0, 0.0015),
                 role="visual", rgba=(0.20, 0.55, 0.25, 1.0))
    return _solid(name, "sponge", seed, half, mass, 1.2, (0.98, 0.85, 0.25, 1.0),
                  {"hx": half[0], "hy": half[1], "hz": half[2], "mass": mass}, extra=(scrub,))


def build_board(name: str, seed: int, rng: np.random.Generator) -> ObjectModel:
    """A wooden chopping board: 24–34 × 16–24 cm, 1.2–2 cm thick, 0.3–0.8 kg."""
    half = np.array([rng.uniform(0.12, 0.17), rng.uniform(0.08, 0.12), rng.uniform(0.006, 0.01)])
    mass = float(rng.uniform(0.3, 0.8))
    rgba = WOOD[int(rng.integers(len(WOOD)))]
    return _solid(name, "board", seed, half, mass, 0.7, rgba, {"hx": half[0], "hy": half[1], "hz": half[2],
                                                                "mass": mass})


def build_tray(name: str, seed: int, rng: np.random.Generator) -> ObjectModel:
    """A serving tray with low walls: 24–36 × 16–24 cm, rim 2–3 cm, 0.2–0.5 kg."""
    hx, hy, h = rng.uniform(0.12, 0.18), rng.uniform(0.08, 0.12), rng.uniform(0.02, 0.03)
    wall, bottom = 0.006, 0.006
    mass = float(rng.uniform(0.2, 0.5))
    rgba = WOOD[int(rng.integers(len(WOOD)))]
    geoms = box_shell_geoms(float(hx), float(hy), float(h), wall, bottom)
    return ObjectModel(
        name=name, category="tray", seed=seed, params={"hx": hx, "hy": hy, "height": h, "mass": mass},
        size=(2 * float(hx), 2 * float(hy), float(h)), mass=mass, friction=0.7, rgba=rgba,
        geometry={"half_extents": (float(hx), float(hy), float(h) / 2), "wall": wall, "bottom": bottom},
        geoms=with_masses(geoms, mass),
        cavity=Cavity("box", floor_z=bottom, rim_z=float(h), half_x=float(hx) - wall,
                      half_y=float(hy) - wall),
    )
