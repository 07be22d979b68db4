"""Framing: how much of each frame the task's key objects fill; whether they and the goal are in view.

For each family, the first ``--tasks`` base tasks as the initial-state gate accepts them, at frame 0 (the
share over whole episodes is not measured yet). Per key object (the instances the recipe's success predicate
names) and camera, at
256² from segmentation renders:

* ``share``: the fraction of the frame its visible geoms cover;
* ``occl``: the fraction of its pixels the robot hides (its pixels with the robot drawn against without);
* ``in view``: the corners of the bounding boxes of its colliding geoms (``geom_aabb``), and the goal
  sphere's extremes along the world axes, project inside the image.

Rules (issue 41): every key object and the goal in every third-person view at frame 0, and every key object
≥ 1.5 % of the frame in at least two third-person views.

    MUJOCO_GL=egl .venv/bin/python benchmarks/bench_framing.py [--tasks 4] [--family jar ...]
"""

from __future__ import annotations

import os

os.environ.setdefault("MUJOCO_GL", "egl")

import argparse
import statistics
from collections import defaultdict

import mujoco
import numpy as np

from mgdata.engine.init_gate import base_task
from mgdata.sim import robot
from mgdata.sim.cameras import CAMERA_NAMES, THIRD_PERSON
from mgdata.sim.scene import build_scene
from mgdata.skeleton.skeleton import load_family_recipe
from mgdata.tasks.recipe import family_recipes

SIZE = 256
MIN_SHARE = 0.015


def key_objects(recipe, names: tuple[str, ...]) -> list[str]:  # type: ignore[no-untyped-def]
    """The instances the recipe's success predicate names (present in the scene), in order."""
    out: list[str] = []
    for prop in recipe.success:
        for s in prop.subjects:
            if s in names and s not in out:
                out.append(s)
    return out


class Framer:
    """Segmentation renders of one model: with and without the robot."""

    def __init__(self, model: mujoco.MjModel) -> None:
        self.model = model
        self.renderer = mujoco.Renderer(model, SIZE, SIZE)
        self.renderer.enable_segmentation_rendering()
        self.hidden = mujoco.MjvOption()
        for group in (robot.NEAR_LOD_GROUP, robot.FAR_LOD_GROUP):
            self.hidden.geomgroup[group] = 0
        self.robot_bodies = set(robot.robot_body_ids(model).tolist())

    def geoms(self, data: mujoco.MjData, camera: str, without_robot: bool = False) -> np.ndarray:
        self.renderer.update_scene(data, camera=camera, scene_option=self.hidden if without_robot else None)
        seg = self.renderer.render()
        return np.where(seg[..., 1] == mujoco.mjtObj.mjOBJ_GEOM, seg[..., 0], -1)

    def project(self, data: mujoco.MjData, camera: str, points: np.ndarray) -> np.ndarray:
        """Pixel coordinates (n, 2) of world ``points`` (n, 3); NaN behind the camera."""
        cam = self.model.camera(camera).id
        pos, rot = data.cam_xpos[cam], data.cam_xmat[cam].reshape(3, 3)
        local = (points - pos) @ rot  # camera frame: x right, y up, -z forward
        f = 0.5 * SIZE / np.tan(np.radians(self.model.cam_fovy[cam]) / 2.0)
        depth = -local[:, 2]
        px = np.where(depth[:, None] > 0, np.column_stack([0.5 * SIZE + f * local[:, 0] / depth,
                                                            0.5 * SIZE - f * local[:, 1] / depth]), np.nan)
        return px

    def corners(self, data: mujoco.MjData, geoms: list[int]) -> np.ndarray:
        """World corners (8 per geom) of the geoms' bounding boxes (``geom_aabb``, in each geom's frame)."""
        signs = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)], dtype=float)
        out = []
        for g in geoms:
            centre, half = self.model.geom_aabb[g, :3], self.model.geom_aabb[g, 3:]
            local = centre + signs * half
            out.append(data.geom_xpos[g] + local @ data.geom_xmat[g].reshape(3, 3).T)
        return np.concatenate(out)

    def inside(self, data: mujoco.MjData, camera: str, points: np.ndarray) -> bool:
        px = self.project(data, camera, points)
        return bool(np.all(np.isfinite(px)) and np.all((px >= 0) & (px <= SIZE)))

    def close(self) -> None:
        self.renderer.close()


def measure(framer: Framer, data: mujoco.MjData, owner: dict[int, str], keys: list[str],
            cameras: tuple[str, ...]) -> dict[tuple[str, str], tuple[float, float, bool]]:
    """(key, camera) -> (share, occlusion, in view) for one state."""
    m = framer.model
    out = {}
    goal = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_GEOM, "goal")
    for camera in cameras:
        seen, bare = framer.geoms(data, camera), framer.geoms(data, camera, without_robot=True)
        for key in keys:
            ids = [g for g, k in owner.items() if k == key]
            visible = np.isin(seen, ids).sum()
            alone = np.isin(bare, ids).sum()
            colliding = [g for g in ids if m.geom_contype[g] or m.geom_conaffinity[g]] or ids
            inview = framer.inside(data, camera, framer.corners(data, colliding))
            out[(key, camera)] = (visible / SIZE ** 2, 1.0 - visible / alone if alone else 1.0, inview)
        if goal >= 0:
            sphere = data.geom_xpos[goal] + m.geom_size[goal, 0] * np.concatenate([np.eye(3), -np.eye(3)])
            inview = framer.inside(data, camera, sphere)  # the sphere's own extent, not its box's corners
            out[("goal", camera)] = (float((seen == goal).mean()), 0.0, inview)
    return out


def owners(model: mujoco.MjModel, keys: list[str]) -> dict[int, str]:
    """Visible geom id -> key instance (its body's top-level name)."""
    out = {}
    for g in range(model.ngeom):
        head = model.body(int(model.geom_bodyid[g])).name.split("/", 1)[0]
        if head in keys and model.geom_group[g] in (0, 2):
            out[g] = head
    # liquid spheres are bodies of their own named <instance>/...; dust specks likewise
    return out


def family_rows(family: str, tasks: int) -> list[dict[tuple[str, str], tuple[float, float, bool]]]:
    recipe = load_family_recipe(family)
    rows = []
    for k in range(tasks):
        scene = build_scene(base_task(recipe, k))
        scene.reset()
        keys = key_objects(recipe, scene.object_names)
        framer = Framer(scene.model)
        rows.append(measure(framer, scene.data, owners(scene.model, keys), keys, CAMERA_NAMES))
        framer.close()
    return rows


def report(family: str, rows: list[dict]) -> bool:  # type: ignore[type-arg]
    """Print the family's table; return whether both rules hold at frame 0 for every task."""
    table: dict[tuple[str, str], list[tuple[float, float, bool]]] = defaultdict(list)
    for row in rows:
        for k, v in row.items():
            table[k].append(v)
    keys = sorted({k for k, _ in table}, key=lambda k: (k == "goal", k))
    print(f"\n### {family} ({len(rows)} tasks, frame 0; share % median [min], robot occlusion median, "
          "in view)\n")
    print("| object | " + " | ".join(CAMERA_NAMES) + " |")
    print("|---|" + "---|" * len(CAMERA_NAMES))
    for key in keys:
        cells = []
        for cam in CAMERA_NAMES:
            v = table[(key, cam)]
            share = [x[0] * 100 for x in v]
            occl = statistics.median(x[1] for x in v)
            inview = sum(x[2] for x in v)
            cells.append(f"{statistics.median(share):.2f} [{min(share):.2f}] o{occl:.0%} v{inview}/{len(v)}")
        print(f"| {key} | " + " | ".join(cells) + " |")
    ok = True
    for row in rows:
        for key in {k for k, _ in row}:
            if any(not row[(key, c)][2] for c in THIRD_PERSON):
                ok = False
            if key != "goal" and sum(row[(key, c)][0] >= MIN_SHARE for c in THIRD_PERSON) < 2:
                ok = False
    big = [min(sum(row[(k, c)][0] >= MIN_SHARE for c in THIRD_PERSON) for row in rows)
           for k in keys if k != "goal"]
    print(f"\n{family}: {'PASS' if ok else 'FAIL'}: every key object and the goal in all four third-person "
          "views "
          f"at frame 0: {all(all(row[(k, c)][2] for k in keys for c in THIRD_PERSON) for row in rows)}; "
          f"third-person views with each key object >= 1.5 % (fewest over tasks): {big}")
    return ok


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--family", action="append", help="family (repeatable; default: all)")
    parser.add_argument("--tasks", type=int, default=4, help="base tasks per family (frame 0)")
    args = parser.parse_args()
    results = {f: report(f, family_rows(f, args.tasks)) for f in (args.family or family_recipes())}
    print("\nsummary: " + ", ".join(f"{f} {'PASS' if ok else 'FAIL'}" for f, ok in results.items()))


if __name__ == "__main__":
    main()
