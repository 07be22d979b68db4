"""Convex decomposition (coacd) of arbitrary meshes, cached on disk by content hash.

Procedural revolved and box-like assets get exact analytic convex parts instantly (``assets.shapes``); any
other mesh (an imported object) is split into convex hulls by coacd, which takes 4–28 s per mesh on this
class of CPU (probe-sim-stack.md §6). Results are stored in ``mgdata.paths.cache_dir()/coacd/<sha256>.npz``,
keyed by the mesh's vertices and faces, the settings and the coacd version, so the cost is paid once. coacd
is seeded, so a decomposition is deterministic.
"""

from __future__ import annotations

import hashlib
from dataclasses import asdict, dataclass
from importlib.metadata import version

import numpy as np

from mgdata.atomic import save_npz_atomic
from mgdata.paths import cache_dir
from mgdata.sim.assets.model import Mesh


@dataclass(frozen=True)
class DecompositionSettings:
    """coacd parameters; the defaults are the probe's fast settings (≈ 10 hulls, 1.1–1.3× hull volume)."""

    threshold: float = 0.08
    max_convex_hull: int = 16
    mcts_iterations: int = 60
    mcts_nodes: int = 10
    resolution: int = 1000
    seed: int = 0


def _key(verts: np.ndarray, faces: np.ndarray, settings: DecompositionSettings) -> str:
    h = hashlib.sha256()
    h.update(np.ascontiguousarray(verts, dtype=np.float64).tobytes())
    h.update(np.ascontiguousarray(faces, dtype=np.int64).tobytes())
    h.update(repr(sorted(asdict(settings).items())).encode())
    h.update(version("coacd").encode())
    return h.hexdigest()


def convex_decomposition(verts: np.ndarray, faces: np.ndarray,
                         settings: DecompositionSettings | None = None) -> list[Mesh]:
    """Convex hulls (vertices only: MuJoCo hulls them) approximating the mesh ``verts``/``faces``.

    The first call for a mesh runs coacd and writes the cache atomically; later calls read it.
    """
    settings = settings or DecompositionSettings()
    path = cache_dir() / "coacd" / f"{_key(verts, faces, settings)}.npz"
    if path.exists():
        with np.load(path) as z:
            return [Mesh(z[f"hull_{i:03d}"]) for i in range(len(z.files))]
    import coacd

    coacd.set_log_level("error")
    mesh = coacd.Mesh(np.asarray(verts, dtype=np.float64), np.asarray(faces, dtype=np.int64))
    parts = coacd.run_coacd(mesh, **asdict(settings))
    hulls = [np.asarray(v, dtype=np.float64) for v, _ in parts]
    save_npz_atomic(path, **{f"hull_{i:03d}": v for i, v in enumerate(hulls)})
    return [Mesh(v) for v in hulls]
