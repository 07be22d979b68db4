"""Motion layer: IK (mink), free-space planning (OMPL), retiming (toppra) and straight lines, behind
:class:`MotionPlanner`. Quaternions are (w, x, y, z)."""

from mgdata.motion.config import (
    CheckConfig,
    IKConfig,
    LinearConfig,
    MotionConfig,
    PlannerConfig,
    RetimeConfig,
    load_motion_config,
)
from mgdata.motion.facade import MotionPlanner
from mgdata.motion.types import NO_CONTACTS, AllowedContacts, Attachment, JointTrajectory, MotionFailure, Pose

__all__ = [
    "NO_CONTACTS",
    "AllowedContacts",
    "Attachment",
    "CheckConfig",
    "IKConfig",
    "JointTrajectory",
    "LinearConfig",
    "MotionConfig",
    "MotionFailure",
    "MotionPlanner",
    "PlannerConfig",
    "Pose",
    "RetimeConfig",
    "load_motion_config",
]
