"""Decimated copies of visual meshes, cached on disk by content hash.

CPU rendering is dominated by triangle count: the Panda's visual meshes have ~135k triangles and render at
~5 camera-frames/s per core; decimated to 10 % they render at ~190/s (probe-sim-stack.md §2). Only visual
(non-colliding) meshes are decimated; collision geometry stays exact. Results live in
``mgdata.paths.cache_dir()/meshes/<sha256>.npz`` keyed by the source file bytes, the ratio and the algorithm
version, so a cache hit is a file read and a changed mesh is never served stale.
"""

from __future__ import annotations

import hashlib
from pathlib import Path

import numpy as np

from mgdata.atomic import save_npz_atomic
from mgdata.paths import cache_dir

_ALGO_VERSION = "quadric-v2"
MIN_FACES = 300
"""Meshes with fewer faces than this are kept as they are."""


def _cache_path(source: Path, ratio: float) -> Path:
    h = hashlib.sha256()
    h.update(source.read_bytes())
    h.update(f"{_ALGO_VERSION}:{ratio:.6f}".encode())
    return cache_dir() / "meshes" / f"{h.hexdigest()}.npz"


def _decimate(source: Path, ratio: float) -> tuple[np.ndarray, np.ndarray]:
    import fast_simplification
    import trimesh

    # Vertices must be merged first, or the mesh collapses into specks. OBJ files keep vertices split by
    # normals/texture coordinates, so rebuild the mesh from bare positions and faces before processing.
    loaded = trimesh.load(str(source), force="mesh")
    mesh = trimesh.Trimesh(np.asarray(loaded.vertices), np.asarray(loaded.faces), process=True)
    verts = np.asarray(mesh.vertices, dtype=np.float64)
    faces = np.asarray(mesh.faces, dtype=np.int64)
    if len(faces) >= MIN_FACES:
        verts, faces = fast_simplification.simplify(verts, faces, target_reduction=1.0 - ratio)
    return np.asarray(verts, dtype=np.float64), np.asarray(faces, dtype=np.int32)


def decimated_mesh(source: Path, ratio: float = 0.1) -> tuple[np.ndarray, np.ndarray]:
    """Vertices (n, 3) float64 and faces (m, 3) int32 of ``source`` reduced to about ``ratio`` of its faces.

    The first call decimates and writes the cache atomically; later calls read it.
    """
    path = _cache_path(source, ratio)
    if path.exists():
        with np.load(path) as z:
            return z["verts"], z["faces"]
    verts, faces = _decimate(source, ratio)
    save_npz_atomic(path, verts=verts, faces=faces)
    return verts, faces
