"""MotionConfig: the motion layer's tunables, loaded from ``recipes/motion.toml``.

Every field has a default, so a missing file section or key falls back to it; an unknown section or key, or a
value of the wrong type or sign, raises :class:`~mgdata.errors.RecipeError` naming the file, the key and what
was expected.

Example::

    config = load_motion_config()                    # recipes/motion.toml
    config = MotionConfig(retime=RetimeConfig(speed_scale=0.3))
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import qpsolvers

from mgdata.errors import RecipeError
from mgdata.paths import recipes_dir
from mgdata.settings import load_settings, settings_from_dict


@dataclass(frozen=True)
class IKConfig:
    """mink differential IK on the TCP site, with seeded restarts."""

    pos_tol: float = 5e-4  # m, position residual that counts as solved
    rot_tol: float = 5e-3  # rad, orientation residual that counts as solved
    max_iters: int = 60  # QP steps per attempt
    restarts: int = 12  # extra attempts from perturbed seeds after the first (seeded at q_seed)
    restart_sigma: float = 0.6  # rad, std of the largest seed perturbation (attempt k uses k/restarts of it)
    posture_cost: float = 1e-2  # weight of the pull toward the posture target (HOME_Q, or the seed)
    polish_radius: float = 0.01  # m; closer than this the posture task stops pulling (exact convergence)
    damping: float = 1e-4  # Levenberg-Marquardt damping of every QP
    limit_margin: float = 0.02  # rad kept between a solution and each joint limit
    solver: str = "daqp"  # qpsolvers backend


@dataclass(frozen=True)
class CheckConfig:
    """Collision checking: robot (and held-object) geoms are inflated while planning, exact on recheck."""

    margin: float = 0.01  # m, inflation of robot and held-object geoms against the world while planning
    self_margin: float = 0.0  # m, clearance required between the robot's own links
    resolution: float = 0.002  # OMPL motion-check step, as a fraction of the joint space's extent
    recheck_step: float = 0.01  # rad, largest joint step between two exact checks of a finished trajectory


@dataclass(frozen=True)
class PlannerConfig:
    """OMPL RRTConnect in joint space; budgets are iteration counts, never wall time (determinism)."""

    max_iterations: int = 20000  # planner loop iterations before plan_fail
    range: float = 0.0  # rad, RRTConnect extension length (0: OMPL's default, 20 % of the extent)
    reduce_steps: int = 30  # PathSimplifier.reduceVertices attempts
    shortcut_steps: int = 30  # PathSimplifier.partialShortcutPath attempts
    smooth: bool = True  # round the corners with smoothBSpline (checked, so never less safe)
    waypoint_step: float = 0.08  # rad, densify the simplified path to this step before retiming


@dataclass(frozen=True)
class RetimeConfig:
    """toppra time-optimal parameterisation under scaled Panda limits, sampled at the control rate."""

    rate: float = 20.0  # Hz, control and recording rate of the output samples
    speed_scale: float = 0.5  # fraction of the Panda's joint velocity limits
    accel_scale: float = 0.3  # fraction of the Panda's joint acceleration limits
    gridpoints_per_waypoint: int = 4  # toppra grid density (at least 100 points in all)


@dataclass(frozen=True)
class LinearConfig:
    """Straight TCP lines by chained IK."""

    step: float = 0.005  # m between IK waypoints
    rot_step: float = 0.05  # rad between IK waypoints (slerp)
    max_joint_step: float = 0.12  # rad, a larger joint change between waypoints is a discontinuity
    refine_depth: int = 3  # times a step whose joints jump too far is halved before it is a discontinuity
    speed: float = 0.12  # m/s, TCP speed cap
    angular_speed: float = 0.6  # rad/s, TCP angular speed cap
    accel: float = 0.6  # m/s², TCP acceleration cap along the line
    angular_accel: float = 3.0  # rad/s², TCP angular acceleration cap
    check_margin: float = 0.0  # m, inflation while checking a line (lines end in deliberate contact)
    max_line_error: float = 0.002  # m, allowed deviation of the retimed samples from the line


@dataclass(frozen=True)
class MotionConfig:
    """All motion tunables; see ``recipes/motion.toml`` for the shipped values."""

    ik: IKConfig = field(default_factory=IKConfig)
    check: CheckConfig = field(default_factory=CheckConfig)
    planner: PlannerConfig = field(default_factory=PlannerConfig)
    retime: RetimeConfig = field(default_factory=RetimeConfig)
    linear: LinearConfig = field(default_factory=LinearConfig)

    def __post_init__(self) -> None:
        for section in dataclasses.fields(self):
            _validate(getattr(self, section.name), section.name)


_MAY_BE_ZERO = frozenset({"restarts", "restart_sigma", "posture_cost", "polish_radius", "damping",
                          "limit_margin", "margin", "self_margin", "range", "reduce_steps", "shortcut_steps",
                          "check_margin", "refine_depth"})
"""Numeric fields for which 0 means "off"; every other number must be positive."""


def _validate(obj: Any, section: str) -> None:
    for f in dataclasses.fields(obj):
        value = getattr(obj, f.name)
        if f.type not in ("float", "int"):
            continue
        if f.name in _MAY_BE_ZERO and value < 0:
            raise RecipeError(f"[{section}] {f.name} = {value!r} must not be negative")
        if f.name not in _MAY_BE_ZERO and not value > 0:
            raise RecipeError(f"[{section}] {f.name} = {value!r} must be positive")
    solver = getattr(obj, "solver", None)
    if solver is not None and solver not in qpsolvers.available_solvers:
        raise RecipeError(f"[{section}] solver = {solver!r} is not an installed QP solver; "
                          f"installed: {sorted(qpsolvers.available_solvers)}")


def motion_config_from_dict(raw: dict[str, Any], source: str = "<dict>") -> MotionConfig:
    """Build a MotionConfig from parsed TOML, rejecting unknown tables/keys and mistyped values."""
    return settings_from_dict(MotionConfig, raw, source)


def load_motion_config(path: Path | str | None = None) -> MotionConfig:
    """Load ``recipes/motion.toml`` (or ``path``); a missing default file means all defaults."""
    file = Path(path) if path is not None else recipes_dir() / "motion.toml"
    return load_settings(MotionConfig, file, explicit=path is not None)
