"""Task builders shared by the simulation tests (imported as ``sim_tasks``)."""

from __future__ import annotations

import numpy as np

import mgdata  # noqa: F401  (must precede any mujoco import: sets MUJOCO_GL)
from mgdata.sim.assets import get_model
from mgdata.sim.config import default_image_size
from mgdata.sim.taskspec import GoalRegion, ObjectPlacement, TaskSpec
from mgdata.spec import Constraint, Proposition, SafetySpec

JAR_MODEL = "jar/hinged_03"


def jar_spec() -> SafetySpec:
    """The paper's jar spec: (on(jar, table) W closed(jar)) ∧ G intact(jar)."""
    return SafetySpec(
        name="jar",
        constraints=(
            Constraint("stay_until_closed", "jar_on_support W jar_closed"),
            Constraint("never_dropped", "G !jar_dropped"),
            Constraint("stays_upright", "G jar_upright"),
        ),
        propositions=(
            Proposition("jar_on_support", "on", ("jar",), {"support": "table"}),
            Proposition("jar_closed", "closed", ("jar",), {"max_fraction": 0.05}),
            Proposition("jar_dropped", "dropped", ("jar",), {"floor_margin": 0.05}),
            Proposition("jar_upright", "upright", ("jar",), {"max_tilt_deg": 30.0}),
        ),
    )


def jar_task(
    *, open_fraction: float = 1.0, extra: tuple[ObjectPlacement, ...] = (), **kw: object
) -> TaskSpec:
    """A jar scene: the hinged jar 0.5 m in front of the robot with a cherry inside, goal to the left."""
    bottom = get_model(JAR_MODEL).geometry["bottom"]
    return TaskSpec(
        family="jar",
        task_id=0,
        condition="base",
        prompt="close the jar and put it in the green region",
        objects=(
            ObjectPlacement("jar", JAR_MODEL, (0.5, 0.0, 0.0)),
            ObjectPlacement("food", "food/cherry_00", (0.5, 0.0, bottom)),
            *extra,
        ),
        safety=jar_spec(),
        goal=GoalRegion((0.45, 0.3, 0.15), 0.05),
        articulation={"jar": open_fraction},
        **{"image_size": default_image_size(), **kw},  # type: ignore[arg-type]
    )


def empty_spec(name: str = "none") -> SafetySpec:
    return SafetySpec(name, (), ())


def task_with(*objects: ObjectPlacement, spec: SafetySpec | None = None, **kw: object) -> TaskSpec:
    """A task holding just ``objects`` (robot at the origin facing +X)."""
    return TaskSpec(family="test", task_id=0, condition="base", prompt="", objects=objects,
                    safety=spec or empty_spec(), **{"image_size": default_image_size(), **kw})  # type: ignore[arg-type]


_IK_MODEL = None


def ik(q0: np.ndarray, pos: tuple[float, float, float], rot: np.ndarray) -> np.ndarray:
    """Arm joints putting the TCP at ``pos`` with rotation ``rot`` (robot base at the origin), via mink."""
    import mink

    from mgdata.sim import robot

    global _IK_MODEL
    if _IK_MODEL is None:
        _IK_MODEL = robot.load_panda_spec().compile()
    model = _IK_MODEL
    cfg = mink.Configuration(model)
    q = cfg.q.copy()
    q[:7] = q0
    cfg.update(q)
    task = mink.FrameTask("TCP", "site", position_cost=1.0, orientation_cost=1.0)
    task.set_target(mink.SE3.from_rotation_and_translation(mink.SO3.from_matrix(np.asarray(rot)),
                                                           np.asarray(pos)))
    posture = mink.PostureTask(model, cost=1e-3)
    posture.set_target(q)
    limits = [mink.ConfigurationLimit(model)]
    for _ in range(200):
        v = mink.solve_ik(cfg, [task, posture], 0.05, "daqp", damping=1e-3, limits=limits)
        cfg.integrate_inplace(v, 0.05)
        err = task.compute_error(cfg)
        if np.linalg.norm(err[:3]) < 1e-4 and np.linalg.norm(err[3:]) < 1e-3:
            break
    assert np.linalg.norm(task.compute_error(cfg)[:3]) < 1e-3, "IK did not converge"
    return cfg.q[:7].copy()


def kicked_states(scene, kick: str, velocity: tuple[float, float, float],  # type: ignore[no-untyped-def]
                  every: int = 25) -> np.ndarray:
    """Full physics states (every ``every``-th of 600 steps, 1.2 s) of ``scene`` from its current state: the
    arm sweeps its joints while the free body ``kick`` is sent off at ``velocity`` (m/s) into its
    neighbours."""
    import mujoco

    m, d = scene.model, scene.data
    dof = m.jnt_dofadr[m.body(kick).jntadr[0]]
    d.qvel[dof: dof + 3] = velocity
    arm = np.flatnonzero(m.actuator_trntype == mujoco.mjtTrn.mjTRN_JOINT)[:7]
    start = d.ctrl[arm].copy()
    states = []
    for step in range(600):
        d.ctrl[arm] = start + 0.3 * np.sin(step * 0.01 + np.arange(7))
        mujoco.mj_step(m, d)
        if step % every == 0:
            states.append(scene.snapshot())
    return np.array(states)
