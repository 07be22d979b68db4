"""Export grasps in a common array format: 4×4 object→TCP transforms with success flags (``.npz``).

Arrays, one row per grasp, in key then file order: ``keys`` (object model), ``ids``, ``transforms``
(N, 4, 4, float64, object frame → TCP frame, metres), ``success`` (bool: validated ``valid`` by the sim
check), ``validated`` (bool: the sim check has run), ``approach`` and ``source`` (strings). Readable with
plain ``numpy.load`` (no pickle).

Example::

    path = export_grasps(db, ["jar/hinged_03"], grasps_dir() / "export" / "jar.npz")
    z = np.load(path); z["transforms"][z["success"]]
"""

from __future__ import annotations

from collections.abc import Iterable
from pathlib import Path

import numpy as np

from mgdata.atomic import save_npz_atomic
from mgdata.grasps.db import GraspDB


def export_grasps(db: GraspDB, keys: Iterable[str], path: Path) -> Path:
    """Write the grasps of ``keys`` (those without grasps are skipped) to ``path`` atomically."""
    rows = [(k, g) for k in keys for g in db.objects.get(k, ())]
    T = np.array([g.matrix() for _, g in rows]).reshape(-1, 4, 4)
    save_npz_atomic(
        Path(path),
        keys=np.array([k for k, _ in rows], dtype=str),
        ids=np.array([g.id for _, g in rows], dtype=str),
        transforms=T,
        success=np.array([g.status == "valid" for _, g in rows], dtype=bool),
        validated=np.array([g.status != "unvalidated" for _, g in rows], dtype=bool),
        approach=np.array([g.approach for _, g in rows], dtype=str),
        source=np.array([g.source for _, g in rows], dtype=str),
    )
    return Path(path)
