"""Geometric helpers behind the predicates: the lowest-point bound never overshoots, fixed tops match the
world conventions, ``GeomGaps`` agrees with MuJoCo's own distances and skips only far pairs."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from mgdata.sim.geometry import FlatTop, GeomGaps, LowestPoint
from mgdata.sim.scene import Scene, build_scene
from mgdata.sim.taskspec import ObjectPlacement
from mgdata.sim.world import FLOOR_Z, TABLE_TOP_Z, TABLE_X, TABLE_Y
from tests.helpers.sim_tasks import task_with


@pytest.fixture(scope="module")
def scene() -> Scene:
    return build_scene(task_with(ObjectPlacement("jar", "jar/hinged_03", (0.5, 0.0, 0.0)),
                                 ObjectPlacement("cup", "cup/tumbler_00", (0.5, 0.3, 0.0))))


def pose(scene: Scene, name: str, pos: tuple[float, ...], quat: tuple[float, ...]) -> None:
    adr = scene.model.jnt_qposadr[scene.model.joint(f"{name}/free").id]
    scene.data.qpos[adr : adr + 3] = pos
    scene.data.qpos[adr + 3 : adr + 7] = np.asarray(quat) / np.linalg.norm(quat)
    mujoco.mj_forward(scene.model, scene.data)


def test_fixed_tops_are_the_table_and_the_floor(scene: Scene) -> None:
    m, d = scene.model, scene.data
    table, floor = FlatTop(m, d, m.geom("table/top").id), FlatTop(m, d, m.geom("floor").id)
    assert table.z == pytest.approx(TABLE_TOP_Z) and floor.z == pytest.approx(FLOOR_Z)
    assert np.allclose(table.lo, [TABLE_X[0], TABLE_Y[0]]) and np.allclose(table.hi, [TABLE_X[1], TABLE_Y[1]])
    assert table.overlaps(np.array([1.0, 0.7]), np.array([1.2, 0.9]))
    assert not table.overlaps(np.array([1.06, 0.0]), np.array([1.2, 0.1]))
    assert floor.overlaps(np.array([50.0, 50.0]), np.array([51.0, 51.0]))
    with pytest.raises(ValueError, match="not a world-fixed"):
        FlatTop(m, d, int(scene.object_geom_ids("jar")[0]))


@settings(max_examples=60, deadline=None)
@given(pos=st.tuples(st.floats(0.3, 0.7), st.floats(-0.3, 0.3), st.floats(-0.2, 0.4)),
       quat=st.tuples(*[st.floats(-1.0, 1.0)] * 4).filter(lambda q: np.linalg.norm(q) > 0.1),
       z=st.floats(-0.3, 0.5))
def test_lowest_point_bound_and_below(scene: Scene, pos, quat, z) -> None:  # type: ignore[no-untyped-def]
    pose(scene, "jar", pos, quat)
    m, d = scene.model, scene.data
    low = LowestPoint(m, scene.object_geom_ids("jar"))
    exact = low(d)
    # independent: every vertex of the jar's convex collision meshes, and 720 points on each rim of its
    # cylinder (the hinge pin), in world coordinates
    verts = []
    a = np.linspace(0.0, 2.0 * np.pi, 720)
    for g in scene.object_geom_ids("jar"):
        if m.geom_type[g] == mujoco.mjtGeom.mjGEOM_MESH:
            mesh = m.geom_dataid[g]
            v = m.mesh_vert[m.mesh_vertadr[mesh] : m.mesh_vertadr[mesh] + m.mesh_vertnum[mesh]]
        else:
            assert m.geom_type[g] == mujoco.mjtGeom.mjGEOM_CYLINDER
            r, h = m.geom_size[g, :2]
            rim = [np.stack([r * np.cos(a), r * np.sin(a), np.full_like(a, z)], 1) for z in (-h, h)]
            v = np.concatenate(rim)
        verts.append(d.geom_xpos[g] + v @ d.geom_xmat[g].reshape(3, 3).T)
    assert exact == pytest.approx(float(np.concatenate(verts)[:, 2].min()), abs=1e-6)
    assert low.lower_bound(d) <= exact + 1e-12
    if abs(exact - z) > 1e-9:
        assert low.below(d, z) is (exact < z)


def test_geom_gaps_match_mujoco_distances(scene: Scene) -> None:
    m, d = scene.model, scene.data
    jar, cup = scene.object_geom_ids("jar"), scene.object_geom_ids("cup")
    pose(scene, "jar", (0.5, 0.0, 0.0), (1.0, 0.0, 0.0, 0.0))  # the property test above left it anywhere
    for dy in (0.2, 0.08, 0.0705, 0.069):
        pose(scene, "cup", (0.5, dy, 0.0), (1.0, 0.0, 0.0, 0.0))
        true = min(mujoco.mj_geomDistance(m, d, int(a), int(b), 1.0, None) for a in cup for b in jar)
        gaps = GeomGaps(m, cup, jar, 0.005)
        near = gaps.near(d)
        if true < 0.005:
            assert min(g for g, _ in near) == pytest.approx(true, abs=1e-9)
            for dist, up in near:
                if dist > 0:
                    assert up[1] > 0.9, "the direction points from the jar towards the cup (+Y)"
        else:
            assert not near and gaps.min(d) == 0.005
