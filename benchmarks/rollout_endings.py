"""Where a policy's failed rollouts left the object: its distance to the goal centre at the end and at its
closest, and the steps it spent inside the goal sphere, from the raw MuJoCo states of recorded rollouts.

Input: the rollouts dataset of ``mgdata eval --record`` (``OUT/rollouts/<family>``) of a family with a goal
sphere (jar, lid …). Prints one line per failed rollout and a summary::

    .venv/bin/python benchmarks/rollout_endings.py /work/runs/eval/rollouts/jar --object jar
"""

from __future__ import annotations

import argparse
from pathlib import Path

import mujoco
import numpy as np

from mgdata.record.physics import model_from_bytes, set_physics_state
from mgdata.record.reader import DatasetReader


def distances(reader: DatasetReader, i: int, body: str) -> tuple[np.ndarray, float]:
    """Per frame, the object's distance to the goal centre (m), and the goal's radius."""
    ep = reader.episode(i)
    model = model_from_bytes(reader.scene_mjb(i))
    data = mujoco.MjData(model)
    goal = model.body("goal").id
    out = np.empty(ep.length)
    for k in range(ep.length):
        set_physics_state(model, data, ep.physics_state[k])
        mujoco.mj_kinematics(model, data)
        out[k] = np.linalg.norm(data.body(body).xpos - data.xpos[goal])
    radius = float(model.geom_size[model.body_geomadr[goal]][0])
    return out, radius


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("rollouts", type=Path, help="a recorded rollouts dataset (mgdata eval --record)")
    p.add_argument("--object", default="jar", help="the body whose distance to the goal is measured")
    args = p.parse_args()
    reader = DatasetReader(args.rollouts)
    ends, closest, passed = [], [], 0
    print(f"{'scenario':<24} {'end':<8} {'steps':>5} {'end dist':>9} {'closest':>8}  "
          "steps inside (first-last)")
    for i in range(reader.num_episodes):
        origin = reader.episode(i).meta.variation["rollout"]
        if origin["end"] == "success":
            continue
        d, radius = distances(reader, i, args.object)
        inside = np.flatnonzero(d < radius)
        span = f"{len(inside)} ({inside[0]}-{inside[-1]})" if len(inside) else "0"
        print(f"{origin['scenario']:<24} {origin['end']:<8} {len(d):>5} {d[-1]:>8.3f}m {d.min():>7.3f}m  "
              f"{span}")
        ends.append(d[-1])
        closest.append(d.min())
        passed += bool(len(inside))
    if ends:
        print(f"\n{len(ends)} failed rollouts: {passed} passed through the goal sphere (radius "
              f"{radius:.3f} m); distance to its centre at the end median {np.median(ends):.3f} m, "
              f"closest median {np.median(closest):.3f} m")


if __name__ == "__main__":
    main()
