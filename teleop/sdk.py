"""Lazy imports of the vendor servo SDKs (the ``teleop`` extra), with one clear error when missing."""

from __future__ import annotations

import importlib
from types import ModuleType

from mgdata.errors import MgdataError

_MODULES = {"dynamixel": ("dynamixel_sdk", "dynamixel-sdk"), "feetech": ("scservo_sdk", "feetech-servo-sdk"),
            "viser": ("viser", "viser")}


def require(name: str) -> ModuleType:
    """Import the SDK of servo family ``name`` (``dynamixel``/``feetech``) or ``viser``."""
    module, dist = _MODULES[name]
    try:
        return importlib.import_module(module)
    except ImportError:
        raise MgdataError(f"teleop needs the {dist!r} package, which is not installed; install the teleop "
                          "extra: "
                          "pip install -e '.[teleop]'") from None
