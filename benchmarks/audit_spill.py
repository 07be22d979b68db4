"""How much liquid the kept demonstrations of a dataset spilled, measured independently of ``spilled``.

For every frame of every episode it restores the stored physics state in the stored scene and counts the
liquid's particles (bodies ``<liquid>/p…``) inside the container's own bounding box (its collision geoms, in
its frame, 1 cm of headroom above the rim): raw MuJoCo geometry, not the predicate's cavity model. Prints, per
episode, the largest fraction outside over all frames, and the worst over the dataset (the spec's limit:
15 %).

Run: ``.venv/bin/python benchmarks/audit_spill.py DATASET [--container container] [--liquid liquid]``
"""

from __future__ import annotations

import argparse
from pathlib import Path

import mujoco
import numpy as np

from mgdata.record.physics import model_from_bytes, set_physics_state
from mgdata.record.reader import DatasetReader


def _box(m: mujoco.MjModel, d: mujoco.MjData, body: int) -> tuple[np.ndarray, np.ndarray]:
    rot, corners = d.xmat[body].reshape(3, 3), []
    signs = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)], dtype=float)
    for g in np.flatnonzero(m.geom_bodyid == body):
        if m.geom_contype[g] or m.geom_conaffinity[g]:
            c, h = m.geom_aabb[g, :3], m.geom_aabb[g, 3:]
            corners.append((d.geom_xpos[g] + (c + signs * h) @ d.geom_xmat[g].reshape(3, 3).T - d.xpos[body])
                           @ rot)
    local = np.concatenate(corners)
    return local.min(0), local.max(0) + np.array([0.0, 0.0, 0.01])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("dataset", type=Path)
    parser.add_argument("--container", default="container")
    parser.add_argument("--liquid", default="liquid")
    args = parser.parse_args()
    reader = DatasetReader(args.dataset)
    worst = 0.0
    for e in range(reader.num_episodes):
        ep, m = reader.episode(e), model_from_bytes(reader.scene_mjb(e))
        d = mujoco.MjData(m)
        container = m.body(args.container).id
        particles = [b for b in range(m.nbody) if m.body(b).name.startswith(f"{args.liquid}/p")]
        assert ep.physics_state is not None, "the dataset stores no physics states"
        outside = 0.0
        for state in ep.physics_state:
            set_physics_state(m, d, state)
            lo, hi = _box(m, d, container)
            local = (d.xpos[particles] - d.xpos[container]) @ d.xmat[container].reshape(3, 3)
            outside = max(outside, 1.0 - float(np.all((local >= lo) & (local <= hi), axis=1).mean()))
        worst = max(worst, outside)
        print(f"episode {e:3d} task {reader.record(e).meta.task_id:2d}: {ep.length} frames, "
              f"at most {outside:.1%} of {len(particles)} particles outside the container")
    print(f"{reader.num_episodes} episodes: worst {worst:.1%} outside (limit 15 %)")


if __name__ == "__main__":
    main()
