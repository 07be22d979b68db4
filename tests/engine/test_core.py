"""Engine core: seeds and variation draws, the success gate, the draw cursor, segments, the registry."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from mgdata.episode.gate import STAGES, AttemptFailed, SuccessGate, keep
from mgdata.errors import DatasetError, UnknownFamilyError
from mgdata.generate.resume import DrawCursor, RunState
from mgdata.motion.types import Pose
from mgdata.skeleton import segment as seg
from mgdata.skeleton.skeleton import (
    FamilySkeleton,
    available_families,
    available_skeletons,
    register,
    skeleton_for,
)
from mgdata.skeleton.variation import attempt_seed, draw_variation

KNOBS = {"standoff_m": (0.08, 0.12), "lift_m": (0.10, 0.20)}


def test_seeds_are_stable_and_distinct() -> None:
    seeds = {attempt_seed("jar", t, d, s) for t in range(5) for d in range(20) for s in range(2)}
    assert len(seeds) == 200
    assert attempt_seed("jar", 3, 7) == attempt_seed("jar", 3, 7)
    assert attempt_seed("jar", 3, 7) != attempt_seed("lid", 3, 7)
    assert all(0 <= s < 2**63 for s in seeds)
    with pytest.raises(ValueError):
        attempt_seed("jar", -1, 0)


def test_variation_draws_reproduce_and_stay_in_range() -> None:
    a = draw_variation("jar", 2, 5, 0, KNOBS)
    b = draw_variation("jar", 2, 5, 0, dict(reversed(list(KNOBS.items()))))  # knob order does not matter
    assert a == b
    for name, (lo, hi) in KNOBS.items():
        assert lo <= a[name] <= hi
    canonical = draw_variation("jar", 2, 0, 0, KNOBS)
    assert canonical["standoff_m"] == pytest.approx(0.10) and canonical["lift_m"] == pytest.approx(0.15)
    assert np.array_equal(a.rng("grasp").random(4), b.rng("grasp").random(4))
    assert not np.array_equal(a.rng("grasp").random(4), a.rng("planner").random(4))
    assert [draw_variation("jar", 0, k, 0, KNOBS).pick(3) for k in range(6)] == [0, 1, 2, 0, 1, 2]
    with pytest.raises(KeyError, match="lift_m"):
        a["nope"]
    assert a.as_meta()["draw"] == 5


def test_gate_needs_consecutive_holding_steps() -> None:
    gate = SuccessGate(hold_steps=3)
    pattern = [True, True, False, True, True, True, False]
    passed = [gate.update(x) for x in pattern]
    assert passed == [False, False, False, False, False, True, True]  # latches
    assert gate.passed_at == 5 and gate.best == 3
    gate.reset()
    assert not gate.passed and gate.streak == 0 and gate.best == 0
    # success while the arm still moves does not count, however long it lasts
    for _ in range(20):
        assert not gate.update(True, holding=False)
    assert [gate.update(True, holding=True) for _ in range(3)] == [False, False, True]


def test_kept_means_no_violation_at_any_step() -> None:
    assert keep(True, {"a": None, "b": None})
    assert not keep(False, {"a": None})
    # a violation before engagement keeps ν = 1 (the paper's verdict) but never a demonstration
    assert not keep(True, {"a": None, "b": 0})
    assert not keep(True, {"a": 17})


@settings(max_examples=200, deadline=None)
@given(st.lists(st.tuples(st.booleans(), st.booleans()), max_size=60), st.integers(1, 12))
def test_gate_matches_reference_semantics(steps: list[tuple[bool, bool]], hold: int) -> None:
    gate = SuccessGate(hold_steps=hold)
    for success, holding in steps:
        gate.update(success, holding)
    # Reference: some window of `hold` consecutive steps that are all holding steps with success exists.
    ok = [s and h for s, h in steps]
    expected = any(all(ok[i:i + hold]) for i in range(len(ok) - hold + 1))
    assert gate.passed == expected


def test_failure_stages_are_closed() -> None:
    err = AttemptFailed("unsafe", "jar_upright violated at step 12", segment="lift")
    assert err.stage == "unsafe" and err.segment == "lift"
    assert "ik_fail" in STAGES and "goal_not_reached" in STAGES
    with pytest.raises(ValueError):
        AttemptFailed("exploded", "?")


def test_cursor_order_is_canonical_and_resume_matches_uninterrupted() -> None:
    full = DrawCursor((4, 1, 7))
    order = [full.take() for _ in range(9)]
    assert order == [(4, 0), (1, 0), (7, 0), (4, 1), (1, 1), (7, 1), (4, 2), (1, 2), (7, 2)]
    # Stop after 4 attempts; the dataset holds only the kept ones (say (4,0) and (4,1)), the saved cursor
    # knows more. A resumed cursor continues exactly where the uninterrupted one was.
    partial = DrawCursor((4, 1, 7))
    for _ in range(4):
        partial.take()
    resumed = DrawCursor.resume((4, 1, 7), saved=partial.next_draw, seen=[(4, 0), (4, 1)])
    assert [resumed.take() for _ in range(5)] == order[4:]
    # Without the saved cursor the dataset alone floors the draws: nothing is ever reused.
    floor = DrawCursor.resume((4, 1, 7), saved=None, seen=[(4, 0), (4, 1), (1, 0)])
    assert floor.take() == (7, 0) and floor.take() == (1, 1)
    with pytest.raises(ValueError):
        DrawCursor(())


@settings(max_examples=100, deadline=None)
@given(st.lists(st.integers(0, 30), min_size=1, max_size=6, unique=True), st.integers(0, 40))
def test_cursor_never_repeats(tasks: list[int], cut: int) -> None:
    cursor = DrawCursor(tuple(tasks))
    first = [cursor.take() for _ in range(cut)]
    resumed = DrawCursor.resume(tasks, saved=dict(cursor.next_draw))
    rest = [resumed.take() for _ in range(20)]
    assert len(set(first + rest)) == len(first) + len(rest)


def test_run_state_round_trip_and_compatibility(tmp_path: Path) -> None:
    path = tmp_path / "state.json"
    assert RunState.load(path) is None
    state = RunState("jar", 0, "abc", {3: 4, 0: 2})
    state.save(path)
    back = RunState.load(path)
    assert back == state
    back.check_compatible(RunState("jar", 0, "abc"), path)
    with pytest.raises(DatasetError, match=r"seed=0.*seed=1"):
        back.check_compatible(RunState("jar", 1, "abc"), path)
    path.write_text("{broken")
    with pytest.raises(DatasetError, match="unreadable"):
        RunState.load(path)


def test_segments_validate_their_options() -> None:
    s = seg.linear("lift", "lift", gripper="close", attached="jar", allow=(("hand", "jar"),))
    assert s.kind == "linear" and s.allow.pairs == (("hand", "jar"),)
    assert isinstance(seg.free("go", Pose.identity()).target, Pose)
    assert seg.reverse("back", of="push").of == "push"
    assert seg.gripper("close", "close", steps=5).gripper == "close"
    with pytest.raises(ValueError, match="target"):
        seg.MotionSegment("x", "free")
    with pytest.raises(ValueError, match="steps"):
        seg.hold("wait", steps=0)
    with pytest.raises(ValueError, match="'of'"):
        seg.MotionSegment("x", "reverse")
    with pytest.raises(ValueError, match="kind"):
        seg.MotionSegment("x", "teleport", target="t")  # type: ignore[arg-type]


def test_registry_finds_and_rejects_skeletons() -> None:
    @register
    class Dummy(FamilySkeleton):
        name = "dummy_test_family"

        def segments(self, ctx):  # type: ignore[no-untyped-def]
            return [seg.hold("wait", steps=1)]

    sk = skeleton_for("dummy_test_family")
    assert isinstance(sk, Dummy) and sk.success_extra(None) is True  # type: ignore[arg-type]
    with pytest.raises(KeyError, match="no runtime target"):
        sk.resolve("nowhere", None)  # type: ignore[arg-type]
    assert "dummy_test_family" in available_skeletons()
    assert {"jar", "clutter_dry", "clutter_liquid"} <= set(available_families())  # the recipes
    with pytest.raises(UnknownFamilyError, match="no skeleton 'nonesuch'"):
        skeleton_for("nonesuch")
