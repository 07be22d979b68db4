"""Small textured meshes the object-import tests write for themselves (no downloaded assets).

``textured_box`` writes ``box.obj`` + ``box.mtl`` + ``box.png``: a closed box whose every side shows the
whole image (UVs by planar projection), the image a 2 x 2 checker of :data:`MAGENTA` and :data:`CYAN`, colours
that nothing else in a scene has.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

MAGENTA = (230, 30, 200)
CYAN = (20, 200, 230)


def checker(size: int = 32) -> np.ndarray:
    """A ``size`` x ``size`` RGB image, 2 x 2 squares: magenta top-left and bottom-right, cyan elsewhere."""
    img = np.empty((size, size, 3), dtype=np.uint8)
    h = size // 2
    img[:, :] = CYAN
    img[:h, :h] = MAGENTA
    img[h:, h:] = MAGENTA
    return img


def box_triangles(extents: tuple[float, float, float]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Vertices (36, 3), faces (12, 3) and UVs (36, 2) of a box centred at the origin, one vertex per
    triangle corner, outward winding, each side's UVs spanning the image."""
    import trimesh

    box = trimesh.creation.box(extents)
    verts = box.vertices[box.faces].reshape(-1, 3)
    normals = np.repeat(box.face_normals, 3, axis=0)
    half = np.asarray(extents) / 2.0
    uv = np.empty((len(verts), 2))
    for i, (v, n) in enumerate(zip(verts, normals, strict=True)):
        a, b = [k for k in range(3) if k != int(np.argmax(np.abs(n)))]
        uv[i] = (v[a] / half[a] + 1.0) / 2.0, (v[b] / half[b] + 1.0) / 2.0
    return verts, np.arange(len(verts)).reshape(-1, 3), uv


def write_obj(path: Path, verts: np.ndarray, faces: np.ndarray, uv: np.ndarray | None,
              mtl: str | None = None) -> Path:
    lines = [f"mtllib {mtl}", "usemtl skin"] if mtl else []
    lines += [f"v {x:.6f} {y:.6f} {z:.6f}" for x, y, z in verts]
    if uv is not None:
        lines += [f"vt {u:.6f} {v:.6f}" for u, v in uv]
        lines += [f"f {a + 1}/{a + 1} {b + 1}/{b + 1} {c + 1}/{c + 1}" for a, b, c in faces]
    else:
        lines += [f"f {a + 1} {b + 1} {c + 1}" for a, b, c in faces]
    path.write_text("\n".join(lines) + "\n")
    return path


def textured_box(folder: Path, extents: tuple[float, float, float] = (0.04, 0.06, 0.08), *,
                 image: bool = True, drop_faces: int = 0, stem: str = "box") -> Path:
    """Write ``<stem>.obj`` (+ ``.mtl`` naming ``<stem>.png``, + the PNG unless ``image`` is False) into
    ``folder``; ``drop_faces`` triangles left out make it open. Returns the OBJ's path."""
    from PIL import Image

    folder.mkdir(parents=True, exist_ok=True)
    verts, faces, uv = box_triangles(extents)
    faces = faces[drop_faces:]
    (folder / f"{stem}.mtl").write_text(f"newmtl skin\nKd 1 1 1\nmap_Kd {stem}.png\n")
    if image:
        Image.fromarray(checker()).save(folder / f"{stem}.png")
    return write_obj(folder / f"{stem}.obj", verts, faces, uv, mtl=f"{stem}.mtl")
