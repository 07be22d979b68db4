"""Bottles: a closed cylinder body, a conical shoulder, a neck and a cap.

Frame: origin at the bottom centre, +Z up. Collision: a cylinder, one convex frustum hull for the shoulder,
a neck cylinder and a cap cylinder (exact, analytic); the visual is a smooth surface of revolution.
``geometry`` keys: ``radius``, ``body_height`` (to the shoulder), ``neck_radius``, ``height`` (with cap),
``grasp_height``.
"""

from __future__ import annotations

import numpy as np

from mgdata.sim.assets.model import Geom, ObjectModel, with_masses
from mgdata.sim.assets.shapes import frustum_hull, revolve

GLASS = ((0.30, 0.55, 0.35, 0.9), (0.55, 0.35, 0.20, 0.9), (0.75, 0.85, 0.90, 0.8), (0.20, 0.35, 0.65, 0.9))
CAPS = ((0.85, 0.80, 0.70, 1.0), (0.15, 0.15, 0.15, 1.0), (0.80, 0.15, 0.15, 1.0))


def build_bottle(name: str, seed: int, rng: np.random.Generator) -> ObjectModel:
    """A bottle: radius 2.8–3.4 cm, body 12–18 cm, shoulder 3–5 cm, neck 1.2–1.5 cm × 3 cm, 0.25–0.6 kg."""
    r, hb, hs = rng.uniform(0.028, 0.034), rng.uniform(0.12, 0.18), rng.uniform(0.03, 0.05)
    rn, hn, hc = rng.uniform(0.012, 0.015), 0.03, 0.012
    mass = float(rng.uniform(0.25, 0.6))
    rgba = GLASS[int(rng.integers(len(GLASS)))]
    cap_rgba = CAPS[int(rng.integers(len(CAPS)))]
    z_neck, z_cap = hb + hs, hb + hs + hn
    height = z_cap + hc
    parts = (
        Geom("body", "cylinder", (r, hb / 2), pos=(0.0, 0.0, hb / 2), role="collision"),
        Geom("shoulder", "mesh", mesh=frustum_hull(r, hb, rn, z_neck, 24), role="collision"),
        Geom("neck", "cylinder", (rn, hn / 2), pos=(0.0, 0.0, z_neck + hn / 2), role="collision"),
        Geom("cap", "cylinder", (rn + 0.0015, hc / 2), pos=(0.0, 0.0, z_cap + hc / 2), rgba=cap_rgba),
    )
    outline = np.array([[0.0, 0.0], [r, 0.0], [r, hb], [rn, z_neck], [rn, z_cap], [0.0, z_cap]])
    return ObjectModel(
        name=name, category="bottle", seed=seed,
        params={"radius": r, "body_height": hb, "shoulder": hs, "neck_radius": rn, "mass": mass},
        size=(2 * float(r), 2 * float(r), float(height)), mass=mass, friction=0.9, rgba=rgba,
        geometry={"radius": float(r), "body_height": float(hb), "neck_radius": float(rn),
                  "height": float(height), "grasp_height": float(hb) / 2},
        geoms=(*with_masses(parts, mass), Geom("visual", "mesh", mesh=revolve(outline), role="visual")),
    )
