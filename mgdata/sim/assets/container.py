"""Food containers with a separate lid: ``container/tub_NN`` and its matching ``lid/tub_NN``, and the narrow
tupperware ``container/lunchbox_NN`` with ``lid/lunchbox_NN``.

Both are drawn from the container's seed, so ``lid/tub_03`` fits ``container/tub_03``. Frames: origin at the
bottom centre, +Z up. A container is an open box (exact box walls, box ``cavity``). The lid is a plate with a
skirt that drops 1 cm outside the walls (so a placed lid seats and cannot slide off) and a knob on top for a
top-down grasp; its origin is the bottom of the skirt, so placing the lid at the container's origin +
``seat_height`` (container ``geometry``) seats it; it leaves 2 mm around the walls. Tubs are 10–14 cm wide
(a hand cannot close across one); lunchboxes are 5.4–6 cm wide, 14–18 cm long and 10–11.5 cm tall (the
paper's ~18 cm tupperware, narrow enough to be carried capped by a side grasp under the skirt).
``geometry``: container ``half_extents`` (outer x, y, height/2), ``wall``, ``bottom``, ``seat_height``,
``grasp_height`` (a side grasp's, under the skirt), ``kind`` (``tub``, ``lunchbox``); lid ``half_extents``,
``skirt``, ``knob_height``, ``thickness``, ``plug_depth`` (how far the lid drops over the container when it
seats: its skirt), ``kind`` (``skirt``).
"""

from __future__ import annotations

import math

import numpy as np

from mgdata.sim.assets.model import Cavity, Geom, ObjectModel, model_seed, with_masses
from mgdata.sim.assets.shapes import box_shell_geoms

PLASTIC = ((0.90, 0.92, 0.95, 1.0), (0.55, 0.75, 0.90, 1.0), (0.95, 0.75, 0.55, 1.0), (0.70, 0.85, 0.60, 1.0))
LID = ((0.20, 0.45, 0.80, 1.0), (0.85, 0.25, 0.25, 1.0), (0.25, 0.65, 0.35, 1.0), (0.95, 0.65, 0.15, 1.0))
WALL, BOTTOM, SKIRT, LID_T, GAP = 0.004, 0.005, 0.010, 0.005, 0.002
FLARE_DEG = 20.0  # the skirt's sides lean out by this much towards their bottom edge
UNDER_SKIRT = 0.025  # m from the seated lid's skirt down to a side grasp (the pads stay clear of it)
RANGES = {  # stem: half length, half width, height (m)
    "tub": ((0.06, 0.08), (0.05, 0.07), (0.06, 0.08)),
    "lunchbox": ((0.07, 0.09), (0.027, 0.030), (0.10, 0.115)),
}


def _dims(container_name: str) -> dict[str, float]:
    (hx, hy, h), rng = RANGES[_stem(container_name)], np.random.default_rng(model_seed(container_name))
    return {"hx": float(rng.uniform(*hx)), "hy": float(rng.uniform(*hy)),
            "h": float(rng.uniform(*h)), "mass": float(rng.uniform(0.08, 0.15)),
            "lid_mass": float(rng.uniform(0.03, 0.06)), "colour": int(rng.integers(len(PLASTIC)))}


def _stem(name: str) -> str:
    """``tub`` of ``container/tub_03`` or ``lid/tub_03``."""
    return name.split("/", 1)[1].rsplit("_", 1)[0]


def build_container(name: str, seed: int, rng: np.random.Generator) -> ObjectModel:
    """An open plastic box (a tub: 12–16 × 10–14 cm, 6–8 cm tall; a lunchbox: 14–18 × 5.4–6 cm, 10–11.5 cm
    tall) that its matching lid closes."""
    d = _dims(name)
    geoms = box_shell_geoms(d["hx"], d["hy"], d["h"], WALL, BOTTOM)
    return ObjectModel(
        name=name, category="container", seed=seed, params=d,
        size=(2 * d["hx"], 2 * d["hy"], d["h"]), mass=d["mass"], friction=0.8, rgba=PLASTIC[int(d["colour"])],
        geometry={"half_extents": (d["hx"], d["hy"], d["h"] / 2), "wall": WALL, "bottom": BOTTOM,
                  "seat_height": d["h"] - SKIRT, "grasp_height": d["h"] - SKIRT - UNDER_SKIRT,
                  "lid": name.replace("container/", "lid/", 1), "kind": _stem(name)},
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
        *_skirt(hx, hy),
        Geom("knob", "box", knob, pos=(0.0, 0.0, SKIRT + LID_T + knob[2])),
    )
    height = SKIRT + LID_T + 2 * knob[2]
    flare = SKIRT * math.sin(math.radians(FLARE_DEG))
    return ObjectModel(
        name=name, category="lid", seed=seed, params=d,
        size=(2 * (hx + flare) + WALL, 2 * (hy + flare) + WALL, height), mass=d["lid_mass"], friction=0.8,
        rgba=LID[int(d["colour"]) % len(LID)],
        geometry={"half_extents": (hx + WALL / 2, hy + WALL / 2, height / 2), "skirt": SKIRT,
                  "plug_depth": SKIRT, "thickness": LID_T, "knob_height": 2 * knob[2],
                  "container": name.replace("lid/", "container/"), "kind": "skirt"},
        geoms=with_masses(geoms, d["lid_mass"]),
    )


def _skirt(hx: float, hy: float) -> tuple[Geom, ...]:
    """The four sides of the skirt, ``hx``, ``hy`` out from the centre at the top, each flared out by
    ``FLARE_DEG`` towards its bottom edge: a lid landing a few mm off the axis meets the rim's outer edge with
    a flared side and slides into its seat (tests/test_lid.py: seated from up to 4.5 mm off; with 2 mm of room
    and straight sides it stayed on the rim from 3 mm off, 7–10° cocked, and in the lid family 4 of 11
    lunchbox attempts ended with the lid cocked)."""
    half, phi = SKIRT / 2, math.radians(FLARE_DEG)
    out, down = half * math.sin(phi), SKIRT - half * math.cos(phi)
    turn = (math.cos(phi / 2), math.sin(phi / 2))
    return (
        Geom("skirt_px", "box", (WALL / 2, hy, half), (hx + out, 0.0, down), (turn[0], 0.0, -turn[1], 0.0)),
        Geom("skirt_nx", "box", (WALL / 2, hy, half), (-hx - out, 0.0, down), (turn[0], 0.0, turn[1], 0.0)),
        Geom("skirt_py", "box", (hx, WALL / 2, half), (0.0, hy + out, down), (turn[0], turn[1], 0.0, 0.0)),
        Geom("skirt_ny", "box", (hx, WALL / 2, half), (0.0, -hy - out, down), (turn[0], -turn[1], 0.0, 0.0)),
    )
