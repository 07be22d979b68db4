"""Time-optimal retiming of a waypoint path with toppra, sampled at the control rate.

The waypoints are interpolated by a cubic spline over their cumulative joint-space arc length and
parameterised by TOPP-RA under per-coordinate velocity and acceleration bounds. Extra coordinates beyond the
seven joints are "virtual joints" that ride along the path: a linear move adds the TCP's travelled distance
and turned angle so that the same solver caps the Cartesian speed.
"""

from __future__ import annotations

import itertools
import logging

import numpy as np
import toppra
import toppra.algorithm
import toppra.constraint

from mgdata.motion.types import JointTrajectory, MotionFailure

logging.getLogger("toppra").setLevel(logging.ERROR)  # it logs every solve at INFO/DEBUG


def densify(path: np.ndarray, step: float) -> np.ndarray:
    """Insert points so that no segment of the polyline ``path`` (M, D) is longer than ``step`` (max-norm)."""
    out = [path[0]]
    for a, b in itertools.pairwise(path):
        n = max(1, int(np.ceil(np.max(np.abs(b - a)) / step)))
        out.extend(a + (b - a) * (k / n) for k in range(1, n))
        out.append(b)
    return np.array(out)


def retime(
    waypoints: np.ndarray,
    vmax: np.ndarray,
    amax: np.ndarray,
    rate: float,
    gridpoints_per_waypoint: int = 4,
) -> JointTrajectory:
    """Fastest trajectory through ``waypoints`` (M, D >= 7) within ``±vmax`` and ``±amax`` (D,).

    Starts and ends at rest. Only the first seven columns are returned (the arm joints); samples are at
    ``k / rate`` seconds with the last one exactly at the end. Raises ``MotionFailure("retime_fail")``.
    """
    wp = np.asarray(waypoints, dtype=np.float64)
    step = np.diff(wp, axis=0)
    seg = np.linalg.norm(step[:, :7], axis=1) + np.linalg.norm(step[:, 7:], axis=1)
    keep = np.concatenate([[True], seg > 1e-9])
    wp, seg = wp[keep], seg[keep[1:]]
    if len(wp) < 2:
        return JointTrajectory(wp[:1, :7], rate, 0.0)
    s = np.concatenate([[0.0], np.cumsum(seg)])
    path = toppra.SplineInterpolator(s, wp)
    n_grid = max(100, gridpoints_per_waypoint * len(wp))
    grid = np.linspace(0.0, s[-1], n_grid + 1)
    constraints = [
        toppra.constraint.JointVelocityConstraint(np.stack([-vmax, vmax], axis=1)),
        toppra.constraint.JointAccelerationConstraint(np.stack([-amax, amax], axis=1)),
    ]
    algo = toppra.algorithm.TOPPRA(constraints, path, gridpoints=grid, parametrizer="ParametrizeConstAccel")
    traj = algo.compute_trajectory(0.0, 0.0)
    if traj is None or not np.isfinite(traj.duration) or traj.duration <= 0.0:
        raise MotionFailure("retime_fail", f"TOPP-RA found no feasible parameterisation of a {len(wp)}-point "
                            f"path of length {s[-1]:.3f}")
    duration = float(traj.duration)
    n = int(np.ceil(duration * rate - 1e-9)) + 1
    times = np.minimum(np.arange(n) / rate, duration)
    q = traj(times)[:, :7]
    q[0], q[-1] = wp[0, :7], wp[-1, :7]
    return JointTrajectory(q, rate, duration)
