"""The hinged jar: a glass jar whose flat lid swings on a hinge at the jar's −X side.

Frame: origin at the bottom centre, +Z up; the hinge runs along Y at the top of the −X wall, so the lid's
free edge is at +X. The lid link ``lid`` turns on joint ``lid_hinge`` (axis −Y): 0 rad is closed (the lid
rests on the rim), positive opens it upward; the joint's upper limit ``open_angle`` (100–115°, past
vertical) is the stop the open lid leans on. A finger sweep that pushes the lid back past vertical lets
gravity close it; a soft hinge damping keeps the fall gentle.

Graspable by the Panda from the side: outer diameter 5.6–6.8 cm (the hand opens to 8 cm), 0.15–0.30 kg body,
friction 1.0. ``geometry`` keys (m, rad, root frame): ``outer_radius``, ``inner_radius``, ``height`` (body,
without lid), ``wall``, ``bottom`` (= floor height of the inside), ``lid_radius``, ``lid_thickness``,
``lid_mass``, ``mouth_radius`` (inside the shoulder), ``total_height`` (closed), ``hinge_pos`` (x, y, z),
``hinge_axis``, ``open_angle``, ``grasp_height`` (mid-body).
"""

from __future__ import annotations

import numpy as np

from mgdata.sim.assets.model import Articulation, Cavity, Geom, Joint, Link, ObjectModel, with_masses
from mgdata.sim.assets.shapes import vessel_geoms

SECTORS = 16
GLASS = (0.72, 0.86, 0.92, 0.75)
LID_COLOURS = ((0.80, 0.15, 0.12, 1.0), (0.85, 0.65, 0.13, 1.0), (0.15, 0.45, 0.20, 1.0),
               (0.20, 0.30, 0.70, 1.0), (0.55, 0.55, 0.58, 1.0))


def build_hinged_jar(name: str, seed: int, rng: np.random.Generator) -> ObjectModel:
    """A hinged jar with parameters drawn from ``rng`` (see module docstring for ranges and frame)."""
    r_out = float(rng.uniform(0.028, 0.034))
    height = float(rng.uniform(0.080, 0.110))
    wall = float(rng.uniform(0.003, 0.004))
    bottom = 0.006
    lid_t = float(rng.uniform(0.008, 0.011))
    lid_r = r_out + 0.002
    body_mass = float(rng.uniform(0.15, 0.30))
    lid_mass = float(rng.uniform(0.02, 0.04))
    open_angle = float(np.deg2rad(rng.uniform(100.0, 115.0)))
    lid_rgba = LID_COLOURS[int(rng.integers(len(LID_COLOURS)))]
    # A slight shoulder: the body narrows by a few mm under the rim, like a preserve jar.
    outer = np.array([[r_out, 0.0], [r_out, height - 0.012], [r_out - 0.002, height - 0.006],
                      [r_out - 0.002, height]])
    hulls, visual = vessel_geoms(outer, wall, bottom, SECTORS)
    hinge = (-lid_r, 0.0, height + lid_t / 2.0)
    body = (*with_masses(hulls, body_mass),
            Geom("visual", "mesh", mesh=visual, role="visual"),
            Geom("hinge_bracket", "box", (0.004, 0.008, 0.004), pos=(-r_out - 0.002, 0.0, height - 0.002),
                 role="visual", rgba=(0.5, 0.5, 0.5, 1.0)))
    lid_geoms = with_masses((
        Geom("lid", "cylinder", (lid_r, lid_t / 2.0), pos=(lid_r, 0.0, 0.0), rgba=lid_rgba),
        Geom("lid_knuckle", "cylinder", (0.003, 0.008), quat=(0.7071068, 0.7071068, 0.0, 0.0),
             rgba=(0.5, 0.5, 0.5, 1.0), role="visual"),
    ), lid_mass)
    lid = Link(
        name="lid",
        pos=hinge,
        joint=Joint("lid_hinge", "hinge", axis=(0.0, -1.0, 0.0), range=(0.0, open_angle), damping=0.003,
                    armature=2e-5, frictionloss=0.0),
        geoms=lid_geoms,
    )
    inner_r = r_out - wall - 0.002  # the shoulder narrows the mouth
    return ObjectModel(
        name=name,
        category="jar",
        seed=seed,
        params={"outer_radius": r_out, "height": height, "wall": wall, "lid_thickness": lid_t,
                "body_mass": body_mass, "lid_mass": lid_mass, "open_angle": open_angle},
        size=(2.0 * lid_r + 0.006, 2.0 * lid_r, height + lid_t),
        mass=body_mass + lid_mass,
        friction=1.0,
        rgba=GLASS,
        geometry={
            "outer_radius": r_out, "inner_radius": r_out - wall, "height": height, "wall": wall,
            "bottom": bottom, "lid_radius": lid_r, "lid_thickness": lid_t, "lid_mass": lid_mass,
            "mouth_radius": inner_r, "total_height": height + lid_t, "hinge_pos": hinge,
            "hinge_axis": (0.0, -1.0, 0.0),
            "open_angle": open_angle, "grasp_height": height / 2.0,
        },
        geoms=body,
        links=(lid,),
        articulation=Articulation("lid_hinge", "hinge", closed=0.0, open=open_angle),
        cavity=Cavity("round", floor_z=bottom, rim_z=height, radius_floor=inner_r, radius_rim=inner_r),
    )
