"""How long the session's per-step C calls hold Python's GIL (why the leader reader thread stalls during the
loop): a ticker thread sleeps 2 ms in a loop and records how late it wakes while the main thread renders the
task's cameras (MuJoCo), steps the physics, or sleeps (the baseline), with the session's 1 ms switch interval.
Lateness beyond that interval is time a C call kept the GIL.

Run: ``LP_NUM_THREADS=1 .venv/bin/python benchmarks/gil_hold.py [--family jar]``
"""

from __future__ import annotations

import argparse
import sys
import threading
import time
from collections.abc import Callable

import numpy as np

from mgdata.engine.init_gate import base_task
from mgdata.sim.renderer import CameraRig
from mgdata.sim.scene import build_scene
from mgdata.skeleton.skeleton import load_family_recipe
from mgdata.teleop.session import SWITCH_S


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--family", default="jar")
    args = parser.parse_args()
    import mujoco  # after mgdata, which chose the headless GL backend

    sys.setswitchinterval(SWITCH_S)  # as during a live session
    recipe = load_family_recipe(args.family)
    task = base_task(recipe, 0)
    scene = build_scene(task)
    rig = CameraRig(scene, recipe.tasks.cameras, task.image_size)
    lags: list[float] = []
    stop = threading.Event()

    def ticker() -> None:
        while not stop.is_set():
            t = time.perf_counter()
            time.sleep(0.002)
            lags.append(time.perf_counter() - t - 0.002)

    thread = threading.Thread(target=ticker)
    thread.start()

    def measure(name: str, call: Callable[[], object], n: int = 40) -> None:
        lags.clear()
        t = time.perf_counter()
        for _ in range(n):
            call()
        per_call = (time.perf_counter() - t) / n * 1000
        late = np.array(lags) * 1000
        print(f"{name}: {per_call:.1f} ms a call; the ticker woke late by p50 {np.percentile(late, 50):.2f}  "
              f"p95 {np.percentile(late, 95):.2f}  max {late.max():.1f} ms")

    steps = round(scene.physics.control_dt / scene.model.opt.timestep)
    measure(f"render {len(rig.cameras)} cameras", rig.render)
    measure(f"physics, one control step ({steps} mj_step)",
            lambda: [mujoco.mj_step(scene.model, scene.data) for _ in range(steps)])
    measure("sleep 20 ms (baseline)", lambda: time.sleep(0.02))
    stop.set()
    thread.join()
    rig.close()


if __name__ == "__main__":
    main()
