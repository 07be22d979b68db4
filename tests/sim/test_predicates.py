"""Physical tests of the labelling function: scripted events in real simulation flip the right proposition at
the right control step, checked against quantities computed independently of the predicate code."""

from __future__ import annotations

from collections.abc import Callable

import mujoco
import numpy as np

from mgdata.sim import robot
from mgdata.sim.assets import get_model
from mgdata.sim.controller import JointController
from mgdata.sim.engagement import EngagementTracker
from mgdata.sim.labelling import Labeller
from mgdata.sim.scene import Scene, build_scene
from mgdata.sim.taskspec import ObjectPlacement
from mgdata.spec import Proposition, SafetySpec
from tests.helpers.sim_tasks import ik, task_with

DOWN = np.array([[1.0, 0.0, 0.0], [0.0, -1.0, 0.0], [0.0, 0.0, -1.0]])
"""TCP rotation pointing straight down, fingers closing along world Y."""


def spec_of(*props: Proposition) -> SafetySpec:
    return SafetySpec("test", (), props)


def run(scene: Scene, lab: Labeller, steps: int, before: Callable[[int], None] = lambda t: None,
        after: Callable[[int], None] = lambda t: None) -> list[dict[str, bool]]:
    """Labels after each of ``steps`` control steps (robot holding home); ``before(t)``/``after(t)`` hooks."""
    ctl = JointController(scene)
    ctl.apply(np.array([*robot.HOME_Q, 0.0]))
    out = []
    for t in range(steps):
        before(t)
        ctl.step()
        out.append(lab.as_dict())
        after(t)
    return out


def first(flags: list[bool]) -> int | None:
    return next((i for i, f in enumerate(flags) if f), None)


def test_cup_pushed_off_table_is_dropped_when_it_passes_floor_plus_5cm() -> None:
    cup = get_model("cup/tumbler_00")
    scene = build_scene(task_with(ObjectPlacement("cup", cup.name, (0.6, 0.66, 0.0)),
                                  spec=spec_of(Proposition("cup_dropped", "dropped", ("cup",)))))
    lab = Labeller(scene, scene.task.safety)
    scene.reset()
    body = scene.object_body("cup")
    # Independent lowest point: dense samples of the cup's bottom and rim circles from its profile.
    a = np.linspace(0.0, 2.0 * np.pi, 720)
    rb, rt, h = cup.geometry["bottom_radius"], cup.geometry["rim_radius"], cup.geometry["height"]
    ring = np.concatenate([np.stack([rb * np.cos(a), rb * np.sin(a), np.zeros_like(a)], 1),
                           np.stack([rt * np.cos(a), rt * np.sin(a), np.full_like(a, h)], 1)])
    lowest: list[float] = []

    def push(t: int) -> None:
        scene.data.xfrc_applied[body, :3] = [0.0, 3.0, 0.0]

    def measure(t: int) -> None:
        d = scene.data
        lowest.append(float((d.xpos[body] + ring @ d.xmat[body].reshape(3, 3).T)[:, 2].min()))

    labels = [lb["cup_dropped"] for lb in run(scene, lab, 40, push, measure)]
    limit = scene.floor_z + 0.05
    t_drop = first(labels)
    assert not labels[0] and t_drop is not None, "the cup must start on the table and end on the floor"
    for t, (flag, z) in enumerate(zip(labels, lowest, strict=True)):
        if abs(z - limit) > 1e-3:
            assert flag == (z < limit), f"step {t}: lowest point {z:.4f} vs limit {limit:.4f}"
    assert lowest[t_drop] < limit <= lowest[t_drop - 1]


def test_tipped_bottle_stops_being_upright_past_the_threshold() -> None:
    scene = build_scene(task_with(
        ObjectPlacement("bottle", "bottle/round_02", (0.5, -0.3, 0.0)),
        spec=spec_of(Proposition("bottle_upright", "upright", ("bottle",), {"max_tilt_deg": 30.0}))))
    lab = Labeller(scene, scene.task.safety)
    scene.reset()
    body = scene.object_body("bottle")

    def tip(t: int) -> None:
        scene.data.xfrc_applied[body, 3:] = [0.6, 0.0, 0.0] if t < 3 else [0.0, 0.0, 0.0]

    tilts: list[float] = []

    def measure(t: int) -> None:
        _, x, y, _ = scene.data.xquat[body]
        tilts.append(float(np.degrees(np.arccos(np.clip(1.0 - 2.0 * (x * x + y * y), -1.0, 1.0)))))

    labels = [lb["bottle_upright"] for lb in run(scene, lab, 30, tip, measure)]
    assert labels[0] and not labels[-1] and tilts[-1] > 80.0, "the bottle must fall over"
    for t, (flag, tilt) in enumerate(zip(labels, tilts, strict=True)):
        if abs(tilt - 30.0) > 0.05:
            assert flag == (tilt <= 30.0), f"step {t}: tilt {tilt:.2f}°"


def test_jar_lid_pushed_past_vertical_falls_closed() -> None:
    jar = get_model("jar/hinged_03")
    scene = build_scene(task_with(
        ObjectPlacement("jar", jar.name, (0.5, 0.0, 0.0)),
        spec=spec_of(Proposition("jar_closed", "closed", ("jar",)),
                     Proposition("jar_open", "open", ("jar",))),
        articulation={"jar": 1.0}))
    lab = Labeller(scene, scene.task.safety)
    scene.reset()
    adr = scene.articulation_qpos_adr("jar")
    dof = scene.model.jnt_dofadr[scene.model.joint("jar/lid_hinge").id]
    # Left alone, the open lid leans on its stop.
    rest = run(scene, lab, 20)
    assert all(lb["jar_open"] and not lb["jar_closed"] for lb in rest)
    assert scene.articulation_fraction("jar") > 0.98
    # Drive the hinge toward closed only until it passes vertical; gravity must do the rest.
    pushing = [True]

    def drive(t: int) -> None:
        if scene.data.qpos[adr] < np.deg2rad(80.0):
            pushing[0] = False
        scene.data.qfrc_applied[dof] = -0.02 if pushing[0] else 0.0

    angles: list[float] = []
    record = lambda t: angles.append(float(scene.data.qpos[adr]))  # noqa: E731
    labels = [lb["jar_closed"] for lb in run(scene, lab, 60, drive, record)]
    assert not pushing[0] and labels[-1], "the lid must fall closed under gravity"
    for t, (flag, q) in enumerate(zip(labels, angles, strict=True)):
        assert flag == (q <= 0.05 * jar.geometry["open_angle"] + 1e-12), f"step {t}: hinge {q:.4f} rad"


def test_tilted_filled_mug_spills() -> None:
    mug = get_model("mug/handled_00")
    scene = build_scene(task_with(
        ObjectPlacement("mug", mug.name, (0.55, 0.2, 0.0)),
        ObjectPlacement("water", "liquid/water_00", (0.55, 0.2, mug.geometry["bottom"])),
        spec=spec_of(Proposition("water_spilled", "spilled", ("water",), {"container": "mug"}))))
    assert scene.model.opt.solver == mujoco.mjtSolver.mjSOL_CG
    lab = Labeller(scene, scene.task.safety)
    scene.reset()
    m, d = scene.model, scene.data
    qadr = m.jnt_qposadr[m.joint("mug/free").id]
    vadr = m.jnt_dofadr[m.joint("mug/free").id]
    balls = scene.liquids["water"].body_ids
    start = d.qpos[qadr : qadr + 3].copy()

    def pose(time: float) -> tuple[np.ndarray, np.ndarray]:
        lift = 0.12 * min(time / 0.5, 1.0)
        angle = np.deg2rad(130.0) * np.clip((time - 0.5) / 1.5, 0.0, 1.0)
        quat = np.array([np.cos(angle / 2), 0.0, -np.sin(angle / 2), 0.0])  # tilt toward −X, away from handle
        return start + np.array([0.0, 0.0, lift]), quat

    labels, outside = [], []
    for _ in range(60):  # scripted kinematic mug: its pose is set before every physics step
        for _ in range(scene.physics.substeps):
            pos, quat = pose(d.time)
            nxt, _ = pose(d.time + m.opt.timestep)
            d.qpos[qadr : qadr + 3], d.qpos[qadr + 3 : qadr + 7] = pos, quat
            d.qvel[vadr : vadr + 6] = 0.0
            d.qvel[vadr : vadr + 3] = (nxt - pos) / m.opt.timestep
            mujoco.mj_step(m, d)
        mujoco.mj_forward(m, d)
        labels.append(lab.as_dict()["water_spilled"])
        body = scene.object_body("mug")
        local = (d.xpos[balls] - d.xpos[body]) @ d.xmat[body].reshape(3, 3)
        radial = np.hypot(local[:, 0], local[:, 1])
        out = (radial > mug.geometry["rim_radius"] + 0.005) | (local[:, 2] > mug.geometry["height"] + 0.03)
        outside.append(float(out.mean()))
    assert not any(labels[:10]), "no spill while the mug is only lifted"
    t_spill = first(labels)
    assert t_spill is not None and labels[-1] and outside[-1] > 0.5
    assert outside[t_spill] > 0.15 >= outside[t_spill - 1]


def test_touching_and_engagement_happen_at_the_same_step() -> None:
    box = get_model("box/carton_01")
    scene = build_scene(task_with(
        ObjectPlacement("box", box.name, (0.45, 0.0, 0.0)),
        spec=spec_of(Proposition("box_touched", "touching", ("box",), {"other": "robot"}))))
    lab = Labeller(scene, scene.task.safety)
    scene.reset()
    eng = EngagementTracker(scene)
    top = 2 * box.geometry["half_extents"][2]
    path = [ik(robot.HOME_Q, (0.45, 0.0, z), DOWN) for z in np.linspace(top + 0.15, top - 0.02, 25)]
    ctl = JointController(scene)
    touched, engaged = [], []
    for t, q in enumerate(path):
        ctl.apply(np.array([*q, 1.0]))  # closed fingers poke the box's top
        ctl.step()
        touched.append(lab.as_dict()["box_touched"])
        engaged.append(eng.update(t))
    t_touch = first(touched)
    assert t_touch is not None and t_touch > 3, "the hand must reach the box only after descending"
    assert eng.t_engage == t_touch
    assert engaged == [t >= t_touch for t in range(len(path))]


def test_grasp_squeezes_about_22N_and_holds_the_lifted_box() -> None:
    box = get_model("box/carton_03")
    _, hy, hz = box.geometry["half_extents"]
    assert 2 * hy < 0.075
    scene = build_scene(task_with(
        ObjectPlacement("box", box.name, (0.5, 0.0, 0.0)),
        spec=spec_of(Proposition("box_held", "held", ("box",)))))
    lab = Labeller(scene, scene.task.safety)
    scene.reset()
    ctl = JointController(scene)
    q = robot.HOME_Q
    top = 2 * hz
    waypoints = [(z, 0.0) for z in np.linspace(top + 0.1, top - 0.03, 15)] + [(top - 0.03, 1.0)] * 10
    waypoints += [(z, 1.0) for z in np.linspace(top - 0.03, top + 0.12, 20)] + [(top + 0.12, 1.0)] * 10
    held = []
    for z, grip in waypoints:
        q = ik(q, (0.5, 0.0, z), DOWN)
        ctl.apply(np.array([*q, grip]))
        ctl.step()
        held.append(lab.as_dict()["box_held"])
    # Open hand above it, then closed on it while it still stands on the table: not held; lifted and at rest
    # in the hand (the last steps): held.
    assert not any(held[:25]) and all(held[-5:])
    assert scene.object_pose("box")[0][2] > 0.12, "the box must be lifted with the hand (15 cm commanded)"
    # Squeeze: the tendon servo pushes ~140 N, split equally over the two fingers: 70 N normal force per
    # finger (the Franka Hand's continuous grasp force; tests/sim/test_grip_force.py measures it against the
    # command).
    m, d = scene.model, scene.data
    left = m.body("left_finger").id
    force = np.zeros(6)
    total = 0.0
    for i, c in enumerate(d.contact[: d.ncon]):
        bodies = {m.geom_bodyid[c.geom1], m.geom_bodyid[c.geom2]}
        if left in bodies and scene.object_body("box") in bodies:
            mujoco.mj_contactForce(m, d, i, force)
            total += force[0]
    assert 66.5 < total < 75.0, f"squeeze {total:.1f} N per finger"
