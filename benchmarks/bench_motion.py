"""Motion-layer speed: IK, free-space plans and straight lines, as CPU milliseconds per call.

Targets (issue 4): IK ≤ ~10 ms typical, RRTConnect free plans of tens of ms, 10–20 cm lines ≤ ~100 ms.
Scenes are the motion tests' own (Panda, table, a 30 cm wall, optional clutter boxes). CPU time
(``time.process_time``) is reported because it barely moves with the machine's other load.

Run: ``.venv/bin/python benchmarks/bench_motion.py [--n 30]``
"""

from __future__ import annotations

import argparse
import sys
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests" / "motion"))
from motion_scenes import down_pose, home_data, scene  # imports mgdata first (MUJOCO_GL)

from mgdata.motion import MotionConfig, MotionFailure, MotionPlanner, load_motion_config
from mgdata.sim.robot import HOME_Q


def timed(fn: Callable[[int], object], n: int) -> tuple[np.ndarray, int, list[object]]:
    """CPU ms of ``fn(i)`` for i < n, the number of MotionFailures, and the results."""
    ms, fails, out = [], 0, []
    for i in range(n):
        t0 = time.process_time()
        try:
            out.append(fn(i))
        except MotionFailure:
            fails += 1
        ms.append((time.process_time() - t0) * 1e3)
    return np.array(ms), fails, out


def row(name: str, ms: np.ndarray, fails: int, extra: str = "") -> None:
    n = len(ms)
    print(f"{name:<44} n={n:<4} ok={100 * (n - fails) / n:5.1f}%  median {np.median(ms):7.2f} ms  "
          f"p90 {np.percentile(ms, 90):7.2f} ms  max {ms.max():7.2f} ms  {extra}")


def clutter_scene(n_boxes: int, seed: int) -> object:
    """The wall scene plus loose boxes scattered on the table (away from the two plan endpoints)."""
    import mujoco

    from mgdata.sim.robot import load_panda_spec

    spec = load_panda_spec()
    table = spec.worldbody.add_body(name="table", pos=[0.6, 0.0, -0.02])
    table.add_geom(type=mujoco.mjtGeom.mjGEOM_BOX, size=[0.4, 0.6, 0.02])
    wall = spec.worldbody.add_body(name="wall", pos=[0.5, 0.0, 0.15])
    wall.add_geom(type=mujoco.mjtGeom.mjGEOM_BOX, size=[0.15, 0.015, 0.15])
    rng = np.random.default_rng(seed)
    for i in range(n_boxes):
        x, y = rng.uniform(0.3, 0.8), rng.choice([-1, 1]) * rng.uniform(0.32, 0.55)
        body = spec.worldbody.add_body(name=f"obj{i}", pos=[x, y, 0.03])
        body.add_freejoint()
        body.add_geom(type=mujoco.mjtGeom.mjGEOM_BOX, size=[0.02, 0.02, 0.03])
    return spec.compile()


def bench_free(label: str, model: object, config: MotionConfig, n: int) -> None:
    mp = MotionPlanner(model, config)  # type: ignore[arg-type]
    mp.sync(home_data(model))  # type: ignore[arg-type]
    rng = np.random.default_rng(0)
    qa = mp.ik(down_pose(0.5, 0.2, 0.15), HOME_Q, rng, collision_free=True)
    qb = mp.ik(down_pose(0.5, -0.2, 0.15), HOME_Q, rng, collision_free=True)
    checks0 = mp.checker.n_checks
    ms, fails, trajs = timed(lambda i: mp.free(qa, qb, np.random.default_rng(i)), n)
    checks = (mp.checker.n_checks - checks0) / n
    dur = np.mean([t.duration for t in trajs]) if trajs else float("nan")
    rate = (mp.checker.n_checks - checks0) / (ms.sum() / 1e3)
    row(label, ms, fails, f"{checks:.0f} checks/plan ({rate / 1e3:.0f} k/s), trajectory {dur:.2f} s")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--n", type=int, default=30, help="repetitions per figure")
    args = parser.parse_args()
    n = args.n
    config = load_motion_config()
    model = scene(wall=True, box=False)
    mp = MotionPlanner(model, config)
    mp.sync(home_data(model))
    rng = np.random.default_rng(0)
    print(f"motion benchmark: {n} repetitions per figure, CPU time per call\n")

    near = [mp.fk(mp._ik.clip(HOME_Q + rng.normal(0, 0.5, 7))) for _ in range(4 * n)]
    ms, fails, _ = timed(lambda i: mp.ik(near[i], HOME_Q, np.random.default_rng(i)), len(near))
    row("IK, targets near HOME (seed HOME)", ms, fails)
    anywhere = [mp.fk(rng.uniform(mp.lower, mp.upper)) for _ in range(4 * n)]
    ms, fails, _ = timed(lambda i: mp.ik(anywhere[i], HOME_Q, np.random.default_rng(i)), len(anywhere))
    row("IK, targets anywhere in reach (seed HOME)", ms, fails)
    ms, fails, _ = timed(lambda i: mp.ik(near[i], HOME_Q, np.random.default_rng(i), collision_free=True),
                         len(near))
    row("IK + collision check (misses: targets in table or wall)", ms, fails)

    bench_free("free: over a 30 cm wall (RRTConnect)", model, config, n)
    bench_free("free: over the wall, 20 boxes on the table", clutter_scene(20, 1), config, n)

    q_above = mp.ik(down_pose(0.6, 0.35, 0.25), HOME_Q, rng, collision_free=True)
    for length in (0.10, 0.20):
        ms, fails, trajs = timed(lambda i, d=length: mp.linear(
            q_above, down_pose(0.6, 0.35, 0.25 - d), np.random.default_rng(i)), n)
        row(f"linear: {length * 100:.0f} cm descent, orientation held", ms, fails,
            f"trajectory {np.mean([t.duration for t in trajs]):.2f} s")
    ms, fails, _ = timed(lambda i: mp.linear(q_above, down_pose(0.5, 0.25, 0.15), np.random.default_rng(i),
                                             orientation="slerp"), n)
    row("linear: 18 cm diagonal, slerp", ms, fails)


if __name__ == "__main__":
    main()
