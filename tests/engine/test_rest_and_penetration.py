"""The gate's physical checks, against quantities computed here from raw MuJoCo data: "at rest" over every
physics substep (a body rocking between 20 Hz samples is refused), and each episode's deepest contact
overlap (recorded, bounded by ``[tasks] max_penetration``, audited by ``mgdata validate``)."""

from __future__ import annotations

import dataclasses

import mujoco
import numpy as np
import pytest

from mgdata.engine.init_gate import base_task
from mgdata.episode.gate import RestCheck, SuccessGate
from mgdata.episode.runner import EpisodeRunner
from mgdata.record.episode import MemorySink
from mgdata.record.physics import STATE_SPEC
from mgdata.record.physics_audit import PhysicsAuditor, PhysicsGate
from mgdata.record.reader import EpisodeData
from mgdata.record.recorder import Recorder
from mgdata.sim.controller import JointController
from mgdata.sim.penetration import deepest_contact
from mgdata.sim.robot import HOME_Q
from mgdata.sim.scene import Scene, build_scene
from mgdata.tasks.recipe import load_recipe

DT, SUBSTEPS = 0.002, 25  # the shipped 500 Hz physics, 20 Hz control
LINEAR, ANGULAR = 0.005, 0.05  # the shipped rest bounds (m/s, rad/s)


def _oscillators(amplitude: float, turn: float) -> tuple[mujoco.MjModel, mujoco.MjData]:
    """A puck on a spring slide and a paddle on a spring hinge, no gravity, whose discrete period is exactly
    one control period (25 substeps): sampled at 20 Hz, both look still. Semi-implicit Euler on
    x'' = -w^2 x has cos(theta) = 1 - (w h)^2 / 2 per step; theta = 2 pi / 25 gives the stiffness."""
    w2 = 2.0 * (1.0 - np.cos(2.0 * np.pi / SUBSTEPS)) / DT**2
    xml = f"""<mujoco><option timestep="{DT}" gravity="0 0 0" integrator="Euler"/>
      <worldbody>
        <body name="puck" pos="0 0 0.1"><joint name="slide" type="slide" axis="1 0 0" stiffness="{w2}"/>
          <inertial pos="0 0 0" mass="1" diaginertia="1 1 1"/><geom type="box" size="0.02 0.02 0.02"
          contype="0" conaffinity="0"/></body>
        <body name="paddle" pos="0.5 0 0.1"><joint name="hinge" type="hinge" axis="0 0 1" stiffness="{w2}"/>
          <inertial pos="0 0 0" mass="1" diaginertia="1 1 1"/><geom type="box" size="0.05 0.01 0.01"
          contype="0" conaffinity="0"/></body>
      </worldbody></mujoco>"""
    model = mujoco.MjModel.from_xml_string(xml)
    data = mujoco.MjData(model)
    data.qpos[:] = [amplitude, turn]
    mujoco.mj_forward(model, data)
    return model, data


def test_a_body_rocking_between_control_samples_is_not_at_rest() -> None:
    for body in ("puck", "paddle"):
        model, data = _oscillators(amplitude=0.001, turn=0.01)  # 1 mm, 0.57 deg
        rest = RestCheck(model, [model.body(body).id], linear=LINEAR, angular=ANGULAR)
        sampled, verdicts, peak = [], [], 0.0
        start = data.xquat[model.body(body).id].copy(), data.xpos[model.body(body).id].copy()
        for _ in range(10):  # ten control periods, stepped as JointController.step does
            rest.reset()
            for _ in range(SUBSTEPS):
                mujoco.mj_step(model, data)
                rest.observe(data)
                peak = max(peak, float(np.abs(data.qvel).max()))
            mujoco.mj_forward(model, data)
            sampled.append(rest.speeds(data))  # what the old check read: the speed at the sample alone
            verdicts.append(rest.at_rest(data))
        # raw data: the motion between samples is large, the samples see none of it
        assert peak > 0.1  # rad/s or m/s: amplitude 1 mm / 0.01 rad at 2 pi * 20 Hz ~ 0.126
        assert np.abs(data.xquat[model.body(body).id] - start[0]).max() < 1e-6  # back where it was
        assert np.abs(data.xpos[model.body(body).id] - start[1]).max() < 1e-6
        assert all(lin <= LINEAR and ang <= ANGULAR for lin, ang in sampled)  # the old check: "at rest"
        assert not any(verdicts)  # the new one: not at rest in any period


def test_a_still_body_is_at_rest_and_the_speeds_are_mujocos_object_velocity(scene: Scene) -> None:
    m, d = scene.model, scene.data
    scene.reset()
    jar = scene.object_body("jar")
    ctl = JointController(scene)
    rest = RestCheck(m, [jar], linear=LINEAR, angular=ANGULAR)
    ctl.watch(rest)
    ctl.apply(np.array([*HOME_Q, 0.0]))
    ctl.step()
    assert rest.at_rest(d)  # the settled jar on the table
    d.qvel[m.jnt_dofadr[m.body_jntadr[jar]]:][:6] = [0.03, -0.02, 0.01, 0.4, 0.1, -0.2]
    mujoco.mj_forward(m, d)
    v = np.zeros(6)
    mujoco.mj_objectVelocity(m, d, mujoco.mjtObj.mjOBJ_BODY, jar, v, 0)
    lin, ang = rest.speeds(d)
    assert lin == pytest.approx(np.linalg.norm(v[3:]), abs=1e-12)
    assert ang == pytest.approx(np.linalg.norm(v[:3]), abs=1e-12)
    ctl.step()  # the controller shows the check every substep: the jar falling back is seen
    assert rest.peak_linear >= 0.02 and not rest.at_rest(d)
    scene.reset()


@pytest.fixture(scope="module")
def scene() -> Scene:
    return build_scene(base_task(load_recipe("jar"), 0))


def _raw_deepest(model: mujoco.MjModel, data: mujoco.MjData) -> float:
    return max([0.0, *(-data.contact[i].dist for i in range(data.ncon))])


def test_the_deepest_contact_is_the_geometric_overlap() -> None:
    xml = """<mujoco><worldbody><geom name="ground" type="plane" size="1 1 0.1"/>
      <body name="cube" pos="0 0 0.0173"><freejoint/><geom type="box" size="0.02 0.02 0.02"/></body>
      </worldbody></mujoco>"""
    model = mujoco.MjModel.from_xml_string(xml)
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    p = deepest_contact(model, data)
    assert p.depth == pytest.approx(0.0027, abs=1e-9)  # 2 cm half-height, centre 17.3 mm up
    assert {p.body1, p.body2} == {"world", "cube"} and p.bodies == "cube|world"
    data.qpos[2] = 0.025
    mujoco.mj_forward(model, data)
    assert deepest_contact(model, data).depth == 0.0


def _episode(scene: Scene, bound: float | None, steps: int = 4) -> tuple[EpisodeRunner, MemorySink, list]:
    scene.reset()
    sink = MemorySink()
    rec = Recorder(scene, scene.task.safety, sink, None, lambda _s: True)
    runner = EpisodeRunner(JointController(scene), rec, SuccessGate(3), 20, max_penetration=bound)
    runner.start()
    depths = [_raw_deepest(scene.model, scene.data)]
    ends = []
    for _ in range(steps):
        ends.append(runner.step(HOME_Q, 0.0, holding=True).end)
        depths.append(_raw_deepest(scene.model, scene.data))
        if ends[-1] is not None:
            break
    return runner, sink, [ends, depths]


def test_the_episode_records_its_deepest_contact_and_the_bound_refuses_deeper(scene: Scene) -> None:
    runner, _, (ends, depths) = _episode(scene, bound=None)
    assert ends[-1] == "passed"
    meta = runner.finish(seed=0, draw_index=0, source="planner")
    assert meta.kept and meta.max_penetration == pytest.approx(max(depths), abs=1e-12)
    assert meta.penetration_step == int(np.argmax(depths)) and meta.penetration_bodies == "jar|table"
    assert 0.00005 < meta.max_penetration < 0.001  # the resting jar sinks a fraction of a millimetre

    tight = 0.5 * max(depths)  # a bound the resting jar exceeds: the episode ends at once, not kept
    runner, _, (ends, depths) = _episode(scene, bound=tight)
    assert ends == ["penetration"]  # frame 0 already sinks deeper: the first step ends it
    meta = runner.finish(seed=0, draw_index=0, source="planner", stage="penetration", reason="too deep")
    assert not meta.kept and meta.failure_stage == "penetration"
    scene.reset()


def _as_episode(frames: list, meta, index: int = 0) -> EpisodeData:
    n = len(frames)
    return EpisodeData(index=index, task="t", meta=meta, state=np.stack([f.state for f in frames]),
                       action=np.stack([f.action for f in frames]),
                       labels=np.stack([f.labels for f in frames]),
                       dfa_state=np.stack([f.dfa_state for f in frames]),
                       violated=np.stack([f.violated for f in frames]),
                       engaged=np.array([f.engaged for f in frames]),
                       success=np.array([f.success for f in frames]),
                       timestamp=np.arange(n) / 20.0, frame_index=np.arange(n), global_index=np.arange(n),
                       physics_state=np.stack([f.physics_state for f in frames]))


def test_the_physics_audit_recomputes_the_record_and_catches_motion_in_the_hold(scene: Scene) -> None:
    runner, sink, _ = _episode(scene, bound=None)
    meta = runner.finish(seed=0, draw_index=0, source="planner")
    frames = sink.episodes[-1][0]
    gate = PhysicsGate(LINEAR, ANGULAR, ("jar",), 0.001)
    auditor = PhysicsAuditor(gate, hold_steps=3, fps=20)
    assert auditor.audit(_as_episode(frames, meta), scene.model) == []
    wrong = dataclasses.replace(meta, max_penetration=meta.max_penetration + 0.0005)
    assert "mgdata/max_penetration" in " ".join(auditor.audit(_as_episode(frames, wrong), scene.model))
    strict = PhysicsAuditor(dataclasses.replace(gate, max_penetration=0.0001), hold_steps=3, fps=20)
    assert "overlap by" in " ".join(strict.audit(_as_episode(frames, meta), scene.model))
    # the jar slid 1 mm between two hold frames: 0.02 m/s, four times the rest speed
    m, d = scene.model, scene.data
    moved = list(frames)
    mujoco.mj_setState(m, d, frames[-1].physics_state, STATE_SPEC)
    d.qpos[m.jnt_qposadr[m.body_jntadr[scene.object_body("jar")]]] += 0.001
    state = frames[-1].physics_state.copy()
    mujoco.mj_getState(m, d, state, STATE_SPEC)
    moved[-1] = dataclasses.replace(frames[-1], physics_state=state)
    loose = dataclasses.replace(meta, max_penetration=None)  # the moved frame's contact is not the record's
    problems = auditor.audit(_as_episode(moved, loose), scene.model)
    assert any("not at rest in its hold: jar moves 1.000 mm" in p for p in problems), problems
    scene.reset()
