"""Food containers with a separate lid: ``container/tub_NN`` and its matching ``lid/tub_NN``.

Both are drawn from the container's seed, so ``lid/tub_03`` fits ``container/tub_03``. Frames: origin at the
bottom centre, +Z up. The tub is an open box (exact box walls, box ``cavity``). The lid is a plate with a
skirt that drops 1 cm outside the tub's walls (so a placed lid seats and cannot slide off) and a knob on top
for a top-down grasp; its origin is the bottom of the skirt, so placing the lid at the tub's origin +
``seat_height`` (tub ``geometry``) seats it. ``geometry``: tub ``half_extents`` (outer x, y, height/2),
``wall``, ``bottom``, ``seat_height``; lid ``half_extents``, ``skirt``, ``knob_height``, ``thickness``.
"""

from __future__ import annotations

import numpy as np

from mgdata.sim.assets.model import Cavity, Geom, ObjectModel, model_seed, with_masses
from mgdata.sim.assets.shapes import box_shell_geoms

PLASTIC = ((0.90, 0.92, 0.95, 1.0), (0.55, 0.75, 0.90, 1.0), (0.95, 0.75, 0.55, 1.0), (0.70, 0.85, 0.60, 1.0))
LID = ((0.20, 0.45, 0.80, 1.0), (0.85, 0.25, 0.25, 1.0), (0.25, 0.65, 0.35, 1.0), (0.95, 0.65, 0.15, 1.0))
WALL, BOTTOM, SKIRT, LID_T, GAP = 0.004, 0.005, 0.010, 0.005, 0.002


def _dims(container_name: str) -> dict[str, float]:
    rng = np.random.default_rng(model_seed(container_name))
    return {"hx": float(rng.uniform(0.06, 0.08)), "hy": float(rng.uniform(0.05, 0.07)),
            "h": float(rng.uniform(0.06, 0.08)), "mass": float(rng.uniform(0.08, 0.15)),
            "lid_mass": float(rng.uniform(0.03, 0.06)), "colour": int(rng.integers(len(PLASTIC)))}


def build_container(name: str, seed: int, rng: np.random.Generator) -> ObjectModel:
    """An open plastic tub (12–16 × 10–14 cm, 6–8 cm tall) that its matching lid closes."""
    d = _dims(name)
    geoms = box_shell_geoms(d["hx"], d["hy"], d["h"], WALL, BOTTOM)
    return ObjectModel(
        name=name, category="container", seed=seed, params=d,
        size=(2 * d["hx"], 2 * d["hy"], d["h"]), mass=d["mass"], friction=0.8, rgba=PLASTIC[int(d["colour"])],
        geometry={"half_extents": (d["hx"], d["hy"], d["h"] / 2), "wall": WALL, "bottom": BOTTOM,
                  "seat_height": d["h"] - SKIRT, "lid": name.replace("container/", "lid/", 1)},
        geoms=with_masses(geoms, d["mass"]),
        cavity=Cavity("box", floor_z=BOTTOM, rim_z=d["h"], half_x=d["hx"] - WALL, half_y=d["hy"] - WALL),
    )


def build_lid(name: str, seed: int, rng: np.random.Generator) -> ObjectModel:
    """The lid of ``container/<same model>``: a plate, a 1 cm skirt outside the tub walls and a knob."""
    d = _dims(name.replace("lid/", "container/", 1))
    hx, hy = d["hx"] + GAP + WALL / 2, d["hy"] + GAP + WALL / 2
    top_z = SKIRT + LID_T / 2
    knob = (0.012, 0.012, 0.008)
    geoms = (
        Geom("plate", "box", (hx + WALL / 2, hy + WALL / 2, LID_T / 2), pos=(0.0, 0.0, top_z)),
        Geom("skirt_px", "box", (WALL / 2, hy, SKIRT / 2), pos=(hx, 0.0, SKIRT / 2)),
        Geom("skirt_nx", "box", (WALL / 2, hy, SKIRT / 2), pos=(-hx, 0.0, SKIRT / 2)),
        Geom("skirt_py", "box", (hx, WALL / 2, SKIRT / 2), pos=(0.0, hy, SKIRT / 2)),
        Geom("skirt_ny", "box", (hx, WALL / 2, SKIRT / 2), pos=(0.0, -hy, SKIRT / 2)),
        Geom("knob", "box", knob, pos=(0.0, 0.0, SKIRT + LID_T + knob[2])),
    )
    height = SKIRT + LID_T + 2 * knob[2]
    return ObjectModel(
        name=name, category="lid", seed=seed, params=d,
        size=(2 * hx + WALL, 2 * hy + WALL, height), mass=d["lid_mass"], friction=0.8,
        rgba=LID[int(d["colour"]) % len(LID)],
        geometry={"half_extents": (hx + WALL / 2, hy + WALL / 2, height / 2), "skirt": SKIRT,
                  "thickness": LID_T, "knob_height": 2 * knob[2],
                  "container": name.replace("lid/", "container/")},
        geoms=with_masses(geoms, d["lid_mass"]),
    )
