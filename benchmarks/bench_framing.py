"""Framing (issue 41): how much of each camera's frame the task's key objects fill, whether they and the goal
lie inside every view, and how much of them the arm hides, for every family.

For each family it takes ``--n`` stored episodes (``--data DIR/<family>`` if that dataset exists, else it
generates them camera-free there with ``mgdata generate --recipe <a copy with cameras = []>``), restores
their physics states and renders them at ``--size``² with MuJoCo's segmentation renderer
(``mujoco.Renderer.enable_segmentation_rendering``) through every camera, placed by the *current*
``recipes/sim.toml`` ``[cameras]`` merged with the family recipe's ``[cameras]`` (not the stored scene's
cameras, so one dataset measures any layout). Per key object and camera:

* **share**: the object's visible pixels (the arm drawn) as a share of the frame, at frame 0 (min over the
  episodes) and over every ``--stride``-th frame of the episodes (median, min);
* **in view**: the share of the object's bounding points (its geoms' bounding-box corners) that project
  inside the image in front of the camera, at frame 0 (min over the episodes); for the goal: points on the
  goal sphere;
* **arm**: the share of the object's pixels the robot hides (1 − visible with the robot / visible without
  it; the robot's geoms moved to a hidden geom group on a model copy), at frame 0 and the median and max
  over the episode.

The goal sphere is hidden in the area renders (it is transparent and would cover what it holds). Key
objects (:data:`KEY_ROLES`): the roles the family's success predicates name, plus the roles the task
manipulates on the way there (dusty's sponge and source, the stack); dusty has no goal sphere, its tray
(``dest``) is its goal region. Rules (a summary line per family): at frame 0 of every episode, (1) every key
object and the goal are wholly inside every third-person view (every bounding point), (2) every key object
covers ≥ ``--min-share`` (1.5 %) of the frame in at least two third-person views.

``--sheet PATH`` writes a contact sheet: per family two rows (frame 0 and the last frame of the first
episode), the five cameras in RGB from the project's camera rig. ``--markdown PATH`` saves the tables.
``--cost ROUNDS`` measures only what the framing costs to render: per family, the camera rig's five-camera
observations per CPU-second on base task 0 with sim.toml's views over those with the family's (one core,
interleaved rounds, the median ratio).

    MUJOCO_GL=egl .venv/bin/python benchmarks/bench_framing.py --data /tmp/framing/data \\
        [--family jar …] [--n 10] [--sheet docs/framing_after.jpg] [--markdown /tmp/after.md]
    LP_NUM_THREADS=1 MUJOCO_GL=egl .venv/bin/python benchmarks/bench_framing.py --cost 7
"""

from __future__ import annotations

import os

os.environ.setdefault("MUJOCO_GL", "egl")  # before mujoco is imported (mgdata does the same)
os.environ.setdefault("LP_NUM_THREADS", "1")  # llvmpipe on one core, as bench_sim times it

import argparse
import copy
import dataclasses
import re
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass, field
from pathlib import Path

import mujoco
import numpy as np

from mgdata.engine.init_gate import base_task
from mgdata.paths import recipes_dir
from mgdata.record.physics import model_from_bytes, set_physics_state
from mgdata.record.reader import DatasetReader
from mgdata.sim import robot
from mgdata.sim.cameras import CAMERA_NAMES, THIRD_PERSON, CameraLayout, camera_poses, with_overrides
from mgdata.sim.config import load_sim_config
from mgdata.sim.renderer import CameraRig, contact_sheet
from mgdata.sim.scene import build_scene
from mgdata.skeleton.skeleton import load_family_recipe
from mgdata.tasks.recipe import family_recipes, load_recipe

KEY_ROLES: dict[str, tuple[str, ...]] = {
    "jar": ("jar",),
    "clutter_dry": ("target",),
    "clutter_liquid": ("container",),
    "dusty": ("dest", "sponge", "source"),
    "cabinet": ("cabinet", "target"),
    "lid": ("container", "lid"),
    "stack": ("target", "stack"),
}
"""Family -> the roles whose objects must be visible. A role with ``count`` > 1 (``stack``: three objects
``stack_0`` … ``stack_2``) is measured as one object, the union of its instances."""


def key_roles(family: str) -> tuple[str, ...]:
    """:data:`KEY_ROLES`' entry, or for another family (a plugin's) the roles its success predicates name."""
    if family in KEY_ROLES:
        return KEY_ROLES[family]
    subjects = [s for p in load_recipe(family).success for s in p.subjects]
    return tuple(dict.fromkeys(re.sub(r"_\d+$", "", s) for s in subjects))


HIDDEN_GROUP = 3
"""A geom group MuJoCo's default options do not draw (the collision geoms' group)."""


def layout_for(family: str) -> CameraLayout:
    """The layout the family's scenes are built with now (sim.toml's ``[cameras]``, the recipe's over it)."""
    return with_overrides(load_sim_config().cameras, load_recipe(family).cameras)


def apply_layout(model: mujoco.MjModel, layout: CameraLayout) -> None:
    """Move ``model``'s cameras to ``layout`` (the robot base read from the model, welded to the world)."""
    base = model.body(robot.ROOT_BODY)
    quat = base.quat
    w, x, y, z = quat
    yaw = float(np.arctan2(2 * (w * z + x * y), 1 - 2 * (y**2 + z**2)))
    for name, (pos, q, fovy) in camera_poses(tuple(base.pos), yaw, layout).items():
        cam = model.camera(name)
        cam.pos, cam.quat, cam.fovy = pos, q, fovy


def instance_geoms(model: mujoco.MjModel) -> dict[str, np.ndarray]:
    """Top-level body name (an object instance, ``base``, ``table``, ``goal``) -> the geoms under it."""
    top = np.zeros(model.nbody, dtype=int)
    for b in range(1, model.nbody):
        top[b] = b if model.body_parentid[b] == 0 else top[model.body_parentid[b]]
    out: dict[str, list[int]] = {}
    for g in range(model.ngeom):
        b = int(top[model.geom_bodyid[g]])
        out.setdefault(model.body(b).name if b else "world", []).append(g)
    return {k: np.array(v) for k, v in out.items()}


def key_objects(family: str, geoms: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
    """Key object -> its geoms (instances ``role`` or ``role_<i>``)."""
    out = {}
    for role in key_roles(family):
        names = [n for n in geoms if n == role or re.fullmatch(rf"{role}_\d+", n)]
        if not names:
            raise SystemExit(f"{family}: no instance of key role {role!r} in the scene ({sorted(geoms)})")
        out[role] = np.concatenate([geoms[n] for n in sorted(names)])
    return out


def corners(model: mujoco.MjModel, data: mujoco.MjData, ids: np.ndarray) -> np.ndarray:
    """World points of the bounding-box corners of geoms ``ids`` (drawn ones only: group < 3)."""
    signs = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)], dtype=float)
    pts = []
    for g in ids:
        if model.geom_group[g] >= HIDDEN_GROUP:
            continue
        centre, half = model.geom_aabb[g, :3], model.geom_aabb[g, 3:]
        local = centre + signs * half
        pts.append(data.geom_xpos[g] + local @ data.geom_xmat[g].reshape(3, 3).T)
    return np.concatenate(pts) if pts else np.zeros((0, 3))


def sphere_points(centre: np.ndarray, radius: float) -> np.ndarray:
    grid = [[x, y, z] for x in (-1, 0, 1) for y in (-1, 0, 1) for z in (-1, 0, 1)]
    dirs = np.array([d for d in grid if any(d)], float)
    return centre + radius * dirs / np.linalg.norm(dirs, axis=1, keepdims=True)


def in_view(model: mujoco.MjModel, data: mujoco.MjData, cam: int, pts: np.ndarray, size: int) -> float:
    """Share of ``pts`` that project inside the ``size``² image of camera ``cam``, in front of it."""
    if len(pts) == 0:
        return 0.0
    # camera frame: x right, y up, -z ahead
    rel = (pts - data.cam_xpos[cam]) @ data.cam_xmat[cam].reshape(3, 3)
    depth = -rel[:, 2]
    f = 0.5 * size / np.tan(np.radians(model.cam_fovy[cam]) / 2)
    with np.errstate(divide="ignore", invalid="ignore"):
        u = 0.5 * size + f * rel[:, 0] / depth
        v = 0.5 * size - f * rel[:, 1] / depth
    inside = (depth > 0) & (u >= 0) & (u <= size) & (v >= 0) & (v <= size)
    return float(inside.mean())


@dataclass
class Cell:
    """One key object in one camera, over the episodes."""

    share0: list[float] = field(default_factory=list)    # frame 0, per episode
    shares: list[float] = field(default_factory=list)    # every sampled frame
    inside0: list[float] = field(default_factory=list)
    arm0: list[float] = field(default_factory=list)
    arms: list[float] = field(default_factory=list)


class Segmenter:
    """Segmentation renders of one model: with the robot, and with the robot's geoms hidden."""

    def __init__(self, model: mujoco.MjModel, size: int, hide_robot: np.ndarray, hide: np.ndarray) -> None:
        self.models = []
        for hidden in (hide, np.concatenate([hide, hide_robot])):
            m = copy.copy(model)
            m.geom_group[hidden] = HIDDEN_GROUP
            m.vis.global_.offwidth = max(m.vis.global_.offwidth, size)
            m.vis.global_.offheight = max(m.vis.global_.offheight, size)
            self.models.append(m)
        self.renderers = [mujoco.Renderer(m, size, size) for m in self.models]
        for r in self.renderers:
            r.enable_segmentation_rendering()

    def render(self, data: mujoco.MjData, camera: str) -> tuple[np.ndarray, np.ndarray]:
        """Geom id per pixel (−1: none), with the robot and without it."""
        out = []
        for r in self.renderers:
            r.update_scene(data, camera)
            seg = r.render()
            ids = np.where(seg[..., 1] == int(mujoco.mjtObj.mjOBJ_GEOM), seg[..., 0], -1)
            out.append(ids)
        return out[0], out[1]

    def close(self) -> None:
        for r in self.renderers:
            r.close()


def measure_family(family: str, root: Path, n: int, size: int, stride: int,
                   sheet: list[np.ndarray] | None) -> tuple[dict[tuple[str, str], Cell], list[float]]:
    """Cells per (object, camera) and the goal's in-view share per third-person camera (min over episodes)."""
    reader = DatasetReader(root)
    layout = layout_for(family)
    cells: dict[tuple[str, str], Cell] = {}
    goal_in: dict[str, list[float]] = {c: [] for c in CAMERA_NAMES}
    for e in range(min(n, reader.num_episodes)):
        model = model_from_bytes(reader.scene_mjb(e))
        apply_layout(model, layout)
        data = mujoco.MjData(model)
        geoms = instance_geoms(model)
        keys = key_objects(family, geoms)
        goal = geoms.get("goal", np.zeros(0, int))
        seg = Segmenter(model, size, geoms["base"], goal)
        ep = reader.episode(e)
        assert ep.physics_state is not None
        frames = sorted({*range(0, ep.length, stride), ep.length - 1})
        for t in frames:
            set_physics_state(model, data, ep.physics_state[t])
            mujoco.mj_forward(model, data)
            for cam in CAMERA_NAMES:
                cid = model.camera(cam).id
                with_arm, without = seg.render(data, cam)
                for role, ids in keys.items():
                    cell = cells.setdefault((role, cam), Cell())
                    shown = np.isin(with_arm, ids).sum()
                    bare = np.isin(without, ids).sum()
                    share = shown / size**2
                    arm = 1.0 - shown / bare if bare else 0.0
                    cell.shares.append(share)
                    cell.arms.append(arm)
                    if t == 0:
                        cell.share0.append(share)
                        cell.arm0.append(arm)
                        cell.inside0.append(in_view(model, data, cid, corners(model, data, ids), size))
                if t == 0:
                    if len(goal):
                        g = goal[0]
                        pts = sphere_points(data.geom_xpos[g], float(model.geom_size[g, 0]))
                    else:  # dusty: the tray it cleans is the goal region
                        pts = corners(model, data, keys[key_roles(family)[0]])
                    goal_in[cam].append(in_view(model, data, cid, pts, size))
        seg.close()
        if sheet is not None and e == 0:
            with CameraRig.of_model(model, CAMERA_NAMES, size, load_sim_config().render) as rig:
                for t in (0, ep.length - 1):
                    set_physics_state(model, rig.data, ep.physics_state[t])
                    mujoco.mj_forward(model, rig.data)
                    images = rig.render(rig.data)
                    images = {f"{family} t{t} {k}": v for k, v in images.items()}
                    sheet.append(contact_sheet(images))
    return cells, [min(goal_in[c]) for c in THIRD_PERSON]


def table(family: str, cells: dict[tuple[str, str], Cell], goal_in: list[float]) -> list[str]:
    lines = [f"### {family}", "",
             "| object | camera | share t0 (min) | share episode (median / min) | in view t0 | arm hides t0 "
             "| arm hides episode (median / max) |",
             "|---|---|---|---|---|---|---|"]
    for (role, cam), c in cells.items():
        lines.append(f"| {role} | {cam} | {min(c.share0):.2%} | {statistics.median(c.shares):.2%} / "
                     f"{min(c.shares):.2%} | {min(c.inside0):.0%} | {max(c.arm0):.0%} | "
                     f"{statistics.median(c.arms):.0%} / {max(c.arms):.0%} |")
    goal = "goal" if family != "dusty" else "goal (the tray)"
    shown = ", ".join(f"{c} {g:.0%}" for c, g in zip(THIRD_PERSON, goal_in, strict=True))
    lines.append(f"| {goal} | {shown} in view t0 | | | | | |")
    return lines


def verdict(family: str, cells: dict[tuple[str, str], Cell], goal_in: list[float], min_share: float) -> str:
    """The summary line: do the two rules hold at frame 0 of every episode?"""
    out_of_view = [f"{role}@{cam} {min(c.inside0):.0%}" for (role, cam), c in cells.items()
                   if cam in THIRD_PERSON and min(c.inside0) < 1.0]
    out_of_view += [f"goal@{cam} {g:.0%}" for cam, g in zip(THIRD_PERSON, goal_in, strict=True) if g < 1.0]
    small = []
    for role in key_roles(family):
        big = [cam for cam in THIRD_PERSON if min(cells[(role, cam)].share0) >= min_share]
        if len(big) < 2:
            best = sorted((min(cells[(role, cam)].share0) for cam in THIRD_PERSON), reverse=True)[:2]
            small.append(f"{role} (best two {best[0]:.2%}, {best[1]:.2%})")
    rule1 = "yes" if not out_of_view else "NO: " + ", ".join(out_of_view)
    rule2 = "yes" if not small else "NO: " + ", ".join(small)
    return (f"**{family}**: key objects and goal inside every third-person view at t0: {rule1}; "
            f"every key object ≥ {min_share:.1%} in ≥ 2 third-person views at t0: {rule2}")


def render_cost(family: str, rounds: int, frames: int) -> float:
    """Five-camera observations per CPU-second with the family's framing over those with sim.toml's, on its
    base task 0 (one core; interleaved rounds, median ratio)."""
    recipe = load_family_recipe(family)
    task = base_task(recipe, 0)
    scenes = {"framed": build_scene(task), "plain": build_scene(dataclasses.replace(task, cameras={}))}
    rigs = {k: CameraRig(s) for k, s in scenes.items()}
    for s in scenes.values():
        s.reset()
    ratios = []
    for _ in range(rounds):
        took = {}
        for k, rig in rigs.items():
            start = time.process_time()
            for _ in range(frames):
                rig.render()
            took[k] = time.process_time() - start
        ratios.append(took["plain"] / took["framed"])
    for rig in rigs.values():
        rig.close()
    return statistics.median(ratios)


def camera_free_recipes(folder: Path) -> Path:
    """A copy of the recipes with every family's ``cameras = []``."""
    out = folder / "recipes_camera_free"
    shutil.rmtree(out, ignore_errors=True)
    shutil.copytree(recipes_dir(), out)
    for path in out.glob("*.toml"):
        path.write_text(re.sub(r"(?m)^cameras = \[.*\]", "cameras = []", path.read_text()))
    return out


def ensure_dataset(family: str, data: Path, n: int, workers: int) -> Path:
    root = data / family
    if (root / "meta" / "info.json").exists():
        return root
    recipes = camera_free_recipes(data)
    cmd = [str(Path(sys.executable).with_name("mgdata")), "generate", "--family", family, "--recipe",
           str(recipes / f"{family}.toml"), "--n", str(n), "--out", str(root), "--workers", str(workers)]
    print("$", " ".join(cmd), flush=True)
    subprocess.run(cmd, check=True)
    return root


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--family", nargs="+", default=list(family_recipes()))
    parser.add_argument("--data", type=Path, default=None,
                        help="folder of datasets <family>/ (generated camera-free there if missing)")
    parser.add_argument("--n", type=int, default=10, help="episodes per family")
    parser.add_argument("--size", type=int, default=256)
    parser.add_argument("--stride", type=int, default=10, help="frames between episode samples")
    parser.add_argument("--min-share", type=float, default=0.015)
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--sheet", type=Path, default=None, help="contact sheet PNG (frame 0 and last)")
    parser.add_argument("--markdown", type=Path, default=None, help="also write the tables here")
    parser.add_argument("--cost", type=int, default=0, metavar="ROUNDS",
                        help="only time rendering: the family's framing against sim.toml's, ROUNDS rounds")
    args = parser.parse_args()
    if args.cost:
        for family in args.family:
            ratio = render_cost(family, args.cost, 20)
            print(f"{family}: five-camera observations per CPU-second, framed / sim.toml's: {ratio:.2f}",
                  flush=True)
        return
    data = args.data or Path(tempfile.mkdtemp(prefix="bench_framing_"))
    sheet: list[np.ndarray] | None = [] if args.sheet else None
    out: list[str] = []
    summary: list[str] = []
    for family in args.family:
        root = ensure_dataset(family, data, args.n, args.workers)
        cells, goal_in = measure_family(family, root, args.n, args.size, args.stride, sheet)
        lines = table(family, cells, goal_in)
        summary.append(verdict(family, cells, goal_in, args.min_share))
        print("\n".join(lines) + "\n\n" + summary[-1] + "\n", flush=True)
        out += [*lines, "", summary[-1], ""]
    print("\n".join(["## Summary", "", *summary]))
    if args.markdown:
        args.markdown.write_text("\n".join([*out, "## Summary", "", *[f"- {s}" for s in summary]]) + "\n")
    if sheet:
        import cv2

        cv2.imwrite(str(args.sheet), cv2.cvtColor(np.concatenate(sheet, axis=0), cv2.COLOR_RGB2BGR))
        print(f"contact sheet: {args.sheet}")


if __name__ == "__main__":
    main()
