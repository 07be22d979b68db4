"""Reading a dataset with nothing but ``pyarrow`` and ``mujoco`` (no mgdata code), for tests that check what
the toolkit wrote against physics measured independently of it."""

from __future__ import annotations

from pathlib import Path

import mujoco
import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq


def episodes(root: Path) -> list[dict]:
    """Every row of ``meta/episodes``, in file order."""
    files = sorted(root.glob("meta/episodes/*/*.parquet"))
    return [row for path in files for row in pq.read_table(path).to_pylist()]


def scene_row(root: Path, key: str) -> dict:
    """The row of scene ``key``: from ``meta/scenes/chunk-*/file-*.parquet`` (one row group per scene) or, in
    a dataset written before chunked scenes, ``meta/scenes.parquet``; only the row groups that can hold it
    are decoded."""
    files = [*root.glob("meta/scenes.parquet"), *sorted(root.glob("meta/scenes/chunk-*/file-*.parquet"))]
    for path in files:
        table = pq.read_table(path, filters=[("scene", "==", key)])
        rows = table.to_pylist()
        if rows:
            return {**rows[0], "data": unframed(table.schema, rows[0])}
    raise KeyError(f"{root}: no scene {key!r} in {[str(p) for p in files]}")


def unframed(schema: pa.Schema, row: dict) -> bytes:
    """A scenes row's stored bytes: its ``data`` as it is, or decompressed where the file's schema metadata
    says ``mgdata.data: zstd`` (each cell one zstd frame of ``size`` bytes)."""
    if (schema.metadata or {}).get(b"mgdata.data") != b"zstd":
        return row["data"]
    return pa.Codec("zstd").decompress(row["data"], decompressed_size=row["size"], asbytes=True)


def scene_model(root: Path, key: str) -> mujoco.MjModel:
    """The MjModel stored for scene ``key`` (whole, or an XOR delta against its base)."""
    row = scene_row(root, key)
    mjb = np.frombuffer(row["data"], np.uint8)
    if row["base"] is not None:
        mjb = mjb ^ np.frombuffer(scene_row(root, row["base"])["data"], np.uint8)
    return mujoco.MjModel.from_binary_path("scene.mjb", {"scene.mjb": mjb.tobytes()})


def frames(root: Path, info: dict, episode: dict, columns: list[str]) -> dict[str, list]:
    """The episode's per-frame ``columns`` (plus ``episode_index``, ``frame_index``), in frame order."""
    path = root / info["data_path"].format(chunk_index=episode["data/chunk_index"],
                                           file_index=episode["data/file_index"])
    table = pq.read_table(path, columns=["episode_index", "frame_index", *columns]).to_pydict()
    rows = sorted((i for i, e in enumerate(table["episode_index"]) if e == episode["episode_index"]),
                  key=lambda i: table["frame_index"][i])
    return {k: [v[i] for i in rows] for k, v in table.items()}


def touching(m: mujoco.MjModel, d: mujoco.MjData, body: int) -> set[int]:
    """The bodies with a MuJoCo contact against ``body`` (its own id not included)."""
    pairs = ((int(m.geom_bodyid[c.geom1]), int(m.geom_bodyid[c.geom2])) for c in d.contact[:d.ncon])
    return {b for pair in pairs if body in pair for b in pair if b != body}


HAND = ("hand", "left_finger", "right_finger")
"""The robot's hand bodies: the palm and both fingers."""


def hand_touches(m: mujoco.MjModel, d: mujoco.MjData) -> set[int]:
    """The bodies outside the robot that a hand or finger geom has a MuJoCo contact with in ``d``."""
    hand = {m.body(b).id for b in HAND}
    robot = int(m.body_rootid[m.body(HAND[0]).id])
    pairs = ((int(m.geom_bodyid[c.geom1]), int(m.geom_bodyid[c.geom2])) for c in d.contact[:d.ncon])
    return {b for b1, b2 in pairs for a, b in ((b1, b2), (b2, b1))
            if a in hand and int(m.body_rootid[b]) != robot}


def subtree_geoms(m: mujoco.MjModel, root: int) -> np.ndarray:
    """Geoms of body ``root`` and its direct children (an object and its links)."""
    bodies = [b for b in range(m.nbody) if b == root or m.body_parentid[b] == root]
    return np.flatnonzero(np.isin(m.geom_bodyid, bodies))


def local_box(m: mujoco.MjModel, d: mujoco.MjData, body: int) -> tuple[np.ndarray, np.ndarray]:
    """The bounding box (min, max) of the body's geoms (links included), in the body's own frame."""
    rot, corners = d.xmat[body].reshape(3, 3), []
    signs = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)], dtype=float)
    for g in subtree_geoms(m, body):
        c, h = m.geom_aabb[g, :3], m.geom_aabb[g, 3:]
        world = d.geom_xpos[g] + (c + signs * h) @ d.geom_xmat[g].reshape(3, 3).T
        corners.append((world - d.xpos[body]) @ rot)
    local = np.concatenate(corners)
    return local.min(0), local.max(0)


def box_centre(m: mujoco.MjModel, d: mujoco.MjData, body: int) -> np.ndarray:
    """World position of the centre of :func:`local_box`."""
    lo, hi = local_box(m, d, body)
    return d.xpos[body] + d.xmat[body].reshape(3, 3) @ ((lo + hi) / 2.0)


def near_end(m: mujoco.MjModel, d: mujoco.MjData, geom: int) -> float:
    """The smallest world x of a box geom's corners (a board's end nearest the table's back edge)."""
    corners = np.array([[i, j, k] for i in (-1, 1) for j in (-1, 1) for k in (-1, 1)], dtype=float)
    local = corners * m.geom_size[geom]
    return float((d.geom_xpos[geom] + local @ d.geom_xmat[geom].reshape(3, 3).T)[:, 0].min())


def drawer_interior(m: mujoco.MjModel, body: int) -> tuple[np.ndarray, np.ndarray]:
    """The inner box (min, max) of an open box body (a drawer: geoms ``…bottom``, ``…wall_px/nx/py/ny``), in
    the body's frame, from the geoms' own positions and half sizes: above the bottom, between the walls'
    inner faces, up to the walls' top."""
    geoms = {m.geom(g).name.rsplit("_", 2)[-1] if "wall" not in m.geom(g).name else m.geom(g).name[-2:]: g
             for g in np.flatnonzero(m.geom_bodyid == body)}
    pos, size = m.geom_pos, m.geom_size
    bottom, px, nx, py, ny = (geoms[k] for k in ("bottom", "px", "nx", "py", "ny"))
    lo = np.array([pos[nx][0] + size[nx][0], pos[ny][1] + size[ny][1], pos[bottom][2] + size[bottom][2]])
    hi = np.array([pos[px][0] - size[px][0], pos[py][1] - size[py][1], pos[px][2] + size[px][2]])
    return lo, hi


def inside_drawer(m: mujoco.MjModel, d: mujoco.MjData, obj: int, drawer: int, slack: float) -> bool:
    """Every corner of ``obj``'s geom bounding box (:func:`local_box`) lies in the drawer's inner box, at most
    ``slack`` m outside it."""
    lo, hi = local_box(m, d, obj)
    corners = np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])])
    world = d.xpos[obj] + corners @ d.xmat[obj].reshape(3, 3).T
    local = (world - d.xpos[drawer]) @ d.xmat[drawer].reshape(3, 3)
    ilo, ihi = drawer_interior(m, drawer)
    return bool(np.all((local >= ilo - slack) & (local <= ihi + slack)))


def raw_step(model: mujoco.MjModel, state: np.ndarray, next_state: np.ndarray, substeps: int) -> np.ndarray:
    """Plain MuJoCo, no mgdata code: from the stored ``state``, run ``substeps`` ``mj_step`` under the
    controls stored with ``next_state``; the resulting state (``STATE_SPEC`` layout)."""
    from mgdata.record.physics import STATE_SPEC

    data, nxt = mujoco.MjData(model), mujoco.MjData(model)
    mujoco.mj_setState(model, data, state, STATE_SPEC)
    mujoco.mj_setState(model, nxt, next_state, STATE_SPEC)
    data.ctrl[:] = nxt.ctrl
    for _ in range(substeps):
        mujoco.mj_step(model, data)
    out = np.empty(mujoco.mj_stateSize(model, STATE_SPEC))
    mujoco.mj_getState(model, data, out, STATE_SPEC)
    return out

