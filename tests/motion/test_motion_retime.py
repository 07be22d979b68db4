"""toppra retiming against the analytic time-optimal profile of a straight joint-space move."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from mgdata.motion.retime import densify, retime

joints = arrays(np.float64, 7, elements=st.floats(-1.5, 1.5))
vlims = arrays(np.float64, 7, elements=st.floats(0.3, 2.6))
alims = arrays(np.float64, 7, elements=st.floats(1.0, 20.0))


def bang_coast_bang(dq: np.ndarray, vmax: np.ndarray, amax: np.ndarray) -> float:
    """Minimum time of a rest-to-rest straight move: trapezoid (or triangle) on the binding joint limits."""
    length = float(np.linalg.norm(dq))
    u = np.abs(dq) / length
    with np.errstate(divide="ignore", over="ignore"):
        v, a = float(np.min(vmax / u)), float(np.min(amax / u))
    return length / v + v / a if length >= v * v / a else 2.0 * np.sqrt(length / a)


@settings(max_examples=60, deadline=None)
@given(dq=joints.filter(lambda d: np.linalg.norm(d) > 0.02), vmax=vlims, amax=alims)
def test_straight_move_duration_is_time_optimal(dq: np.ndarray, vmax: np.ndarray, amax: np.ndarray) -> None:
    start = np.linspace(-0.5, 0.5, 7)
    traj = retime(np.stack([start, start + dq]), vmax, amax, 20.0)
    optimal = bang_coast_bang(dq, vmax, amax)
    assert optimal * (1 - 1e-3) <= traj.duration <= optimal * 1.03  # never faster than allowed; grid error
    assert traj.q[0].tobytes() == start.tobytes() and np.array_equal(traj.q[-1], start + dq)
    assert len(traj) == int(np.ceil(traj.duration * 20.0 - 1e-9)) + 1
    qd = np.diff(traj.q, axis=0) * 20.0
    assert np.all(np.abs(qd) <= vmax * 1.01)


def test_densify_keeps_the_polyline_and_its_ends() -> None:
    path = np.array([[0.0] * 7, [1.0] + [0.0] * 6, [1.0, 0.5] + [0.0] * 5])
    dense = densify(path, 0.1)
    assert dense[0].tobytes() == path[0].tobytes() and dense[-1].tobytes() == path[-1].tobytes()
    assert np.max(np.abs(np.diff(dense, axis=0))) <= 0.1 + 1e-12
    assert any(np.array_equal(row, path[1]) for row in dense) and len(dense) == 16


def test_a_zero_length_path_is_one_sample() -> None:
    q = np.arange(7.0)
    traj = retime(np.stack([q, q]), np.ones(7), np.ones(7), 20.0)
    assert len(traj) == 1 and traj.duration == 0.0
