"""The family contract of a kept demo, checked from raw MuJoCo on a dataset's stored states (the recipe and
spec files read as plain TOML, not through mgdata): shared by the family tests and the corrections tests."""

from __future__ import annotations

import fnmatch
import itertools
import json
import tomllib
from pathlib import Path

import mujoco
import numpy as np

from mgdata.paths import recipes_dir
from tests.helpers import rawdata

AT_REST_M_S = 0.01
FLOOR_MARGIN_M = 0.05  # "dropped": below the floor + 5 cm (reference-implementation.md §2)


def raw_recipe(family: str) -> dict:
    return tomllib.loads((recipes_dir() / f"{family}.toml").read_text())


def raw_spec(family: str) -> dict:
    raw = raw_recipe(family)
    return tomllib.loads((recipes_dir() / raw["spec"]).read_text())



def check_kept_contract(family: str, root: Path) -> None:
    """Every episode of the dataset at ``root`` is, from raw MuJoCo on its stored states alone, what a kept
    ``family`` demo promises: no violation recorded, nothing on the floor, upright objects upright, liquid
    in its container, and over the last ``hold_steps`` frames the goal met (the picked object held by both
    fingers off the table inside the goal sphere, or the recipe's ``inside`` objects in their container, a
    drawer closed, dust wiped) and at rest."""
    raw, spec = raw_recipe(family), raw_spec(family)
    picked = next((p["subjects"][0] for p in raw["success"].values() if p["evaluator"] == "in_region"), None)
    inside = [(p["subjects"][0], p["params"]["container"]) for p in raw["success"].values()
              if p["evaluator"] == "inside"]  # e.g. dusty: the food inside the tray, nothing held
    clean = any(p["evaluator"] == "clean" for p in raw["success"].values())
    hold = raw["tasks"]["hold_steps"]
    upright = [(p["subjects"][0], p["params"]["max_tilt_deg"]) for p in spec["propositions"].values()
               if p["evaluator"] == "upright"]
    info = json.loads((root / "meta" / "info.json").read_text())
    for episode in rawdata.episodes(root):
        m = rawdata.scene_model(root, episode["mgdata/scene"])
        d = mujoco.MjData(m)
        frames = rawdata.frames(root, info, episode, ["sim.physics_state", "safety.violated"])
        assert episode["mgdata/kept"] and not any(any(v) for v in frames["safety.violated"])
        objects = [m.body(b).name for b in range(m.nbody) if m.body_parentid[b] == 0 and m.body_jntnum[b]
                   and "/" not in m.body(b).name]
        liquids = sorted({m.body(b).name.split("/")[0] for b in range(m.nbody) if "/p" in m.body(b).name})
        centres = []
        state_spec = info["features"]["sim.physics_state"]["info"]["mujoco_state_spec"]
        for t, state in enumerate(frames["sim.physics_state"]):
            mujoco.mj_setState(m, d, np.asarray(state, dtype=np.float64), state_spec)
            mujoco.mj_forward(m, d)
            for name in objects:  # nothing reached the floor
                assert d.xpos[m.body(name).id][2] > m.geom("floor").pos[2] + FLOOR_MARGIN_M, (t, name)
            for pattern, limit in upright:
                for name in fnmatch.filter(objects, pattern):
                    z_axis = d.xmat[m.body(name).id].reshape(3, 3)[:, 2]
                    assert np.degrees(np.arccos(np.clip(z_axis[2], -1, 1))) <= limit + 1e-6, (t, name)
            for liquid in liquids:
                assert fraction_inside(m, d, liquid, picked) >= 0.85, (t, liquid)
            if t >= len(frames["sim.physics_state"]) - hold and picked is not None:
                body = m.body(picked).id
                centres.append(rawdata.box_centre(m, d, body))
                fingers = [touching(m, d, f, body) for f in ("left_finger", "right_finger")]
                assert all(fingers), (t, "both fingers on the object")
                assert not touching(m, d, "table", body), (t, "the table does not support it")
                goal = m.geom("goal")
                assert np.linalg.norm(centres[-1] - d.geom_xpos[goal.id]) < m.geom_size[goal.id][0], t
            if t >= len(frames["sim.physics_state"]) - hold and inside:
                for obj, container in inside:
                    body = m.body(obj).id
                    if mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, f"{container}/drawer") >= 0:
                        drawer = m.body(f"{container}/drawer")  # in a closed drawer
                        assert rawdata.inside_drawer(m, d, body, drawer.id, 0.005), (t, obj)
                        slide = drawer.jntadr[0]
                        assert d.qpos[m.jnt_qposadr[slide]] <= 0.05 * m.jnt_range[slide][1], (t, "closed")
                        centres.append(rawdata.box_centre(m, d, body))
                        continue
                    host = m.body(container).id  # its box centre inside the container's own bounding box
                    lo, hi = rawdata.local_box(m, d, host)
                    local = (rawdata.box_centre(m, d, body) - d.xpos[host]) @ d.xmat[host].reshape(3, 3)
                    assert np.all((local >= lo) & (local <= hi)), (t, obj, "inside", container)
                    centres.append(rawdata.box_centre(m, d, body))
                if clean:  # every dust speck parked below the floor (wiped)
                    specks = [m.body_mocapid[b] for b in range(m.nbody) if "/d" in m.body(b).name
                              and m.body_mocapid[b] >= 0]
                    assert np.all(d.mocap_pos[specks, 2] < m.geom("floor").pos[2]), (t, "dust left")
        dt = 1.0 / info["fps"]
        speeds = [np.linalg.norm(b - a) / dt for a, b in itertools.pairwise(centres)]
        assert max(speeds) <= AT_REST_M_S


def touching(m: mujoco.MjModel, d: mujoco.MjData, body_name: str, body: int) -> bool:
    mine = set(rawdata.subtree_geoms(m, body).tolist())
    other = set(np.flatnonzero(m.geom_bodyid == m.body(body_name).id).tolist())
    return any((c.geom1 in mine and c.geom2 in other) or (c.geom2 in mine and c.geom1 in other)
               for c in d.contact[:d.ncon] if c.dist <= 0.0005)


def fraction_inside(m: mujoco.MjModel, d: mujoco.MjData, liquid: str, container: str) -> float:
    """Particles inside the container's bounding box (its frame; 1 cm of headroom above the rim)."""
    body = m.body(container).id
    lo, hi = rawdata.local_box(m, d, body)
    pts = np.array([d.xpos[b] for b in range(m.nbody) if m.body(b).name.startswith(f"{liquid}/p")])
    local = (pts - d.xpos[body]) @ d.xmat[body].reshape(3, 3)
    inside = np.all((local >= lo) & (local <= hi + np.array([0.0, 0.0, 0.01])), axis=1)
    return float(inside.mean())
