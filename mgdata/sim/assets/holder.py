"""A paper-towel holder of the wall-mounted kind, lying on its back plate: the plate flat on the table, an arm
standing up at each end and the bar between the arms near their tops (the roll goes on the bar; none is
on it).

Frame: origin at the bottom centre, +Z up, X along the bar. Exact box and cylinder primitives (seen and
colliding). ``geometry`` keys: ``half_extents`` (x, y, z half sizes of the bounding box, m), ``bar_radius``,
``bar_z`` (height of the bar's axis), ``kind`` = ``paper_towel_holder`` (its name in prompts).
"""

from __future__ import annotations

import numpy as np

from mgdata.sim.assets.model import Geom, ObjectModel, with_masses

PLATE_T = 0.006
ARM_T = 0.008
ABOVE_BAR = 0.004
"""m of arm above the bar's top."""
FINISHES = ((0.75, 0.75, 0.78, 1.0), (0.20, 0.20, 0.22, 1.0), (0.78, 0.62, 0.44, 1.0))
"""Brushed steel, black metal, light wood."""


def build_towel_holder(name: str, seed: int, rng: np.random.Generator) -> ObjectModel:
    """A paper-towel holder: 27–31 cm long, 4.5–5.5 cm wide, 6.5–8 cm tall, bar ⌀ 2.2–2.6 cm, 0.2–0.4 kg."""
    hx, hy, h = (float(v) for v in (rng.uniform(0.135, 0.155), rng.uniform(0.0225, 0.0275),
                                    rng.uniform(0.065, 0.08)))
    bar_r = float(rng.uniform(0.011, 0.013))
    mass = float(rng.uniform(0.2, 0.4))
    rgba = FINISHES[int(rng.integers(len(FINISHES)))]
    arm_h = (h - PLATE_T) / 2
    bar_z = h - ABOVE_BAR - bar_r
    arm_x = hx - ARM_T / 2
    geoms = (
        Geom("plate", "box", (hx, hy, PLATE_T / 2), pos=(0.0, 0.0, PLATE_T / 2)),
        Geom("arm_p", "box", (ARM_T / 2, hy, arm_h), pos=(arm_x, 0.0, PLATE_T + arm_h)),
        Geom("arm_n", "box", (ARM_T / 2, hy, arm_h), pos=(-arm_x, 0.0, PLATE_T + arm_h)),
        Geom("bar", "cylinder", (bar_r, hx - ARM_T), pos=(0.0, 0.0, bar_z),
             quat=(0.7071068, 0.0, 0.7071068, 0.0)),  # its axis along X
    )
    return ObjectModel(
        name=name, category="holder", seed=seed,
        params={"hx": hx, "hy": hy, "height": h, "bar_radius": bar_r, "mass": mass},
        size=(2 * hx, 2 * hy, h), mass=mass, friction=0.7, rgba=rgba,
        geometry={"half_extents": (hx, hy, h / 2), "bar_radius": bar_r, "bar_z": bar_z,
                  "kind": "paper_towel_holder"},
        geoms=with_masses(geoms, mass),
    )
