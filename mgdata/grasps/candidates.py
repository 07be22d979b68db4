"""Candidate grasps from an object model's geometry, one generator per kind of shape. Candidates are
``source="generated"``, ``status="unvalidated"`` until ``mgdata grasps validate`` runs.

* **side** (round objects narrow enough for the hand at the grasp height: ``outer_radius`` of a jar,
  ``radius`` of a bottle, the ``bottom_radius``…``rim_radius`` taper of a cup): the gripper points at the
  object's axis horizontally from ``angles`` directions, fingers closing horizontally, at the model's
  ``grasp_height`` (or mid-height) raised to ``min_side_height`` (the wrist clears the table) but kept
  ``side_top_clearance`` below the top; the TCP sits on the axis unless the palm would touch the object, in
  which case it backs off. Two rolls per direction (fingers swapped), which reach differently. A box-shaped
  vessel (``half_extents`` and ``wall``) whose narrow side fits the hand (a lunchbox) is grasped the same way
  from both ends of its long axis (``end_p``, ``end_n``), fingers across the narrow side.
* **rim** (open vessels with a ``wall`` too wide for a side grasp: bowls, mugs, teacups, tubs, trays): a
  pinch of the wall from above. The gripper points straight down over the middle of the wall, fingers
  closing radially (round vessels, ``rim_angles`` directions, none within ``handle_clear_deg`` of a handle)
  or across the wall (rectangular vessels, the middle of each side), the TCP ``rim_depth`` below the rim but
  high enough that the inner fingertip clears the vessel's floor by ``floor_clearance``. A handleless round
  vessel whose wall slopes (bowls) also gets ``wall_*`` pinches along the wall (they hold it level); a rim
  steeper than ``rim_follow_max_deg`` (plates) gets none.
* **handle** (mugs, teacups: ``handle_center``, ``handle_radius``): at points of the handle's arc
  ``handle_elevations_deg`` above its outermost point (0°: horizontal, from the handle's side), pointing at
  the arc's centre, fingers closing across the bar; two rolls each. The tilted ones keep the wrist off the
  table where the handle is low (teacups).
* **top** (solid objects, no ``wall``, no articulation, whose narrower horizontal extent plus
  ``top_clearance`` fits between the fingers: boxes, sponges, bottles, paper-towel holders): straight down
  at the bounding box's centre line, ``top_depth`` below the top, closing across the narrow side, and (not
  round ones) ``pose_offset`` of the long side off the middle both ways along it (``top_p``, ``top_n``); two
  rolls each.
* **knob** (a model with a root geom named ``knob``, a box or a cylinder: tub and canister lids, caps):
  straight down on the knob, closing along X and along Y, two rolls each, the fingertips ``tip_clearance``
  above the surface the knob stands on.
* **drawer handle** (a slide articulation with ``handle_pos`` and ``handle_axis``: cabinets): from the
  front, fingers closing across the bar, **expressed in the drawer's frame** (``Grasp.frame``), so the
  grasp moves with the drawer; at the bar's middle and ``pose_offset`` of its ``handle_length`` off it both
  ways (``handle_p``, ``handle_n``); two rolls each.

Objects none of these fit (a chopping board lying flat: 16–20 cm wide, 1.5 cm thick) get no candidates.

Example::

    grasps = candidates(get_model("jar/hinged_03"), CandidateConfig())
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import mujoco
import numpy as np

from mgdata.grasps.db import Grasp, approach_hint
from mgdata.sim.assets.model import ObjectModel
from mgdata.sim.robot import FINGERTIP_REACH, GRIPPER_MAX_OPENING, PALM_DEPTH

Vec3 = tuple[float, float, float]

MAX_OPENING = GRIPPER_MAX_OPENING
"""The Panda hand's finger gap when open (m)."""
DOWN = np.array([0.0, 0.0, -1.0])


@dataclass(frozen=True)
class CandidateConfig:
    """Tunables of the generator (``recipes/grasps.toml`` ``[candidates]``)."""

    angles: int = 12  # side-grasp directions around the axis
    palm_clearance: float = 0.008  # m kept between the palm and the object
    finger_clearance: float = 0.012  # m of opening to spare around the grasped width
    top_depth: float = 0.02  # m below the object's top for top grasps (fingertips overlap the object)
    top_clearance: float = 0.006  # m of opening to spare around a top grasp's width (straight down)
    min_side_height: float = 0.055  # m above the object's base: lower side grasps put the wrist on the table
    side_top_clearance: float = 0.015  # m kept between a side grasp and the object's top (rim, lid)
    tip_clearance: float = 0.002  # m kept between a fingertip and the surface below it
    floor_clearance: float = 0.009  # m kept between a rim pinch's inner fingertip and the vessel's floor
    rim_angles: int = 8  # rim-pinch directions around a round vessel
    rim_depth: float = 0.012  # m from the rim down to the TCP of a rim pinch
    handle_clear_deg: float = 40.0  # no rim pinch this close (degrees about the axis) to a handle
    rim_follow_wall_deg: float = 8.0  # a handleless round vessel's wall sloping more: pinch along it
    rim_follow_max_deg: float = 45.0  # ... up to this; a steeper one (a plate's 71-78° rim) gets no rim pinch
    handle_elevations_deg: Vec3 = (0.0, 50.0, 70.0)  # handle grasps at these points of the handle's arc
    pose_offset: float = 0.25  # top and drawer-handle grasps also this fraction of the length off the middle
    edge_inset: float = 0.025  # m from a flat object's edge in to the TCP of an edge pinch
    edge_max_height: float = 0.03  # m: a solid this thin and too wide for a top grasp gets edge pinches


def _quat(x: np.ndarray, y: np.ndarray, z: np.ndarray) -> tuple[float, float, float, float]:
    """Unit quaternion (w, x, y, z) of the rotation whose columns are ``x``, ``y``, ``z``."""
    mat = np.stack([x, y, z], axis=1)
    quat = np.empty(4)
    mujoco.mju_mat2Quat(quat, mat.ravel())
    if quat[0] < 0:
        quat = -quat
    return tuple(float(v) for v in quat)  # type: ignore[return-value]


def _two_rolls(name: str, pos: np.ndarray, approach: np.ndarray, closing: np.ndarray,
               frame: str = "") -> list[Grasp]:
    """The grasp at ``pos`` approaching along ``approach`` with fingers closing along ±``closing``, in both
    rolls (``_r0``: gripper +Y = ``closing``; ``_r1``: −``closing``)."""
    out = []
    for roll in (0, 1):
        y = closing * (1.0 if roll == 0 else -1.0)
        quat = _quat(np.cross(y, approach), y, approach)
        out.append(Grasp(f"{name}_r{roll}", tuple(float(v) for v in pos), quat,  # type: ignore[arg-type]
                         approach_hint(quat), "generated", frame=frame))
    return out


def _side_radius(model: ObjectModel, height: float) -> float | None:
    """Radius (m) of a round object at ``height``: jar ``outer_radius``, bottle ``radius``, or a vessel's
    linear taper from ``bottom_radius`` to ``rim_radius``; None if it is not round."""
    geo = model.geometry
    if "outer_radius" in geo:
        return float(geo["outer_radius"])
    if "radius" in geo and "body_height" in geo:
        return float(geo["radius"])
    if "rim_radius" in geo and "bottom_radius" in geo:
        bottom, rim, top = float(geo["bottom_radius"]), float(geo["rim_radius"]), float(geo["height"])
        return max(bottom, rim) if "handle_center" in geo else bottom + (rim - bottom) * height / top
    return None


def side_grasps(model: ObjectModel, cfg: CandidateConfig) -> list[Grasp]:
    """Horizontal grasps around a round object's axis, or from both ends of a narrow box-shaped vessel
    (empty if it is too wide for the hand)."""
    geo = model.geometry
    top = float(geo.get("height", model.size[2])) - cfg.side_top_clearance
    height = min(max(float(geo.get("grasp_height", model.size[2] / 2.0)), cfg.min_side_height), top)
    if "half_extents" in geo and "wall" in geo:
        return _end_grasps(model, height, cfg)
    radius = _side_radius(model, height)
    if radius is None or 2.0 * radius + cfg.finger_clearance > MAX_OPENING:
        return []
    back = max(0.0, radius + cfg.palm_clearance - PALM_DEPTH)
    out = []
    for k in range(cfg.angles):
        phi = 2.0 * math.pi * k / cfg.angles
        side = np.array([math.cos(phi), math.sin(phi), 0.0])  # where the gripper sits
        closing = np.array([-math.sin(phi), math.cos(phi), 0.0])
        pos = side * back + np.array([0.0, 0.0, height])
        out += _two_rolls(f"side_{round(math.degrees(phi)):03d}", pos, -side, closing)
    return out


def _end_grasps(model: ObjectModel, height: float, cfg: CandidateConfig) -> list[Grasp]:
    """A box-shaped vessel whose narrow side fits the hand (a lunchbox): from each end of its long axis,
    horizontally, fingers closing across the narrow side at ``height``, the palm ``palm_clearance`` off the
    end wall (its lid's skirt stays above the fingers)."""
    hx, hy, _ = (float(v) for v in model.geometry["half_extents"])
    long_axis, half_long, half_narrow = (np.array([1.0, 0.0, 0.0]), hx, hy) if hx >= hy else \
        (np.array([0.0, 1.0, 0.0]), hy, hx)
    if 2.0 * half_narrow + cfg.finger_clearance > MAX_OPENING:
        return []
    closing = np.cross(np.array([0.0, 0.0, 1.0]), long_axis)
    inset = half_long + cfg.palm_clearance - PALM_DEPTH  # the TCP's distance from the centre
    out = []
    for name, sign in (("end_p", 1.0), ("end_n", -1.0)):
        side = sign * long_axis  # where the gripper sits
        out += _two_rolls(name, side * inset + np.array([0.0, 0.0, height]), -side, closing)
    return out


def rim_grasps(model: ObjectModel, cfg: CandidateConfig) -> list[Grasp]:
    """Top-down pinches across the wall of an open vessel too wide for a side grasp."""
    geo = model.geometry
    if "wall" not in geo or model.articulation is not None or side_grasps(model, cfg):
        return []
    wall, bottom = float(geo["wall"]), float(geo.get("bottom", 0.0))
    if "rim_radius" in geo:
        height = float(geo["height"])
        sites = []
        for k in range(cfg.rim_angles):
            phi = 2.0 * math.pi * k / cfg.rim_angles
            if "handle_center" in geo and abs(math.remainder(phi, 2.0 * math.pi)) < math.radians(
                    cfg.handle_clear_deg):
                continue  # the handle is at +X
            radial = np.array([math.cos(phi), math.sin(phi), 0.0])
            sites.append((f"rim_{round(math.degrees(phi)):03d}",
                          radial * (float(geo["rim_radius"]) - wall / 2.0), radial))
        slope = float(geo.get("rim_slope", 0.0))
        if slope > math.radians(cfg.rim_follow_max_deg):
            return []  # a plate's rim: a vertical pinch slides off it or lifts one side (docs/grasps.md)
    elif "half_extents" in geo:
        hx, hy, hz = (float(v) for v in geo["half_extents"])
        height, slope = 2.0 * hz, 0.0
        sites = [(name, np.array(axis) * (half - wall / 2.0), np.array(axis))
                 for name, axis, half in (("rim_px", (1.0, 0.0, 0.0), hx), ("rim_py", (0.0, 1.0, 0.0), hy),
                                          ("rim_nx", (-1.0, 0.0, 0.0), hx), ("rim_ny", (0.0, -1.0, 0.0), hy))]
    else:
        return []
    z = max(height - cfg.rim_depth, bottom + FINGERTIP_REACH + cfg.floor_clearance)
    out = []
    for name, xy, closing in sites:
        out += _two_rolls(name, xy + np.array([0.0, 0.0, z]), DOWN, closing)
    if "handle_center" not in geo and slope > math.radians(cfg.rim_follow_wall_deg):
        out += _wall_pinches(sites, height, slope, cfg)  # a bowl: also along its sloping wall
    return out


def _wall_pinches(sites: list[tuple[str, np.ndarray, np.ndarray]], height: float, slope: float,
                  cfg: CandidateConfig) -> list[Grasp]:
    """Rim pinches tilted to follow a wall sloping ``slope`` (rad from vertical, the ``rim_slope`` of the
    outer wall just below the rim) down and inwards: the pads
    lie flat on both faces of the wall, so closing squeezes it without turning the vessel (a vertical pinch
    on a sloping wall presses it upright: bowls hung 15–22° tilted), and the TCP is ``rim_depth`` down the
    wall from the rim."""
    out = []
    for name, xy, radial in sites:
        approach = -math.sin(slope) * radial - math.cos(slope) * np.array([0.0, 0.0, 1.0])
        closing = math.cos(slope) * radial - math.sin(slope) * np.array([0.0, 0.0, 1.0])
        pos = xy + np.array([0.0, 0.0, height]) + cfg.rim_depth * approach
        out += _two_rolls(name.replace("rim_", "wall_", 1), pos, approach, closing)
    return out


def handle_grasps(model: ObjectModel, cfg: CandidateConfig) -> list[Grasp]:
    """Grasps of a mug's or teacup's handle (an arc in the XZ plane at +X) at points of the arc
    ``handle_elevations_deg`` above its outermost point, pointing at the arc's centre."""
    geo = model.geometry
    if "handle_center" not in geo or "handle_radius" not in geo:
        return []
    cx, cz = (float(v) for v in geo["handle_center"])
    radius = float(geo["handle_radius"])
    out = []
    for deg in dict.fromkeys(cfg.handle_elevations_deg):
        out_dir = np.array([math.cos(math.radians(deg)), 0.0, math.sin(math.radians(deg))])
        pos = np.array([cx, 0.0, cz]) + radius * out_dir
        out += _two_rolls(f"handle_{round(deg):03d}", pos, -out_dir, np.array([0.0, 1.0, 0.0]))
    return out


def top_grasps(model: ObjectModel, cfg: CandidateConfig) -> list[Grasp]:
    """Straight-down grasps across the narrow horizontal side (empty for articulated, hollow or wide
    objects)."""
    if model.articulation is not None or "wall" in model.geometry:
        return []
    sx, sy, sz = model.size
    narrow = min(sx, sy)
    if narrow + cfg.top_clearance > MAX_OPENING:
        return []
    close_along = np.array([1.0, 0.0, 0.0]) if sx <= sy else np.array([0.0, 1.0, 0.0])
    long_along = np.array([0.0, 1.0, 0.0]) if sx <= sy else np.array([1.0, 0.0, 0.0])
    pos = np.array([0.0, 0.0, max(sz - cfg.top_depth, sz / 2.0)])
    out = _two_rolls("top", pos, DOWN, close_along)
    if _side_radius(model, pos[2]) is not None:
        return out  # round (a bottle): the middle only
    shift = long_along * cfg.pose_offset * max(sx, sy)
    return [*out, *_two_rolls("top_p", pos + shift, DOWN, close_along),
            *_two_rolls("top_n", pos - shift, DOWN, close_along)]


def edge_grasps(model: ObjectModel, cfg: CandidateConfig) -> list[Grasp]:
    """Pinches of a flat object's edge where it overhangs a table edge (a board lying flat, a plate's rim):
    the gripper comes in from beyond the edge towards the object's middle, fingers closing across its
    thickness (the lower finger under the overhang), the TCP ``edge_inset`` in from the edge. A board is
    pinched at the middle of each side, level; a plate at ``rim_angles`` directions, the fingers closing
    along the rim's normal (its rim slopes 12-19° from horizontal) at the middle of the rim's thickness."""
    geo, up = model.geometry, np.array([0.0, 0.0, 1.0])
    if model.articulation is not None:
        return []
    if "rim_radius" in geo and float(geo.get("rim_slope", 0.0)) > math.radians(cfg.rim_follow_max_deg):
        rim, height, wall = float(geo["rim_radius"]), float(geo["height"]), float(geo["wall"])
        rise = math.pi / 2.0 - float(geo["rim_slope"])  # the rim's slope from horizontal
        depth = cfg.edge_inset * math.tan(rise)  # the outer surface's drop from the rim's edge
        out = []
        for k in range(cfg.rim_angles):
            phi = 2.0 * math.pi * k / cfg.rim_angles
            radial = np.array([math.cos(phi), math.sin(phi), 0.0])
            pos = radial * (rim - cfg.edge_inset) + up * (height - depth + wall * math.tan(rise) / 2.0)
            approach = -math.cos(rise) * radial - math.sin(rise) * up
            closing = -math.sin(rise) * radial + math.cos(rise) * up
            out += _two_rolls(f"edge_{round(math.degrees(phi)):03d}", pos, approach, closing)
        return out
    if "wall" in geo or "half_extents" not in geo or top_grasps(model, cfg):
        return []
    hx, hy, hz = (float(v) for v in geo["half_extents"])
    if 2.0 * hz > cfg.edge_max_height:
        return []
    out = []
    for name, axis, half in (("edge_px", (1.0, 0.0, 0.0), hx), ("edge_py", (0.0, 1.0, 0.0), hy),
                             ("edge_nx", (-1.0, 0.0, 0.0), hx), ("edge_ny", (0.0, -1.0, 0.0), hy)):
        outward = np.array(axis)
        out += _two_rolls(name, outward * (half - cfg.edge_inset) + up * hz, -outward, up)
    return out


def knob_grasps(model: ObjectModel, cfg: CandidateConfig) -> list[Grasp]:
    """Straight-down grasps of a root geom named ``knob`` (a box, or an upright cylinder: a cap), closing
    along X and along Y."""
    knob = next((g for g in model.geoms if g.name == "knob" and g.kind in ("box", "cylinder")), None)
    if knob is None:
        return []
    hx, hy, hz = knob.size[:3] if knob.kind == "box" else (knob.size[0], knob.size[0], knob.size[1])
    centre = np.array(knob.pos, dtype=float)
    z = max(centre[2], centre[2] - hz + FINGERTIP_REACH + cfg.tip_clearance)
    out = []
    for name, axis, half in (("knob_x", (1.0, 0.0, 0.0), hx), ("knob_y", (0.0, 1.0, 0.0), hy)):
        if 2.0 * half + cfg.finger_clearance <= MAX_OPENING:
            out += _two_rolls(name, np.array([centre[0], centre[1], z]), DOWN, np.array(axis))
    return out


def drawer_handle_grasps(model: ObjectModel, cfg: CandidateConfig) -> list[Grasp]:
    """Grasps of a drawer's bar handle from the front (+X side), fingers closing across the bar, in the
    frame of the link that carries the slide joint."""
    geo, art = model.geometry, model.articulation
    if art is None or art.kind != "slide" or "handle_pos" not in geo or "handle_axis" not in geo:
        return []
    link = next(lk for lk in model.links if lk.joint.name == art.joint)
    rot = np.empty(9)
    mujoco.mju_quat2Mat(rot, np.asarray(link.quat, dtype=float))
    to_link = rot.reshape(3, 3).T  # root frame -> link frame (the joint is closed in the model's pose)
    pos = to_link @ (np.asarray(geo["handle_pos"], dtype=float) - np.asarray(link.pos, dtype=float))
    approach = to_link @ np.array([-1.0, 0.0, 0.0])
    axis = to_link @ np.asarray(geo["handle_axis"], dtype=float)
    closing = np.cross(axis, approach)
    closing /= np.linalg.norm(closing)
    shift = axis * cfg.pose_offset * float(geo.get("handle_length", 0.0))
    return [*_two_rolls("handle", pos, approach, closing, frame=link.name),
            *_two_rolls("handle_p", pos + shift, approach, closing, frame=link.name),
            *_two_rolls("handle_n", pos - shift, approach, closing, frame=link.name)]


GENERATORS = (side_grasps, rim_grasps, handle_grasps, top_grasps, edge_grasps, knob_grasps,
              drawer_handle_grasps)
"""Every generator, in the order their candidates are listed."""


def candidates(model: ObjectModel, cfg: CandidateConfig) -> list[Grasp]:
    """All candidate grasps of a model, side grasps first."""
    return [g for gen in GENERATORS for g in gen(model, cfg)]
