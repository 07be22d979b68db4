"""Task builders shared by the simulation tests (imported as ``sim_tasks``)."""

from __future__ import annotations

import mgdata  # noqa: F401  (must precede any mujoco import: sets MUJOCO_GL)
from mgdata.sim.assets import get_model
from mgdata.spec import Constraint, Proposition, SafetySpec
from mgdata.tasks.taskspec import GoalRegion, ObjectPlacement, TaskSpec

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
        **kw,  # type: ignore[arg-type]
    )
