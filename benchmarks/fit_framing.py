"""Fit a family's third-person framing: the ``[cameras]`` table that frames its key objects and goal tightly.

The four views keep the paper's arrangement: each camera stays on the ray from ``look_at`` through its eye in
``recipes/sim.toml`` (the same azimuth and elevation), and only slides along it. For each family the script
takes the key objects' bounding points and the goal's (``bench_framing``'s, at the settled frame 0 of
``--tasks`` base tasks × ``--draws`` layout draws, gate not applied, so it sees more layouts than a dataset
holds) and fits:

* ``look_at``: from the centre of those points' bounding box (robot base frame), moved (a pattern search)
  to where the four tight eyes are nearest, i.e. the objects largest;
* per camera, the shortest distance along its ray at which every point projects inside ``--margin`` of the
  half-frame, for a shared vertical field of view ``fovy``;
* ``fovy``: from ``--fovy-range``, the widest at which every eye stays ``--reach`` from the arm's shoulder
  (out of the arm's way), ``far_lod_distance`` from the base (render cost unchanged) and inside the room's
  walls; where no field of view allows that, the one whose eyes are pushed back least.

It prints the ``[cameras]`` table to put in ``recipes/<family>.toml``; ``bench_framing.py`` then measures
the frames that table gives on stored episodes.

    MUJOCO_GL=egl .venv/bin/python benchmarks/fit_framing.py [--family jar …] [--tasks 16] [--draws 2]
"""

from __future__ import annotations

import os

os.environ.setdefault("MUJOCO_GL", "egl")  # before mujoco is imported (mgdata does the same)

import argparse

import numpy as np
from bench_framing import corners, instance_geoms, key_objects, sphere_points

from mgdata.sim.cameras import THIRD_PERSON, CameraLayout, base_frame
from mgdata.sim.config import load_sim_config
from mgdata.sim.materials import ROOM_X, ROOM_Y
from mgdata.sim.scene import build_scene
from mgdata.skeleton.skeleton import load_family_recipe
from mgdata.tasks.base import draw_task
from mgdata.tasks.placer import LayoutRejected
from mgdata.tasks.recipe import family_recipes

SHOULDER_HEIGHT = 0.333
"""m: the Panda's shoulder joint above its base (panda.xml ``link1``)."""
WALL_CLEARANCE = 0.2
"""m an eye keeps from the room's walls."""


def frame_points(family: str, tasks: int, draws: int) -> np.ndarray:
    """Key objects' and goal's bounding points (robot base frame) over the layouts, at settled frame 0."""
    recipe = load_family_recipe(family)
    pts = []
    for k in range(min(tasks, recipe.tasks.count)):
        for d in range(draws):
            try:
                task = draw_task(recipe, k, d)
            except LayoutRejected:  # no layout at this draw (generation draws again)
                continue
            scene = build_scene(task)
            scene.reset()
            model, data = scene.model, scene.data
            geoms = instance_geoms(model)
            keys = key_objects(family, geoms)
            world = [corners(model, data, ids) for ids in keys.values()]
            if "goal" in geoms:
                g = geoms["goal"][0]
                world.append(sphere_points(data.geom_xpos[g], float(model.geom_size[g, 0])))
            pos, rot = base_frame(task.robot_base, task.robot_base_yaw)
            pts.append((np.concatenate(world) - pos) @ rot)
    return np.concatenate(pts)


def extent(eye: np.ndarray, target: np.ndarray, pts: np.ndarray, fovy: float) -> float:
    """The largest |image coordinate| of ``pts`` (1: the frame's edge) seen from ``eye`` looking at
    ``target``; infinite if a point is behind the eye."""
    fwd = (target - eye) / np.linalg.norm(target - eye)
    right = np.cross(fwd, [0.0, 0.0, 1.0])
    right /= np.linalg.norm(right)
    up = np.cross(right, fwd)
    rel = pts - eye
    depth = rel @ fwd
    if np.any(depth <= 0.05):
        return float("inf")
    t = np.tan(np.radians(fovy) / 2.0)
    return float(max(np.abs(rel @ right / depth).max(), np.abs(rel @ up / depth).max()) / t)


def tight_distance(target: np.ndarray, ray: np.ndarray, pts: np.ndarray, fovy: float, margin: float) -> float:
    """The shortest distance along ``ray`` from ``target`` at which every point is within ``margin``."""
    lo, hi = 0.1, 8.0
    for _ in range(50):
        mid = 0.5 * (lo + hi)
        lo, hi = (lo, mid) if extent(target + mid * ray, target, pts, fovy) <= margin else (mid, hi)
    return hi


def allowed_distances(target: np.ndarray, ray: np.ndarray, reach: float, lod: float) -> tuple[float, float]:
    """(nearest, farthest) distances along ``ray`` that keep the eye out of the arm's reach, past the far
    level of detail and inside the walls."""
    shoulder = np.array([0.0, 0.0, SHOULDER_HEIGHT])
    ds = np.linspace(0.05, 8.0, 1600)
    eyes = target + ds[:, None] * ray
    ok_near = (np.linalg.norm(eyes - shoulder, axis=1) >= reach) & (np.linalg.norm(eyes, axis=1) >= lod)
    inside = ((eyes[:, 0] > ROOM_X[0] + WALL_CLEARANCE) & (eyes[:, 0] < ROOM_X[1] - WALL_CLEARANCE)
              & (np.abs(eyes[:, 1]) < ROOM_Y[1] - WALL_CLEARANCE))
    near = float(ds[np.argmax(ok_near & inside)]) if np.any(ok_near & inside) else float("inf")
    far = float(ds[inside].max())
    return near, far


def ray(azimuth: float, elevation: float) -> np.ndarray:
    """Unit vector from look_at towards an eye at ``azimuth`` about +Z and ``elevation`` above the table."""
    return np.array([np.cos(elevation) * np.cos(azimuth), np.cos(elevation) * np.sin(azimuth),
                     np.sin(elevation)])


def place(target: np.ndarray, azimuth: float, elevations: np.ndarray, pts: np.ndarray, fovy: float,
          margin: float, reach: float, lod: float) -> tuple[float, np.ndarray, float]:
    """The eye on ``azimuth`` nearest ``target`` over ``elevations``: (distance, ray, how much the constraints
    push it back: 1 none, 0 infeasible)."""
    best = (float("inf"), ray(azimuth, float(elevations[0])), 0.0)
    for elevation in elevations:
        r = ray(azimuth, float(elevation))
        near, far = allowed_distances(target, r, reach, lod)
        tight = tight_distance(target, r, pts, fovy, margin)
        d = max(tight, near)
        if d <= far and d < best[0]:
            best = (d, r, tight / d)
    return best


def fit(pts: np.ndarray, base: CameraLayout, fovys: np.ndarray, elevations: np.ndarray, margin: float,
        reach: float, lod: float) -> tuple[dict[str, object], float]:
    """The ``[cameras]`` overrides, and how much the constraints push the eyes back (1: not at all)."""
    azimuths = {c: float(np.arctan2(*(np.asarray(base.eye(c)) - base.look_at)[1::-1])) for c in THIRD_PERSON}

    def layout(target: np.ndarray, fovy: float) -> tuple[dict[str, tuple[float, np.ndarray, float]], float]:
        eyes = {c: place(target, a, elevations, pts, fovy, margin, reach, lod) for c, a in azimuths.items()}
        return eyes, min(e[2] for e in eyes.values())

    target = 0.5 * (pts.min(axis=0) + pts.max(axis=0))
    fovy, score = max(((f, layout(target, f)[1]) for f in fovys), key=lambda fs: (round(fs[1], 6), fs[0]))

    def cost(t: np.ndarray) -> float:  # the four tight eyes as near as they can be: the objects largest
        eyes, sc = layout(t, fovy)
        return float(sum(np.log(e[0]) for e in eyes.values())) if sc >= score - 1e-6 else float("inf")

    best, step = cost(target), 0.04
    while step > 0.002:  # a pattern search over look_at
        moved = False
        for axis in range(3):
            for sign in (1.0, -1.0):
                trial = target.copy()
                trial[axis] += sign * step
                if (c := cost(trial)) < best - 1e-9:
                    target, best, moved = trial, c, True
        if not moved:
            step /= 2.0
    eyes, score = layout(target, fovy)
    out: dict[str, object] = {"fovy": round(float(fovy), 1), "look_at": [round(float(v), 3) for v in target]}
    for c, (d, r, _) in eyes.items():
        out[c] = [round(float(v), 3) for v in target + d * r]
    return out, score


def toml_table(family: str, overrides: dict[str, object], note: str) -> str:
    lines = [f"# recipes/{family}.toml",
             "# Third-person framing over recipes/sim.toml's [cameras] (fovy, look_at, eyes; robot base "
             "frame),",
             f"# fitted by benchmarks/fit_framing.py ({note}).", "[cameras]"]
    lines += [f"{key} = {value}" for key, value in overrides.items()]
    return "\n".join(lines)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--family", nargs="+", default=list(family_recipes()))
    parser.add_argument("--tasks", type=int, default=16, help="base tasks per family")
    parser.add_argument("--draws", type=int, default=2, help="layout draws per task (gate not applied)")
    parser.add_argument("--margin", type=float, default=0.92, help="share of the half-frame points may use")
    parser.add_argument("--fovy-range", type=float, nargs=2, default=(20.0, 58.0))
    parser.add_argument("--elevation-range", type=float, nargs=2, default=(20.0, 45.0),
                        help="degrees above the table the eyes may sit at, seen from look_at")
    parser.add_argument("--reach", type=float, default=1.0, help="m every eye keeps from the arm's shoulder")
    args = parser.parse_args()
    sim = load_sim_config()
    fovys = np.arange(args.fovy_range[0], args.fovy_range[1] + 0.5, 1.0)
    elevations = np.radians(np.arange(args.elevation_range[0], args.elevation_range[1] + 0.5, 2.5))
    for family in args.family:
        pts = frame_points(family, args.tasks, args.draws)
        overrides, score = fit(pts, sim.cameras, fovys, elevations, args.margin, args.reach,
                               sim.render.far_lod_distance)
        span = pts.max(axis=0) - pts.min(axis=0)
        note = (f"{args.tasks} tasks x {args.draws} draws, margin {args.margin}:\n# key objects and goal "
                f"span {span[0]:.2f} x {span[1]:.2f} x {span[2]:.2f} m; eyes pushed back "
                f"x{1 / score:.2f} at most")
        print(toml_table(family, overrides, note) + "\n", flush=True)


if __name__ == "__main__":
    main()
