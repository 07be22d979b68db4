"""Kept means succeeded, checked from the dataset alone.

A small jar dataset is generated with the real CLI; then, with nothing but ``mujoco``, ``pyarrow`` and
``numpy`` (no mgdata code), each kept episode's stored scene is loaded, its stored physics states are
restored, and the last ``hold_steps`` frames are measured from raw MuJoCo data: the jar's bounding-volume
centre inside the goal sphere, the lid shut, both fingers touching the jar, no contact between the jar and the
table, the jar at rest.
The per-step columns are checked too: no violation flag on any frame of a kept episode.
"""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import mujoco
import numpy as np
import pytest

from tests.helpers import rawdata
from tests.helpers.generate import jar_recipe

MGDATA = [str(Path(sys.executable).parent / "mgdata")]
LID_SHUT_RAD = np.deg2rad(5.0)  # hinge angle from its closed stop
AT_REST_M_S, AT_REST_RAD_S = 0.01, 0.1  # jar speed



@pytest.fixture(scope="module")
def dataset(tmp_path_factory: pytest.TempPathFactory) -> Path:
    tmp = tmp_path_factory.mktemp("trust")
    out = tmp / "jar"
    cmd = [*MGDATA, "generate", "--family", "jar", "--n", "3", "--out", str(out), "--recipe",
           str(jar_recipe(tmp)), "--tasks", "2-4", "--workers", "1"]
    proc = subprocess.run(cmd, capture_output=True, text=True, timeout=900)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    return out


def test_kept_jar_demos_end_at_rest_in_the_goal_measured_from_the_dataset_alone(dataset: Path) -> None:
    info = json.loads((dataset / "meta/info.json").read_text())
    hold = int(info["mgdata"]["hold_steps"])
    spec = info["features"]["sim.physics_state"]["info"]["mujoco_state_spec"]
    episodes = rawdata.episodes(dataset)
    assert len(episodes) == 3 and all(e["mgdata/kept"] for e in episodes)
    for episode in episodes:
        m = rawdata.scene_model(dataset, episode["mgdata/scene"])
        d = mujoco.MjData(m)
        jar, table = m.body("jar").id, m.body("table").id
        jar_geoms = rawdata.subtree_geoms(m, jar)
        fingers = [np.flatnonzero(m.geom_bodyid == m.body(b).id) for b in ("left_finger", "right_finger")]
        table_geoms = np.flatnonzero(m.geom_bodyid == table)
        goal = m.site("goal").id
        hinge = m.joint("jar/lid_hinge")
        free = m.joint("jar/free")
        frames = rawdata.frames(dataset, info, episode,
                                ["sim.physics_state", "safety.violated", "safety.success"])
        n = len(frames["frame_index"])
        assert not any(any(v) for v in frames["safety.violated"]), f"episode {episode['episode_index']}"
        for t in range(n - hold, n):
            mujoco.mj_setState(m, d, np.asarray(frames["sim.physics_state"][t], dtype=np.float64), spec)
            mujoco.mj_forward(m, d)
            where = f"episode {episode['episode_index']} frame {t}"
            gap = np.linalg.norm(rawdata.box_centre(m, d, jar) - d.site_xpos[goal])
            assert gap < m.site_size[goal, 0], f"{where}: jar centre {gap * 100:.1f} cm from the goal centre"
            assert abs(d.qpos[m.jnt_qposadr[hinge.id]]) < LID_SHUT_RAD, f"{where}: lid open"
            pairs = {(int(c.geom1), int(c.geom2)) for c in d.contact[: d.ncon]}
            touching = [any((a in f and b in jar_geoms) or (b in f and a in jar_geoms) for a, b in pairs)
                        for f in fingers]
            assert all(touching), f"{where}: fingers touching the jar: {touching}"
            on_table = any((a in table_geoms and b in jar_geoms) or (b in table_geoms and a in jar_geoms)
                           for a, b in pairs)
            assert not on_table, f"{where}: the jar touches the table"
            v = d.qvel[m.jnt_dofadr[free.id]: m.jnt_dofadr[free.id] + 6]
            assert np.linalg.norm(v[:3]) < AT_REST_M_S and np.linalg.norm(v[3:]) < AT_REST_RAD_S, where
            assert frames["safety.success"][t], f"{where}: success column false in the hold"
