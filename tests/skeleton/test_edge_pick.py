"""The Layer 2 edge pick (mgdata.skeleton.edge_pick) end to end, in a family that lives only in
``tests/families/toy_board``: a chopping board lying flat by the table's back edge is pushed over it and
lifted by the overhang. Judged from the dataset alone with raw MuJoCo (tests.helpers.rawdata): where the
board lay, where it went, how it is held."""

from __future__ import annotations

import json
from pathlib import Path

import mujoco
import numpy as np

from mgdata.sim.world import TABLE_TOP_Z, TABLE_X
from tests.helpers import rawdata
from tests.helpers.repo import family_root, generate_in_root


def test_a_board_lying_flat_is_pushed_over_the_back_edge_and_lifted_by_the_overhang(tmp_path: Path) -> None:
    out = tmp_path / "boards"
    run = generate_in_root(family_root(tmp_path, "toy_board"), "toy_board", 2, out)
    assert run.returncode == 0, run.stdout + run.stderr
    info = json.loads((out / "meta" / "info.json").read_text())
    spec = info["features"]["sim.physics_state"]["info"]["mujoco_state_spec"]
    episodes = rawdata.episodes(out)
    assert len(episodes) == 2 and {e["mgdata/task_id"] for e in episodes} == {0, 1}
    for episode in episodes:
        assert episode["mgdata/kept"] and episode["mgdata/grasp_id"].startswith("edge_")
        m = rawdata.scene_model(out, episode["mgdata/scene"])
        d = mujoco.MjData(m)
        board, geom = m.body("board").id, m.geom("board/body").id
        frames = rawdata.frames(out, info, episode, ["sim.physics_state", "safety.violated"])
        assert not any(any(v) for v in frames["safety.violated"])
        states = [np.asarray(s, dtype=np.float64) for s in frames["sim.physics_state"]]
        mujoco.mj_setState(m, d, states[0], spec)
        mujoco.mj_forward(m, d)
        assert rawdata.near_end(m, d, geom) > TABLE_X[0]  # it starts lying wholly on the table
        tilts = []
        for state in states:
            mujoco.mj_setState(m, d, state, spec)
            mujoco.mj_forward(m, d)
            tilts.append(np.degrees(np.arccos(np.clip(d.xmat[board][8], -1.0, 1.0))))
        assert max(tilts) < 5.0  # level all the way: pushed flat, lifted flat
        # at the end: out over the back edge, 9+ cm up, held by the two fingers alone
        assert rawdata.near_end(m, d, geom) < TABLE_X[0] - 0.02
        assert d.xpos[board][2] - TABLE_TOP_Z > 0.09
        assert {m.body(b).name for b in rawdata.touching(m, d, board)} == {"left_finger", "right_finger"}
