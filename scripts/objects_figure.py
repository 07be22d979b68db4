"""The figure of docs/objects.md: a textured mesh imported with ``mgdata objects import`` and drawn by a
clutter_dry recipe copy, rendered in its task's initial scene (overview and close-up).

It writes its own mesh (a 24-sided can, 6.6 x 11 cm, with a label image: no downloaded assets) into a
temporary root started from the shipped recipes, imports it through the real command (grasps included),
draws clutter_dry task 0 with the can as the target, and renders with MuJoCo's renderer.

Usage: MUJOCO_GL=egl python scripts/objects_figure.py [docs/objects_scene.png]
"""

from __future__ import annotations

import math
import os
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

NAME = "can/label_00"
RADIUS, HEIGHT, SIDES = 0.033, 0.11, 24


def label() -> np.ndarray:
    """A 256 x 128 label: silver rims, a red band with white stripes and the word 'mgdata'."""
    from PIL import Image, ImageDraw

    img = Image.new("RGB", (256, 128), (200, 200, 205))
    draw = ImageDraw.Draw(img)
    draw.rectangle((0, 14, 255, 113), fill=(200, 30, 40))
    for x in range(0, 256, 64):
        draw.rectangle((x, 20, x + 10, 107), fill=(245, 245, 240))
    draw.text((96, 56), "mgdata", fill=(255, 230, 60))
    return np.asarray(img)


def write_can(folder: Path) -> Path:
    """``can.obj`` + ``can.mtl`` + ``can.png``: the side wraps the label once (u = angle), the caps use the
    silver rim."""
    from PIL import Image

    verts, uvs, faces = [], [], []
    for ring, z in enumerate((0.0, HEIGHT)):
        for k in range(SIDES + 1):  # the seam's vertex twice (u = 0 and 1)
            a = 2 * math.pi * k / SIDES
            verts.append((RADIUS * math.cos(a), RADIUS * math.sin(a), z))
            uvs.append((k / SIDES, 0.06 + 0.88 * ring))
    for k in range(SIDES):
        b0, b1, t0, t1 = k, k + 1, SIDES + 1 + k, SIDES + 2 + k
        faces += [(b0, b1, t1), (b0, t1, t0)]
    for z, up in ((0.0, False), (HEIGHT, True)):
        centre = len(verts)
        verts.append((0.0, 0.0, z))
        uvs.append((0.5, 0.97))
        for k in range(SIDES):
            a = 2 * math.pi * k / SIDES
            verts.append((RADIUS * math.cos(a), RADIUS * math.sin(a), z))
            uvs.append((0.5 + 0.4 * math.cos(a), 0.97 + 0.02 * math.sin(a)))
        for k in range(SIDES):
            i, j = centre + 1 + k, centre + 1 + (k + 1) % SIDES
            faces.append((centre, i, j) if up else (centre, j, i))
    folder.mkdir(parents=True, exist_ok=True)
    Image.fromarray(label()).save(folder / "can.png")
    (folder / "can.mtl").write_text("newmtl label\nKd 1 1 1\nmap_Kd can.png\n")
    lines = ["mtllib can.mtl", "usemtl label"]
    lines += [f"v {x:.6f} {y:.6f} {z:.6f}" for x, y, z in verts]
    lines += [f"vt {u:.6f} {v:.6f}" for u, v in uvs]
    lines += [f"f {a + 1}/{a + 1} {b + 1}/{b + 1} {c + 1}/{c + 1}" for a, b, c in faces]
    (folder / "can.obj").write_text("\n".join(lines) + "\n")
    return folder / "can.obj"


def main() -> None:
    out = Path(sys.argv[1] if len(sys.argv) > 1 else "docs/objects_scene.png")
    with tempfile.TemporaryDirectory() as tmp:
        root = Path(tmp) / "root"
        from mgdata.paths import recipes_dir

        shutil.copytree(recipes_dir(), root / "recipes")
        recipe = root / "recipes" / "clutter_dry.toml"
        recipe.write_text(recipe.read_text().replace(
            'models = ["cup/*", "mug/*", "teacup/*", "bottle/*", "box/*", "bowl/*"]', f'models = ["{NAME}"]'))
        mgdata = str(Path(sys.executable).with_name("mgdata"))
        subprocess.run([mgdata, "--root", str(root), "objects", "import", str(write_can(Path(tmp) / "src")),
                        "--name", NAME, "--mass", "0.35"], check=True)
        os.environ["MGDATA_ROOT"] = str(root)
        render(out)
    print(f"wrote {out}")


def render(out: Path) -> None:
    import mujoco
    from PIL import Image

    from mgdata.generate.task_report import gate_report
    from mgdata.sim.scene import build_scene
    from mgdata.skeleton.skeleton import load_family_recipe

    row = next(iter(gate_report(load_family_recipe("clutter_dry"), [0])))
    assert row.task is not None, row.line()
    scene = build_scene(row.task)
    scene.reset()
    m, d = scene.model, scene.data
    w, h = 480, 360
    m.vis.global_.offwidth, m.vis.global_.offheight = max(w, m.vis.global_.offwidth), \
        max(h, m.vis.global_.offheight)
    target = scene.object_pose("target")[0]
    visual = m.geom("target/visual").id
    panels = []
    with mujoco.Renderer(m, h, w) as r:
        for distance, elevation, lift in ((0.75, -35.0, 0.0), (0.28, -12.0, 0.05)):
            cam = mujoco.MjvCamera()
            cam.lookat[:] = target + np.array([0.0, 0.0, lift])
            cam.distance, cam.elevation = distance, elevation
            r.enable_segmentation_rendering()
            seen = {}
            for azimuth in range(0, 360, 15):  # the view that shows most of the can (clutter hides it)
                cam.azimuth = azimuth
                r.update_scene(d, cam)
                seg = r.render()
                mine = (seg[..., 0] == visual) & (seg[..., 1] == mujoco.mjtObj.mjOBJ_GEOM)
                seen[azimuth] = int(mine.sum())
            r.disable_segmentation_rendering()
            cam.azimuth = max(seen, key=lambda a: (seen[a], -a))
            r.update_scene(d, cam)
            panels.append(r.render())
    Image.fromarray(np.hstack(panels)).save(out)


if __name__ == "__main__":
    import mgdata  # noqa: F401  (chooses the headless GL backend before MuJoCo is imported)

    main()
