"""Material-only recolouring of an object instance (the target axis of the OOD variants, docs/scenarios.md).

The paper's recolour rule, applied to every geom of the instance (its ``rgba``; the procedural assets carry
no textures, and an imported object's textured geom is white, so MuJoCo multiplies its image by the tint):
``albedo' = tint × (albedo + albedo_add)`` with ``albedo_add = 1 − luminance(albedo)``, clipped to [0, 1].
The additive term lifts a dark albedo towards white first, so the tint shows in full on any surface.
Alpha, geometry, mass and friction are untouched: only ``geom_rgba`` of the compiled model differs.

Example::

    apply_tint(spec, "target", (1.0, 0.133, 0.133))
"""

from __future__ import annotations

import mujoco
import numpy as np

from mgdata.errors import SceneError

LUMA = np.array([0.2126, 0.7152, 0.0722])
"""Rec. 709 luminance weights of linear RGB."""


def tinted(rgba: np.ndarray, tint: tuple[float, float, float]) -> np.ndarray:
    """``rgba`` (4,) recoloured by ``tint`` (RGB 0…1) with the rule above; alpha kept."""
    rgba = np.asarray(rgba, dtype=np.float64)
    albedo = rgba[:3]
    lifted = albedo + (1.0 - float(LUMA @ albedo))
    out = np.clip(np.asarray(tint, dtype=np.float64) * lifted, 0.0, 1.0)
    return np.array([*out, rgba[3]])


def apply_tint(spec: mujoco.MjSpec, instance: str, tint: tuple[float, float, float]) -> int:
    """Recolour every geom of ``instance`` (names ``<instance>/…``) in ``spec``; returns how many."""
    prefix = f"{instance}/"
    n = 0
    for geom in spec.geoms:
        if geom.name.startswith(prefix):
            geom.rgba = tinted(np.array(geom.rgba), tint).tolist()
            n += 1
    if n == 0:
        raise SceneError(f"cannot recolour {instance!r}: the scene has no geoms of that instance")
    return n
