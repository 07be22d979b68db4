"""Helpers of the teleop tests: the emulated leader builds they share."""

from __future__ import annotations

from mgdata.sim.robot import HOME_Q
from mgdata.teleop.emulator.arms import ArmBuild

GELLO_BUILD = ArmBuild.gello(seed=3).near_wrap(3, HOME_Q[3])
"""A GELLO whose joint 4 sits 2 ticks under the encoder wrap in the calibration pose."""
