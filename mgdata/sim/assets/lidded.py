"""Round containers with a loose lid that seats by its own weight (no weld): two geometry classes.

* ``container/canister_NN`` + ``lid/canister_NN``: a wide-mouthed round canister (outer diameter 5.8–6.6 cm,
  8.5–11 cm tall) and a flat lid: a plate 2.5 mm wider than the canister, a box ``knob`` on top, and a
  tapered ``plug`` underneath that drops into the mouth;
* ``container/bottle_NN`` + ``lid/cap_NN``: a bottle with a shoulder and a narrow neck (outer diameter
  3.0–3.4 cm) and a cap: a cylinder (the ``knob``, gripped whole) with a tapered plug into the neck.

A lid is drawn from its container's seed, so ``lid/cap_03`` fits ``container/bottle_03``. Frames: origin at
the bottom centre, +Z up; a lid's origin is the bottom of its plug, so a lid at the container's origin +
``seat_height`` (container ``geometry``) is seated: its plate rests on the rim, the plug inside the mouth.
The plug tapers from ``PLUG_TOP`` to ``PLUG_BOTTOM`` inside the mouth's radius, so a lid lowered up to about
``PLUG_BOTTOM`` (5–6 mm) off the axis is guided into the seat; the seated lid can move at most ``PLUG_TOP``
(2.5 mm) sideways before the plug meets the wall. Both containers are narrow enough for a side grasp
(``outer_radius``, ``grasp_height``), with the lid on.

``geometry`` keys: container ``outer_radius``, ``inner_radius``, ``height`` (rim), ``wall``, ``bottom``,
``mouth_radius``, ``grasp_height``, ``seat_height``, ``lid`` (its lid's model name), ``kind`` (canister,
bottle); lid ``radius`` (plate or cap), ``plug_depth``, ``seat_tolerance`` (m the seated lid can slide
sideways), ``container``, ``kind`` (lid, cap).
"""

from __future__ import annotations

import numpy as np

from mgdata.sim.assets.model import Cavity, Geom, ObjectModel, model_seed, with_masses
from mgdata.sim.assets.shapes import frustum_hull, vessel_geoms

SECTORS = 16
PLASTIC = ((0.92, 0.92, 0.90, 1.0), (0.60, 0.78, 0.92, 1.0), (0.95, 0.78, 0.55, 1.0), (0.72, 0.86, 0.62, 1.0))
LIDS = ((0.20, 0.45, 0.80, 1.0), (0.85, 0.25, 0.25, 1.0), (0.25, 0.65, 0.35, 1.0), (0.95, 0.65, 0.15, 1.0))
GLASS = (0.72, 0.86, 0.92, 0.8)
WALL, BOTTOM = 0.0035, 0.006
PLUG_TOP, PLUG_BOTTOM = 0.0025, 0.0055
"""m between the mouth's inner wall and the plug's top / bottom edge."""
PLUG_DEPTH = 0.008
PLATE_T, PLATE_OVERHANG = 0.006, 0.0025
KNOB = (0.010, 0.010, 0.008)
CAP_HEIGHT, CAP_OVERHANG = 0.018, 0.002


def _canister_dims(name: str) -> dict[str, float]:
    rng = np.random.default_rng(model_seed(name.replace("lid/", "container/", 1)))
    return {"r": float(rng.uniform(0.029, 0.033)), "h": float(rng.uniform(0.085, 0.110)),
            "mass": float(rng.uniform(0.10, 0.18)), "lid_mass": float(rng.uniform(0.025, 0.045)),
            "colour": int(rng.integers(len(PLASTIC)))}


def _bottle_dims(name: str) -> dict[str, float]:
    rng = np.random.default_rng(model_seed(name.replace("lid/cap_", "container/bottle_", 1)))
    return {"r": float(rng.uniform(0.029, 0.033)), "body": float(rng.uniform(0.075, 0.090)),
            "shoulder": float(rng.uniform(0.012, 0.018)), "neck": float(rng.uniform(0.015, 0.017)),
            "neck_h": float(rng.uniform(0.015, 0.022)), "mass": float(rng.uniform(0.14, 0.22)),
            "cap_mass": float(rng.uniform(0.012, 0.020)), "colour": int(rng.integers(len(LIDS)))}


def _container(name: str, seed: int, d: dict[str, float], outer: np.ndarray, mouth: float, lid: str,
               rgba: tuple[float, float, float, float], kind: str) -> ObjectModel:
    height = float(outer[-1, 1])
    hulls, visual = vessel_geoms(outer, WALL, BOTTOM, SECTORS)
    inner = d["r"] - WALL
    return ObjectModel(
        name=name, category="container", seed=seed, params=d,
        size=(2.0 * d["r"], 2.0 * d["r"], height), mass=d["mass"], friction=1.0, rgba=rgba,
        geometry={"outer_radius": d["r"], "inner_radius": inner, "height": height, "wall": WALL,
                  "bottom": BOTTOM, "mouth_radius": mouth, "grasp_height": min(height / 2.0, 0.06),
                  "seat_height": height - PLUG_DEPTH, "lid": lid, "kind": kind},
        geoms=(*with_masses(hulls, d["mass"]), Geom("visual", "mesh", mesh=visual, role="visual")),
        cavity=Cavity("round", floor_z=BOTTOM, rim_z=height, radius_floor=inner, radius_rim=mouth),
    )


def _plug(mouth: float) -> Geom:
    return Geom("plug", "mesh", mesh=frustum_hull(mouth - PLUG_BOTTOM, 0.0, mouth - PLUG_TOP, PLUG_DEPTH,
                                                  SECTORS))


def build_canister(name: str, seed: int, rng: np.random.Generator) -> ObjectModel:
    """A straight-walled round canister (see the module docstring)."""
    d = _canister_dims(name)
    outer = np.array([[d["r"], 0.0], [d["r"], d["h"]]])
    return _container(name, seed, d, outer, d["r"] - WALL, name.replace("container/", "lid/", 1),
                      PLASTIC[int(d["colour"])], "canister")


def build_canister_lid(name: str, seed: int, rng: np.random.Generator) -> ObjectModel:
    """The canister's lid: plug, plate and a box knob."""
    d = _canister_dims(name)
    radius, mouth = d["r"] + PLATE_OVERHANG, d["r"] - WALL
    knob_z = PLUG_DEPTH + PLATE_T + KNOB[2]
    geoms = (_plug(mouth),
             Geom("plate", "cylinder", (radius, PLATE_T / 2.0), pos=(0.0, 0.0, PLUG_DEPTH + PLATE_T / 2.0)),
             Geom("knob", "box", KNOB, pos=(0.0, 0.0, knob_z)))
    height = knob_z + KNOB[2]
    return ObjectModel(
        name=name, category="lid", seed=seed, params=d, size=(2.0 * radius, 2.0 * radius, height),
        mass=d["lid_mass"], friction=1.0, rgba=LIDS[int(d["colour"]) % len(LIDS)],
        geometry={"radius": radius, "plug_depth": PLUG_DEPTH, "seat_tolerance": PLUG_TOP,
                  "container": name.replace("lid/", "container/", 1), "kind": "lid"},
        geoms=with_masses(geoms, d["lid_mass"]),
    )


def build_bottle(name: str, seed: int, rng: np.random.Generator) -> ObjectModel:
    """A round bottle: body, shoulder, neck (see the module docstring)."""
    d = _bottle_dims(name)
    z_body, z_neck = d["body"], d["body"] + d["shoulder"]
    outer = np.array([[d["r"], 0.0], [d["r"], z_body], [d["neck"], z_neck],
                      [d["neck"], z_neck + d["neck_h"]]])
    lid = name.replace("container/bottle_", "lid/cap_", 1)
    return _container(name, seed, d, outer, d["neck"] - WALL, lid, GLASS, "bottle")


def build_cap(name: str, seed: int, rng: np.random.Generator) -> ObjectModel:
    """The bottle's cap: a plug into the neck under a cylinder gripped whole (its ``knob``)."""
    d = _bottle_dims(name)
    radius, mouth = d["neck"] + CAP_OVERHANG, d["neck"] - WALL
    geoms = (_plug(mouth),
             Geom("knob", "cylinder", (radius, CAP_HEIGHT / 2.0),
                  pos=(0.0, 0.0, PLUG_DEPTH + CAP_HEIGHT / 2.0)))
    return ObjectModel(
        name=name, category="lid", seed=seed, params=d,
        size=(2.0 * radius, 2.0 * radius, PLUG_DEPTH + CAP_HEIGHT), mass=d["cap_mass"], friction=1.0,
        rgba=LIDS[int(d["colour"])],
        geometry={"radius": radius, "plug_depth": PLUG_DEPTH, "seat_tolerance": PLUG_TOP,
                  "container": name.replace("lid/cap_", "container/bottle_", 1), "kind": "cap"},
        geoms=with_masses(geoms, d["cap_mass"]),
    )
