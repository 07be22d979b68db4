"""``on`` and ``touching`` with their gap tolerance: a sub-millimetre hop is still "on the table", a real
lift-off is "off" within one control step, a box resting on another box is on it, one beside it is not.
Contacts, gaps and heights are measured in the test from ``data.contact`` and ``mujoco.mj_geomDistance``."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

from mgdata.motion.config import load_motion_config
from mgdata.sim import robot
from mgdata.sim.controller import JointController
from mgdata.sim.labelling import Labeller
from mgdata.sim.scene import Scene, build_scene
from mgdata.sim.taskspec import ObjectPlacement
from mgdata.spec import EVALUATORS, Proposition, SafetySpec
from tests.helpers.sim_tasks import ik, task_with

DOWN = np.array([[1.0, 0.0, 0.0], [0.0, -1.0, 0.0], [0.0, 0.0, -1.0]])
GAP_TOL = next(p.default for p in EVALUATORS["on"].params if p.name == "gap_tol")


def contact_pairs(scene: Scene, a: str, b: str) -> list[float]:
    """Normal z (pointing from ``b`` into ``a``) of every current contact between geoms named ``a/…`` (or
    exactly ``a``) and ``b/…``."""
    m, d = scene.model, scene.data

    def of(g: int, name: str) -> bool:
        return m.geom(g).name == name or m.geom(g).name.startswith(name + "/")

    out = []
    for c in d.contact[: d.ncon]:
        if of(c.geom1, b) and of(c.geom2, a):
            out.append(float(c.frame[2]))
        elif of(c.geom1, a) and of(c.geom2, b):
            out.append(-float(c.frame[2]))
    return out


def gap(scene: Scene, a: str, b: str) -> float:
    """Smallest signed distance (m) between the geoms of ``a`` and ``b`` (mj_geomDistance, up to 20 cm)."""
    m, d = scene.model, scene.data
    ga = [g for g in range(m.ngeom) if m.geom(g).name.startswith(a + "/")]
    gb = [g for g in range(m.ngeom) if m.geom(g).name.startswith(b + "/")]
    return min(mujoco.mj_geomDistance(m, d, i, j, 0.2, None) for i in ga for j in gb)


def set_z(scene: Scene, name: str, z: float) -> None:
    adr = scene.model.jnt_qposadr[scene.model.joint(f"{name}/free").id]
    scene.data.qpos[adr + 2] = z
    mujoco.mj_forward(scene.model, scene.data)


@pytest.fixture(scope="module")
def stack() -> tuple[Scene, Labeller]:
    """A 8.5 cm carton standing on a 6.5 cm cube-ish carton, a third carton beside the lower one."""
    on = lambda a, b: Proposition(f"{a}_on_{b}", "on", (a,), {"support": b})  # noqa: E731
    spec = SafetySpec("t", (), (on("top", "bottom"), on("top", "table"), on("bottom", "table"),
                                on("side", "bottom"),
                                Proposition("side_touching", "touching", ("side",), {"other": "bottom"}),
                                Proposition("side_near", "touching", ("side",),
                                            {"other": "bottom", "gap_tol": 0.001})))
    lower = 0.065  # box/carton_06 is 6.5 × 6.0 × 6.5 cm
    scene = build_scene(task_with(ObjectPlacement("bottom", "box/carton_06", (0.5, -0.2, 0.0)),
                                  ObjectPlacement("top", "box/carton_02", (0.5, -0.2, lower)),
                                  ObjectPlacement("side", "box/carton_05", (0.5, -0.1, 0.0)), spec=spec))
    return scene, Labeller(scene, spec)


def test_a_box_resting_on_another_box_is_on_it_and_not_on_the_table(stack) -> None:  # type: ignore[no-untyped-def]
    scene, lab = stack
    scene.reset()
    normals = contact_pairs(scene, "top", "bottom")
    assert normals and max(normals) > 0.99, "the top box must rest on the lower one (upward normal)"
    assert not contact_pairs(scene, "top", "table") and gap(scene, "top", "table") > 0.05
    labels = lab.as_dict()
    assert labels["top_on_bottom"] and labels["bottom_on_table"] and not labels["top_on_table"]


def test_a_sub_millimetre_hop_keeps_on_and_a_millimetre_does_not(stack) -> None:  # type: ignore[no-untyped-def]
    scene, lab = stack
    for name, support, label in (("bottom", "table", "bottom_on_table"), ("top", "bottom", "top_on_bottom")):
        scene.reset()
        z0 = scene.data.qpos[scene.model.jnt_qposadr[scene.model.joint(f"{name}/free").id] + 2]
        for lift in (0.0002, 0.0004, 0.0007, 0.0015):
            set_z(scene, name, z0 + lift)
            g = gap(scene, name, support)
            assert not contact_pairs(scene, name, support) and g > 0.0, f"{name} +{lift} m must be airborne"
            if abs(g - GAP_TOL) > 5e-5:
                assert lab.as_dict()[label] is (g <= GAP_TOL), f"{name} {g * 1000:.3f} mm above {support}"


def test_a_real_hop_under_physics_never_leaves_the_table(stack) -> None:  # type: ignore[no-untyped-def]
    scene, lab = stack
    scene.reset()
    m, d = scene.model, scene.data
    d.qvel[m.jnt_dofadr[m.joint("bottom/free").id] + 2] = 0.08  # jumps 0.33 mm (v²/2g), lands after 16 ms
    airborne = 0
    for _ in range(15):  # one physics step at a time (2 ms), labelled after each
        mujoco.mj_step(m, d)
        mujoco.mj_forward(m, d)
        g = gap(scene, "bottom", "table")
        airborne += not contact_pairs(scene, "bottom", "table") and g > 5e-5
        assert g < GAP_TOL and lab.as_dict()["bottom_on_table"]
    assert airborne >= 3, "the box must really leave the table for a few physics steps"


def test_beside_is_not_on_and_touching_tolerance_is_a_parameter(stack) -> None:  # type: ignore[no-untyped-def]
    scene, lab = stack
    scene.reset()
    m, d = scene.model, scene.data
    adr = m.jnt_qposadr[m.joint("side/free").id]
    half = m.geom("bottom/body").size[1] + m.geom("side/body").size[1]
    y_bottom = d.qpos[m.jnt_qposadr[m.joint("bottom/free").id] + 1]
    for clearance, touching in ((-0.0003, True), (0.0004, False)):
        d.qpos[adr + 1] = y_bottom + half + clearance
        mujoco.mj_forward(m, d)
        normals = contact_pairs(scene, "side", "bottom")
        g = gap(scene, "side", "bottom")
        assert bool(normals) is touching and abs(g - clearance) < 1e-4
        assert all(abs(n) < 0.1 for n in normals), "a side contact has a horizontal normal"
        labels = lab.as_dict()
        assert not labels["side_on_bottom"]
        assert labels["side_touching"] is touching  # default gap_tol 0: MuJoCo contact only
        assert labels["side_near"]  # gap_tol 1 mm


def test_lift_off_at_the_linear_lift_profile_is_off_within_one_control_step() -> None:
    """A top-down grasp lifts a carton with the acceleration and speed of the planner's straight lines (the
    jar's lift): ``on(box, table)`` is true up to the last contact and false from the next step but one."""
    scene = build_scene(task_with(ObjectPlacement("box", "box/carton_03", (0.5, 0.0, 0.0)),
                                  spec=SafetySpec("t", (), (Proposition("on", "on", ("box",),
                                                                        {"support": "table"}),))))
    lab = Labeller(scene, scene.task.safety)
    scene.reset()
    ctl = JointController(scene)
    line = load_motion_config().linear
    top = scene.model.geom("box/body").size[2] * 2
    grasp = top - 0.03
    dt = scene.physics.control_dt
    t_cruise = line.speed / line.accel
    lift = [grasp + (0.5 * line.accel * t * t if t < t_cruise else
                     line.speed * (t - t_cruise) + 0.5 * line.accel * t_cruise**2)
            for t in dt * np.arange(1, 21)]
    waypoints = [(z, 0.0) for z in np.linspace(top + 0.1, grasp, 15)] + [(grasp, 1.0)] * 10
    waypoints += [(z, 1.0) for z in lift]
    q = robot.HOME_Q
    labels, touching, gaps = [], [], []
    for z, grip in waypoints:
        q = ik(q, (0.5, 0.0, z), DOWN)
        ctl.apply(np.array([*q, grip]))
        ctl.step()
        labels.append(lab.as_dict()["on"])
        touching.append(bool(contact_pairs(scene, "box", "table")))
        gaps.append(gap(scene, "box", "table"))
    t_last = max(t for t, c in enumerate(touching) if c)
    assert t_last >= 25 and gaps[-1] > 0.05, "the box must leave the table during the lift and stay off"
    assert all(labels[: t_last + 1]), "on the table until the last contact"
    assert not any(labels[t_last + 2 :]), "off from the second step without contact"
    assert gaps[t_last + 1] < 0.002, "the lift must start slowly (the test is about the first millimetre)"
    for t in range(t_last + 1, len(labels)):
        if abs(gaps[t] - GAP_TOL) > 5e-5:
            assert labels[t] is (gaps[t] <= GAP_TOL), f"step {t}: gap {gaps[t] * 1000:.3f} mm"
