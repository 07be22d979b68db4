"""mgdata: safety-annotated robot-manipulation demonstrations in MuJoCo, exported as LeRobot datasets."""

import os
from importlib.metadata import PackageNotFoundError, version

# MuJoCo picks its GL backend at import time; headless CPU rendering needs EGL (or osmesa) chosen first.
os.environ.setdefault("MUJOCO_GL", "egl")
if os.environ["MUJOCO_GL"] in ("egl", "osmesa"):
    os.environ.setdefault("PYOPENGL_PLATFORM", os.environ["MUJOCO_GL"])

try:
    __version__ = version("mgdata")
except PackageNotFoundError:  # running from a source tree that was never installed
    __version__ = "0.0.0+unknown"
