"""Physics: simulation rates and solver settings (``recipes/sim.toml`` ``[physics]``), applied to a scene's
``MjSpec`` by :meth:`Physics.configure`.

Example::

    Physics(timestep=0.001).substeps   # physics steps per 20 Hz control step
"""

from __future__ import annotations

from dataclasses import dataclass

import mujoco

from mgdata.errors import RecipeError

_INTEGRATORS = {"euler": mujoco.mjtIntegrator.mjINT_EULER, "rk4": mujoco.mjtIntegrator.mjINT_RK4,
                "implicit": mujoco.mjtIntegrator.mjINT_IMPLICIT,
                "implicitfast": mujoco.mjtIntegrator.mjINT_IMPLICITFAST}
_SOLVERS = {"PGS": mujoco.mjtSolver.mjSOL_PGS, "CG": mujoco.mjtSolver.mjSOL_CG,
            "Newton": mujoco.mjtSolver.mjSOL_NEWTON}
_CONES = {"pyramidal": mujoco.mjtCone.mjCONE_PYRAMIDAL, "elliptic": mujoco.mjtCone.mjCONE_ELLIPTIC}


@dataclass(frozen=True)
class Physics:
    """Simulation rates and solver settings (``recipes/sim.toml`` ``[physics]``; documented in docs/sim.md).

    ``timestep`` 2 ms (500 Hz) keeps 20 N friction grasps and the hinged lid stable and still runs far faster
    than real time; 25 physics steps make one 20 Hz control period (``control_dt``). A new scene settles for
    ``settle_time`` with the robot at home. Every scene uses elliptic friction cones (``cone``), the setting
    MuJoCo recommends for grasping: with the default pyramidal cones a held jar creeps slowly out of the
    fingers while it is carried (measured: 5 of 10 carries lost the jar; 0 of 10 with elliptic cones).
    Together with the finger pads' torsional friction (``mgdata.sim.robot.GripperConfig``) this is the grip
    contact model. Scenes with liquid particles switch to the CG solver (``liquid_solver``,
    ``liquid_iterations``), the only setting that is both stable and near real time with 50–100 spheres
    (probe-sim-stack.md §7). Solver, integrator and cone are MuJoCo's names (``implicitfast``, ``Newton``…).
    """

    timestep: float = 0.002
    control_dt: float = 0.05
    settle_time: float = 0.3
    integrator: str = "implicitfast"
    solver: str = "Newton"
    iterations: int = 100
    impratio: float = 30.0
    cone: str = "elliptic"
    liquid_solver: str = "CG"
    liquid_iterations: int = 100

    def __post_init__(self) -> None:
        for key in ("timestep", "control_dt", "impratio", "iterations", "liquid_iterations"):
            if not getattr(self, key) > 0:
                raise RecipeError(f"[physics] {key} = {getattr(self, key)!r}: expected a positive number")
        if self.settle_time < 0:
            raise RecipeError(f"[physics] settle_time = {self.settle_time!r}: expected a number >= 0")
        ratio = self.control_dt / self.timestep
        if abs(ratio - round(ratio)) > 1e-6 * ratio:
            raise RecipeError(f"[physics] control_dt = {self.control_dt!r}: expected a whole number of "
                              f"timesteps ({self.timestep!r} s each)")
        for key, names in (("integrator", _INTEGRATORS), ("solver", _SOLVERS), ("cone", _CONES),
                           ("liquid_solver", _SOLVERS)):
            if getattr(self, key) not in names:
                raise RecipeError(f"[physics] {key} = {getattr(self, key)!r}: expected one of "
                                  f"{sorted(names)}")

    @property
    def substeps(self) -> int:
        """Physics steps per control period."""
        return round(self.control_dt / self.timestep)

    def configure(self, spec: mujoco.MjSpec, *, liquid: bool = False) -> None:
        """Set these options on ``spec``; ``liquid`` selects the liquid solver settings."""
        option = spec.option
        option.timestep = self.timestep
        option.integrator = _INTEGRATORS[self.integrator]
        option.impratio = self.impratio
        option.cone = _CONES[self.cone]
        option.solver = _SOLVERS[self.liquid_solver if liquid else self.solver]
        option.iterations = self.liquid_iterations if liquid else self.iterations
