"""A small cabinet fixed to the table, with one sliding drawer and a bar handle.

Frame: origin at the bottom centre of the carcass, +Z up, **front facing +X** (place it with yaw = π to face
a robot standing at −X). The drawer link ``drawer`` slides on joint ``drawer_slide`` along +X from 0 (closed)
to ``travel`` (open, 75 % of the depth; damping 8 N·s/m, friction 1 N). The handle is a horizontal bar along
Y standing off the drawer front. The cabinet is ``fixed`` (welded to the world). ``geometry`` keys (closed,
root frame): ``half_extents`` of the carcass, ``drawer_floor_z``, ``drawer_inner`` (half x, half y, depth),
``handle_pos``, ``handle_axis``, ``handle_radius``, ``handle_length``, ``front_x``, ``travel``.
"""

from __future__ import annotations

import numpy as np

from mgdata.sim.assets.model import Articulation, Geom, Joint, Link, ObjectModel, with_masses
from mgdata.sim.assets.shapes import box_shell_geoms

PANEL = 0.012
WOODS = ((0.80, 0.78, 0.74, 1.0), (0.55, 0.40, 0.28, 1.0), (0.30, 0.38, 0.45, 1.0))
METAL = (0.70, 0.70, 0.72, 1.0)


def build_cabinet(name: str, seed: int, rng: np.random.Generator) -> ObjectModel:
    """A cabinet 36–44 cm deep, 40–56 cm wide, 26–34 cm tall; the drawer fills its upper half."""
    hx, hy, h = rng.uniform(0.18, 0.22), rng.uniform(0.20, 0.28), rng.uniform(0.26, 0.34)
    hx, hy, h = float(hx), float(hy), float(h)
    rgba = WOODS[int(rng.integers(len(WOODS)))]
    p = PANEL / 2
    carcass = (
        Geom("top", "box", (hx, hy, p), pos=(0.0, 0.0, h - p)),
        Geom("base", "box", (hx, hy, p), pos=(0.0, 0.0, p)),
        Geom("side_l", "box", (hx, p, h / 2 - PANEL), pos=(0.0, hy - p, h / 2)),
        Geom("side_r", "box", (hx, p, h / 2 - PANEL), pos=(0.0, -hy + p, h / 2)),
        Geom("back", "box", (p, hy - PANEL, h / 2 - PANEL), pos=(-hx + p, 0.0, h / 2)),
        Geom("shelf", "box", (hx - PANEL, hy - PANEL, p), pos=(PANEL / 2, 0.0, h / 2)),
        Geom("front_low", "box", (p, hy - PANEL, h / 4 - PANEL), pos=(hx - p, 0.0, h / 4 + p / 2)),
    )
    # The drawer: an open box sliding in the upper compartment, its front panel flush with the carcass.
    dz0, dz1 = h / 2 + p + 0.002, h - PANEL - 0.003
    dhx, dhy, dh = hx - PANEL - 0.004, hy - PANEL - 0.003, dz1 - dz0
    box = box_shell_geoms(dhx, dhy, dh, 0.008, 0.008, prefix="drawer_")
    bar_len, standoff, bar_r = min(0.12, 1.2 * dhy), 0.035, 0.007
    front_x = hx
    drawer_geoms = (
        *box,
        Geom("drawer_front", "box", (p, hy - PANEL - 0.002, dh / 2), pos=(dhx + p, 0.0, dh / 2)),
        Geom("handle", "capsule", (bar_r, bar_len / 2), pos=(dhx + PANEL + standoff, 0.0, dh / 2),
             quat=(0.7071068, 0.7071068, 0.0, 0.0), rgba=METAL),
        Geom("handle_post_l", "box", (standoff / 2, 0.005, 0.005),
             pos=(dhx + PANEL + standoff / 2, bar_len / 2 - 0.005, dh / 2), rgba=METAL),
        Geom("handle_post_r", "box", (standoff / 2, 0.005, 0.005),
             pos=(dhx + PANEL + standoff / 2, -bar_len / 2 + 0.005, dh / 2), rgba=METAL),
    )
    travel = 0.75 * 2 * hx
    drawer = Link(
        name="drawer", pos=(0.0, 0.0, dz0),
        joint=Joint("drawer_slide", "slide", axis=(1.0, 0.0, 0.0), range=(0.0, travel), damping=8.0,
                    frictionloss=1.0, armature=0.01),
        geoms=with_masses(drawer_geoms, 0.8),
    )
    handle = (dhx + PANEL + standoff, 0.0, dz0 + dh / 2)
    return ObjectModel(
        name=name, category="cabinet", seed=seed, params={"hx": hx, "hy": hy, "height": h},
        size=(2 * hx + PANEL + standoff + bar_r, 2 * hy, h), mass=8.0, friction=0.7, rgba=rgba,
        geometry={"half_extents": (hx, hy, h / 2), "drawer_floor_z": dz0 + 0.008,
                  "drawer_inner": (dhx - 0.008, dhy - 0.008, dh - 0.008), "handle_pos": handle,
                  "handle_axis": (0.0, 1.0, 0.0), "handle_radius": bar_r, "handle_length": bar_len,
                  "front_x": front_x, "travel": travel},
        geoms=with_masses(carcass, 7.2),
        links=(drawer,),
        articulation=Articulation("drawer_slide", "slide", closed=0.0, open=travel),
        fixed=True,
    )
