"""Annotator tunables from ``recipes/annotate.toml`` (``[live]``: the live checks, ``[draft]``: guided-mode
defaults). Every key is optional; an unknown key or a wrong type is a RecipeError naming the file and key.
The standoff and lift heights are not here: the live checks use ``recipes/grasps.toml`` ``[check]``, the
same numbers as ``mgdata grasps validate``.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

from mgdata.paths import recipes_dir
from mgdata.settings import load_settings

Vec3 = tuple[float, float, float]


@dataclass(frozen=True)
class LiveConfig:
    """The live checks (units: m, rad)."""

    placements: int = 2  # representative placements drawn from the family's recipe (plus the sim check's)
    joint_margin: float = 0.03  # rad kept from every joint limit by the IK solutions (pre-grasp, grasp, lift)
    ik_restarts: int = 2  # IK restarts per pose (the planner uses more; a verdict is due in ~100 ms)
    ik_iters: int = 40  # QP steps per IK attempt (an unreachable pose costs restarts × iters)
    deep_restarts: int = 12  # restarts of the second, thorough IK pass where the quick one fails
    approach_step: float = 0.01  # m between checked poses on the straight approach
    width_clearance: float = 0.004  # m of finger opening to spare around the grasped width
    min_grip_depth: float = 0.008  # m of object the pads cover along the approach: a green grip (pads 17 mm)
    pinch_depth: float = 0.003  # m below which the fingers pinch an edge (red); amber in between
    grip_cone_deg: float = 30.0  # deg the first-contact surfaces may face away from the closing axis (green)
    touch_depth: float = 0.002  # m the open hand may cut into the object and still count as touching
    push_depth: float = 0.020  # m beyond which it lands on the object instead of around it
    default_x: float = 0.50  # m: the documented default placement when a family has no recipe placements
    default_y: Vec3 = (0.0, -0.12, 0.12)  # m, one default placement per value


@dataclass(frozen=True)
class DraftConfig:
    """Guided-mode defaults and slider ranges."""

    depth: float = 0.02  # m the TCP goes past the clicked contact point along the approach
    depth_min: float = -0.05
    depth_max: float = 0.10
    depth_step: float = 0.005
    yaw_step_deg: float = 5.0


@dataclass(frozen=True)
class AnnotateSettings:
    live: LiveConfig = field(default_factory=LiveConfig)
    draft: DraftConfig = field(default_factory=DraftConfig)


def load_annotate_config(path: Path | None = None) -> AnnotateSettings:
    """The annotator settings (defaults where the file or a key is missing)."""
    file = Path(path) if path is not None else recipes_dir() / "annotate.toml"
    return load_settings(AnnotateSettings, file, explicit=path is not None)
