"""Layer-1 simulation benchmark on a jar scene: physics, rendering, labelling + monitoring.

Prints, for the hinged jar with a cherry inside (the jar family's scene):

* physics steps per CPU-second at the scene's timestep (target ≥ 5,000), and per control step;
* five-camera observations per CPU-second at 256² on one core (``LP_NUM_THREADS=1``; target ≥ 75, issue 16),
  for the camera rig and, interleaved in the same process, for the reference path it replaced (a plain
  ``mujoco.Renderer`` with shadows and reflections off, MuJoCo's default tessellation, one level of detail);
  medians of ``--rounds`` rounds, since the machine is shared;
* labelling (4 propositions) + monitor (3 DFAs) cost per control step (target ≤ 100 µs);
* scene build and reset times, and a 63-sphere liquid scene's physics rate (CG + elliptic cone).

* the cost of the look (``recipes/sim.toml [look]``: textures, lights, walls): the rig on the jar scene as
  built now, interleaved with the same scene without textures, with the key light's shadows, and, given
  ``--baseline-mjb`` (a jar scene saved by an earlier version, see ``--save-mjb``), that scene; ratios of
  observations per CPU-second.

``--sheet PATH`` also writes the five views of the jar scene as a contact sheet PNG (docs/jar_views.png);
``--comparison PATH`` writes the reference path's views above the camera rig's and their difference ×4
(docs/render_comparison.png).

    LP_NUM_THREADS=1 .venv/bin/python benchmarks/bench_sim.py [--sheet docs/jar_views.png]
        [--comparison docs/render_comparison.png] [--baseline-mjb before.mjb]

A baseline from an older checkout (its own code builds the scene; ``--save-mjb`` is the same for this one)::

    git worktree add /tmp/old <commit> && cd /tmp/old && PYTHONPATH=. MUJOCO_GL=egl python -c \
      "import sys; sys.path.insert(0, 'benchmarks'); import mujoco; from bench_sim import jar_task; \
       from mgdata.sim.scene import build_scene; \
       mujoco.mj_saveModel(build_scene(jar_task()).model, '/tmp/before.mjb')"
"""

from __future__ import annotations

import os

os.environ.setdefault("LP_NUM_THREADS", "1")
os.environ.setdefault("MUJOCO_GL", "egl")  # before mujoco is imported (mgdata does the same)

import argparse
import dataclasses
import statistics
import time
from collections.abc import Callable
from pathlib import Path

import mujoco
import numpy as np

from mgdata.ltl import Monitor
from mgdata.sim import robot
from mgdata.sim.assets import get_model
from mgdata.sim.cameras import CAMERA_NAMES
from mgdata.sim.config import default_image_size
from mgdata.sim.controller import JointController
from mgdata.sim.labelling import Labeller
from mgdata.sim.renderer import CameraRig, contact_sheet
from mgdata.sim.scene import Scene, build_scene
from mgdata.sim.taskspec import GoalRegion, ObjectPlacement, TaskSpec
from mgdata.spec import Constraint, Proposition, SafetySpec

JAR_SPEC = SafetySpec(
    "jar",
    (Constraint("stay_until_closed", "jar_on_support W jar_closed"),
     Constraint("never_dropped", "G !jar_dropped"), Constraint("stays_upright", "G jar_upright")),
    (Proposition("jar_on_support", "on", ("jar",), {"support": "table"}),
     Proposition("jar_closed", "closed", ("jar",)), Proposition("jar_dropped", "dropped", ("jar",)),
     Proposition("jar_upright", "upright", ("jar",), {"max_tilt_deg": 30.0})),
)


def task(*objects: ObjectPlacement, **kw: object) -> TaskSpec:
    return TaskSpec("jar", 0, "base", "close the jar and put it in the green region", objects, JAR_SPEC,
                    **{"image_size": default_image_size(), **kw})  # type: ignore[arg-type]


def jar_task() -> TaskSpec:
    """The hinged jar 0.5 m in front of the robot, lid open, a cherry inside, goal to its left."""
    bottom = get_model("jar/hinged_03").geometry["bottom"]
    return task(ObjectPlacement("jar", "jar/hinged_03", (0.5, 0.0, 0.0)),
                ObjectPlacement("food", "food/cherry_00", (0.5, 0.0, bottom)),
                goal=GoalRegion((0.45, 0.3, 0.15), 0.05), articulation={"jar": 1.0})


class ReferenceRig:
    """The render path before issue 16: one ``mujoco.Renderer`` on the scene's model (MuJoCo's default
    tessellation, 640×480 offscreen buffer), shadows and reflections off, every camera at the near level."""

    def __init__(self, scene: Scene) -> None:
        self.scene = scene
        self.renderer = mujoco.Renderer(scene.model, 256, 256)
        self.renderer.scene.flags[mujoco.mjtRndFlag.mjRND_SHADOW] = False
        self.renderer.scene.flags[mujoco.mjtRndFlag.mjRND_REFLECTION] = False

    def render(self) -> dict[str, np.ndarray]:
        out = {}
        for name in CAMERA_NAMES:
            self.renderer.update_scene(self.scene.data, camera=name)
            out[name] = self.renderer.render().copy()
        return out

    def __enter__(self) -> ReferenceRig:
        return self

    def __exit__(self, *exc: object) -> None:
        self.renderer.close()


def render_rates(paths: dict[str, Callable[[], object]], rounds: int, n: int = 10) -> dict[str, list[float]]:
    """Observations per CPU-second of each path: ``rounds`` rounds of ``n`` each, the paths interleaved."""
    rates: dict[str, list[float]] = {k: [] for k in paths}
    for _ in range(rounds):
        for name, render in paths.items():
            render()
            c0 = time.process_time()
            for _ in range(n):
                render()
            rates[name].append(n / (time.process_time() - c0))
    return rates


def write_png(path: Path, rgb: np.ndarray) -> None:
    import cv2

    path.parent.mkdir(parents=True, exist_ok=True)
    cv2.imwrite(str(path), cv2.cvtColor(rgb, cv2.COLOR_RGB2BGR))
    print(f"wrote {path}")


def physics_rate(scene: Scene, steps: int) -> float:
    scene.reset()
    t0 = time.process_time()
    for _ in range(steps):
        mujoco.mj_step(scene.model, scene.data)
    return steps / (time.process_time() - t0)


def look_costs(scene: Scene, args: argparse.Namespace) -> None:
    """Rig observations per CPU-second of the jar scene against itself without textures, with shadows, and
    (``--baseline-mjb``) against an earlier version's scene, interleaved."""
    if args.save_mjb:
        mujoco.mj_saveModel(scene.model, str(args.save_mjb))
        print(f"wrote {args.save_mjb}")
    scene.reset()
    arms = {"look": scene}
    for name, change in (("no textures", {"textures": False}), ("shadows", {"shadows": True})):
        sim = dataclasses.replace(scene.sim, look=dataclasses.replace(scene.sim.look, **change))
        arms[name] = build_scene(scene.task, sim=sim)
        arms[name].reset()
    rigs = {name: CameraRig(s) for name, s in arms.items()}
    if args.baseline_mjb:
        model = mujoco.MjModel.from_binary_path(str(args.baseline_mjb))
        rig = CameraRig.of_model(model, CAMERA_NAMES, scene.task.image_size, scene.sim.render)
        rig.data.qpos[:] = scene.data.qpos
        mujoco.mj_forward(model, rig.data)
        rigs["baseline"] = rig
    rates = render_rates({name: rig.render for name, rig in rigs.items()}, args.rounds)
    med = {name: statistics.median(r) for name, r in rates.items()}
    ref = med.get("baseline", med["no textures"])
    arms = "; ".join(f"{name} {rate:.1f} obs/CPU-s (cost ×{ref / rate:.2f})" for name, rate in med.items())
    against = "the baseline scene" if "baseline" in med else "no textures"
    print(f"look: {arms}  [cost relative to {against}; target ≤ ×1.3]")
    if args.sheet:
        write_png(args.sheet.with_name(args.sheet.stem + "_look.png"),
                  np.concatenate([contact_sheet({f"{name} {c}": img for c, img in rig.render().items()})
                                  for name, rig in rigs.items()]))
    for rig in rigs.values():
        rig.close()


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sheet", type=Path, help="write the jar scene's five views here (PNG)")
    parser.add_argument("--comparison", type=Path, help="write before/after views (PNG)")
    parser.add_argument("--rounds", type=int, default=9, help="interleaved timing rounds of the render paths")
    parser.add_argument("--baseline-mjb", type=Path, help="a jar scene (MJB) from an earlier version to time "
                        "the look against")
    parser.add_argument("--save-mjb", type=Path, help="write this version's jar scene (MJB) here")
    args = parser.parse_args()

    t0 = time.perf_counter()
    scene = build_scene(jar_task())
    build = time.perf_counter() - t0
    t0 = time.perf_counter()
    for _ in range(20):
        scene.reset()
    reset = (time.perf_counter() - t0) / 20
    m = scene.model
    print(f"jar scene: nbody {m.nbody}, ngeom {m.ngeom}, nv {m.nv}; timestep {m.opt.timestep * 1000:.1f} ms, "
          f"{scene.physics.substeps} physics steps per 20 Hz control step")
    print(f"build {build * 1000:.0f} ms (incl. settle), reset {reset * 1e6:.0f} µs")

    rate = physics_rate(scene, 20000)
    print(f"physics: {rate:,.0f} steps per CPU-second ({rate * m.opt.timestep:.0f}× real time; "
          f"{rate / scene.physics.substeps:,.0f} control steps/s)  [target ≥ 5,000 steps/s]")

    scene.reset()
    with CameraRig(scene) as rig, ReferenceRig(scene) as ref:
        rates = render_rates({"rig": rig.render, "reference": ref.render}, args.rounds)
        images, before = rig.render(), ref.render()
    fast, slow = (statistics.median(rates[k]) for k in ("rig", "reference"))
    print(f"render: {fast:.1f} five-camera observations per CPU-second at 256² (reference path {slow:.1f}; "
          f"×{fast / slow:.2f}; medians of {args.rounds} rounds, "
          f"LP_NUM_THREADS={os.environ['LP_NUM_THREADS']})"
          "  [target ≥ 75]")
    if args.sheet:
        write_png(args.sheet, contact_sheet(images))
    if args.comparison:
        diff = {f"|diff| x4 {c}": np.minimum(np.abs(images[c].astype(int) - before[c].astype(int)) * 4, 255)
                .astype(np.uint8) for c in images}
        write_png(args.comparison, np.concatenate([
            contact_sheet({f"before {c}": img for c, img in before.items()}),
            contact_sheet({f"after {c}": img for c, img in images.items()}), contact_sheet(diff)]))

    look_costs(scene, args)

    # Labelling + monitor on the states of a short moving rollout (contacts vary step to step).
    spec = scene.task.safety
    lab, mon = Labeller(scene, spec), Monitor(spec)
    scene.reset()
    ctl = JointController(scene)
    snaps = []
    for t in range(40):
        ctl.apply(np.array([*(robot.HOME_Q + 0.3 * np.sin(t / 8.0)), float(t > 20)]))
        ctl.step()
        snaps.append(scene.snapshot())
    lab_time = mon_time = 0.0
    reps = 25
    for snap in snaps:
        scene.restore(snap)
        mon.reset()
        t0 = time.perf_counter()
        for _ in range(reps):
            bits = lab.labels()
        t1 = time.perf_counter()
        for _ in range(reps):
            mon.step(bits)
        lab_time += t1 - t0
        mon_time += time.perf_counter() - t1
    k = len(snaps) * reps
    print(f"labelling {lab_time / k * 1e6:.1f} µs + monitor {mon_time / k * 1e6:.1f} µs = "
          f"{(lab_time + mon_time) / k * 1e6:.1f} µs per control step ({len(spec.propositions)} "
          f"propositions, {len(spec.constraints)} constraints)  [target ≤ 100 µs]")

    liquid = build_scene(task(
        ObjectPlacement("mug", "mug/handled_00", (0.55, 0.2, 0.0)),
        ObjectPlacement("water", "liquid/water_00", (0.55, 0.2, 0.007))))
    lrate = physics_rate(liquid, 2000)
    print(f"liquid scene (63 spheres, CG + elliptic): {lrate:,.0f} steps per CPU-second "
          f"({lrate * liquid.model.opt.timestep:.1f}× real time)")


if __name__ == "__main__":
    main()
