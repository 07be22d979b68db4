"""How much liquid the kept demonstrations of a dataset spilled, measured independently of ``spilled``.

Reads the dataset with ``pyarrow`` and ``mujoco`` only: for every frame of every episode it restores the
stored physics state and counts the liquid's particles (bodies ``<liquid>/p…``) inside the container's own
bounding box (its collision geoms, in its frame, 1 cm of headroom above the rim). Prints, per episode, the
largest fraction outside over all frames, and the worst over the dataset (the spec's limit: 15 %).

Run: ``.venv/bin/python benchmarks/audit_spill.py DATASET [--container container] [--liquid liquid]``
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import mujoco
import numpy as np
import pyarrow.parquet as pq


def _model(root: Path, key: str) -> mujoco.MjModel:
    scenes = {row["scene"]: row for row in pq.read_table(root / "meta/scenes.parquet").to_pylist()}
    row = scenes[key]
    mjb = np.frombuffer(row["data"], np.uint8)
    if row["base"] is not None:
        mjb = mjb ^ np.frombuffer(scenes[row["base"]]["data"], np.uint8)
    return mujoco.MjModel.from_binary_path("scene.mjb", {"scene.mjb": mjb.tobytes()})


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
    root = args.dataset
    info = json.loads((root / "meta" / "info.json").read_text())
    spec = info["features"]["sim.physics_state"]["info"]["mujoco_state_spec"]
    files = sorted(root.glob("meta/episodes/*/*.parquet"))
    episodes = [r for p in files for r in pq.read_table(p).to_pylist()]
    worst = 0.0
    for ep in episodes:
        m = _model(root, ep["mgdata/scene"])
        d = mujoco.MjData(m)
        container = m.body(args.container).id
        particles = [b for b in range(m.nbody) if m.body(b).name.startswith(f"{args.liquid}/p")]
        path = root / info["data_path"].format(chunk_index=ep["data/chunk_index"],
                                               file_index=ep["data/file_index"])
        table = pq.read_table(path, columns=["episode_index", "sim.physics_state"]).to_pydict()
        states = [s for e, s in zip(table["episode_index"], table["sim.physics_state"], strict=True)
                  if e == ep["episode_index"]]
        outside = 0.0
        for state in states:
            mujoco.mj_setState(m, d, np.asarray(state, dtype=np.float64), spec)
            mujoco.mj_forward(m, d)
            lo, hi = _box(m, d, container)
            local = (d.xpos[particles] - d.xpos[container]) @ d.xmat[container].reshape(3, 3)
            outside = max(outside, 1.0 - float(np.all((local >= lo) & (local <= hi), axis=1).mean()))
        worst = max(worst, outside)
        print(f"episode {ep['episode_index']:3d} task {ep['mgdata/task_id']:2d}: {len(states)} frames, "
              f"at most {outside:.1%} of {len(particles)} particles outside the container")
    print(f"{len(episodes)} episodes: worst {worst:.1%} outside (limit 15 %)")


if __name__ == "__main__":
    main()
