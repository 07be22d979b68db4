"""The grasp database (``grasps/*.json``): loading, validation, candidate generation, in-simulation checks."""

from mgdata.grasps.db import Grasp, GraspDB

__all__ = ["Grasp", "GraspDB"]
