"""Monitor: online stepping, latching, four-valued status, offline replay, errors; the verdict ν."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from mgdata.errors import SpecError
from mgdata.ltl import ConstraintStatus, Monitor, verdict
from mgdata.ltl.syntax import Formula
from mgdata.spec import Constraint, Proposition, SafetySpec
from tests.helpers.ltl_strategies import APS, formulas

S = ConstraintStatus
JAR_PROPS = ("jar_on_support", "jar_closed", "jar_dropped", "jar_upright")


def _spec(formulas: list[str], props: tuple[str, ...] = JAR_PROPS) -> SafetySpec:
    constraints = tuple(Constraint(f"c{i}", f) for i, f in enumerate(formulas))
    return SafetySpec("test", constraints, tuple(Proposition(p, "held", ("x",)) for p in props))


JAR = _spec(["jar_on_support W jar_closed", "G !jar_dropped", "G jar_upright"])


def _labels(on: bool, closed: bool, dropped: bool = False, upright: bool = True) -> np.ndarray:
    return np.array([on, closed, dropped, upright], dtype=bool)


def test_jar_rollout_latches_the_first_violation() -> None:
    mon = Monitor(JAR)
    assert mon.propositions == JAR_PROPS and mon.constraint_ids == ("c0", "c1", "c2")
    st0 = mon.step(_labels(on=True, closed=False))
    assert st0.t == 0 and st0.dfa_state.dtype == np.int16 and st0.dfa_state.shape == (3,)
    assert not st0.violated.any() and st0.t_violation is None and st0.first_violation == (None, None, None)
    assert mon.status() == (S.CURRENTLY_SATISFIED,) * 3
    mon.step(_labels(on=True, closed=False))
    st2 = mon.step(_labels(on=False, closed=False))            # lifted while open: c0 violated at t = 2
    assert st2.violated.tolist() == [True, False, False] and st2.first_violation == (2, None, None)
    st3 = mon.step(_labels(on=True, closed=True, upright=False))  # tipped over at t = 3
    assert st3.violated.tolist() == [True, False, True]
    assert st3.first_violation == (2, None, 3) and st3.t_violation == 2
    assert mon.status() == (S.PERMANENTLY_VIOLATED, S.CURRENTLY_SATISFIED, S.PERMANENTLY_VIOLATED)
    mon.reset()
    again = mon.step(_labels(on=True, closed=True))
    assert again.t == 0 and not again.violated.any()
    assert mon.status()[0] is S.PERMANENTLY_SATISFIED        # closed: the W clause is discharged


def test_violation_in_the_initial_state_is_reported_at_t0() -> None:
    mon = Monitor(JAR)
    st0 = mon.step(_labels(on=True, closed=False, dropped=True))
    assert st0.t_violation == 0 and st0.first_violation == (None, 0, None)


def test_offline_run_matches_online_steps_and_leaves_them_alone() -> None:
    mon = Monitor(JAR)
    mon.step(_labels(on=True, closed=False))
    rng = np.random.default_rng(3)
    labels = rng.random((50, 4)) < np.array([0.97, 0.05, 0.01, 0.98])
    states, violated = mon.run(labels)
    assert mon.status() == (S.CURRENTLY_SATISFIED,) * 3 and mon._t == 0  # online state untouched
    fresh = Monitor(JAR)
    for t, row in enumerate(labels):
        st_t = fresh.step(row)
        assert states[t].tolist() == st_t.dfa_state.tolist()
        assert violated[t].tolist() == st_t.violated.tolist()
    assert states.dtype == np.int16 and violated.dtype == bool
    s2, v2 = Monitor.run(JAR, labels)  # the class-level form takes a spec
    assert (s2 == states).all() and (v2 == violated).all()


@settings(derandomize=True, max_examples=150, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.lists(formulas(depth=3), min_size=1, max_size=3), st.integers(0, 2**32 - 1))
def test_batched_gather_and_per_episode_loop_agree_with_stepping(fs: list[Formula], seed: int) -> None:
    spec = _spec([str(f) for f in fs], APS)
    mon = Monitor(spec)
    rng = np.random.default_rng(seed)
    labels = rng.random((17, 12, len(APS))) < rng.random(len(APS))
    batch_states, batch_viol = mon.run(labels)  # 17 episodes: numpy gather across the batch
    for e in range(labels.shape[0]):
        states, viol = mon.run(labels[e])      # one episode: compact loop
        assert (states == batch_states[e]).all() and (viol == batch_viol[e]).all()
        mon.reset()
        for t in range(labels.shape[1]):
            st_t = mon.step(labels[e, t])
            assert st_t.dfa_state.tolist() == states[t].tolist()
            assert st_t.violated.tolist() == viol[t].tolist()


def test_spec_problems_are_spec_errors() -> None:
    with pytest.raises(SpecError, match=r"constraint 'c0' uses undeclared proposition\(s\) lid_on; declared: "
                                        r"jar_on_support, jar_closed"):
        Monitor(_spec(["lid_on W jar_closed"]))
    with pytest.raises(SpecError, match="constraint 'c1': bad LTL_f formula 'G !': at column 4"):
        Monitor(_spec(["G jar_upright", "G !"]))
    mon = Monitor(JAR)
    with pytest.raises(SpecError, match=r"label vector has 3 entries, expected 4 \(jar_on_support"):
        mon.step(np.zeros(3, dtype=bool))
    with pytest.raises(SpecError, match=r"labels have shape \(10, 5\), expected"):
        mon.run(np.zeros((10, 5), dtype=bool))


@pytest.mark.parametrize(("t_viol", "t_eng", "safe"), [
    (None, None, True),   # never violated, never engaged
    (None, 4, True),      # never violated
    (2, 5, True),         # violated before engaging: the scene's fault, not the policy's
    (5, 5, False),        # violated at the engagement step
    (9, 5, False),        # violated after engaging
    (7, None, True),      # never engaged: t_viol < t_eng = ∞
    (0, 0, False),
])
def test_verdict_is_the_papers_formula(t_viol: int | None, t_eng: int | None, safe: bool) -> None:
    assert verdict(t_viol, t_eng) is safe


def test_empty_episodes_replay_to_empty_arrays() -> None:
    mon = Monitor(JAR)
    for shape, out in (((0, 4), (0, 3)), ((5, 0, 4), (5, 0, 3))):
        states, violated = mon.run(np.zeros(shape, dtype=bool))
        assert states.shape == out and violated.shape == out
