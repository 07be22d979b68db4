"""Free-space joint paths with OMPL RRTConnect, deterministic for a given seed.

OMPL's random generator is process-global (``ou.RNG.setSeed``); every solve re-seeds it from the caller's seed
before it builds the planner and simplifier, whose generators are created afterwards. The planner stops on an
exact solution or after ``max_iterations`` loop iterations, and the path is simplified by a fixed number
of reduce/shortcut passes plus one B-spline smoothing pass: nothing depends on wall time, so the same seed
gives the same path on any machine, loaded or not.
"""

from __future__ import annotations

import numpy as np
from ompl import base as ob
from ompl import geometric as og
from ompl import util as ou

from mgdata.motion.collision import CollisionChecker
from mgdata.motion.config import CheckConfig, PlannerConfig
from mgdata.motion.types import MotionFailure

ou.setLogLevel(ou.LOG_NONE)


def _path_array(path: og.PathGeometric) -> np.ndarray:
    return np.array([[path.getState(k)[i] for i in range(7)] for k in range(path.getStateCount())])


def plan_joint_path(
    checker: CollisionChecker,
    q_start: np.ndarray,
    q_goal: np.ndarray,
    lower: np.ndarray,
    upper: np.ndarray,
    seed: int,
    planner: PlannerConfig,
    check: CheckConfig,
) -> np.ndarray:
    """A simplified collision-free polyline (M, 7) from ``q_start`` to ``q_goal``, M >= 2.

    The checker must already be configured (margin, allowed contacts, held object). Raises
    ``MotionFailure("plan_fail")`` when the planner gives up.
    """
    ou.RNG.setSeed(int(seed) % (2**31 - 1) + 1)
    space = ob.RealVectorStateSpace(7)
    bounds = ob.RealVectorBounds(7)
    for i in range(7):
        bounds.setLow(i, float(lower[i]))
        bounds.setHigh(i, float(upper[i]))
    space.setBounds(bounds)
    ss = og.SimpleSetup(space)
    ss.setStateValidityChecker(lambda s: checker.valid(np.array([s[i] for i in range(7)])))
    si = ss.getSpaceInformation()
    si.setStateValidityCheckingResolution(check.resolution)
    start, goal = space.allocState(), space.allocState()
    for i in range(7):
        start[i], goal[i] = float(q_start[i]), float(q_goal[i])
    ss.setStartAndGoalStates(start, goal)
    rrt = og.RRTConnect(si)
    if planner.range > 0:
        rrt.setRange(planner.range)
    ss.setPlanner(rrt)
    iterations = [0]

    def stop() -> bool:
        iterations[0] += 1
        return iterations[0] > planner.max_iterations

    try:
        ss.solve(ob.PlannerTerminationCondition(stop))
        if not ss.haveExactSolutionPath():
            raise MotionFailure("plan_fail", f"RRTConnect found no path in {planner.max_iterations} "
                                f"iterations ({checker.n_checks} collision checks so far)")
        path = ss.getSolutionPath()
        simplifier = og.PathSimplifier(si)
        simplifier.reduceVertices(path, planner.reduce_steps, planner.reduce_steps)
        simplifier.partialShortcutPath(path, planner.shortcut_steps, planner.shortcut_steps)
        simplifier.reduceVertices(path, planner.reduce_steps, planner.reduce_steps)
        if planner.smooth:
            simplifier.smoothBSpline(path, 3)
        simplifier.collapseCloseVertices(path)
        waypoints = _path_array(path)
    finally:
        del ss, rrt, space, si  # drop OMPL objects now rather than at interpreter exit
    waypoints[0], waypoints[-1] = q_start, q_goal
    return waypoints
