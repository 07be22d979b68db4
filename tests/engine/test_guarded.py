"""Guarded segments on a real scene (a carton on the table), checked against raw MuJoCo contacts.

Every control step the test reads ``data.contact`` itself (hand and finger bodies vs the carton's or the
table's geoms, found from the model's body names) and sums ``mj_contactForce`` normals; nothing here uses
the helpers of the code under test.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import mujoco
import numpy as np
import pytest

from mgdata.engine.executor import AttemptResult, Executor
from mgdata.grasps.db import GraspDB
from mgdata.motion import Pose
from mgdata.record.episode import MemorySink
from mgdata.sim.assets import get_model
from mgdata.sim.taskspec import ObjectPlacement
from mgdata.skeleton import segment as s
from mgdata.skeleton.context import Context
from tests.engine.test_segments import DOWN, NEVER
from tests.helpers.scripted import ScriptedSkeleton, scripted_recipe, scripted_task

BOX = (ObjectPlacement("box", "box/carton_00", (0.5, 0.0, 0.0), 0.0),)
TOP = get_model("box/carton_00").size[2]
ABOVE_BOX = Pose([0.5, 0.0, TOP + 0.03], DOWN)
FREE_SPOT = Pose([0.45, 0.25, 0.06], DOWN)  # over bare table, TCP 6 cm up (fingertips ≈ 5 cm up)
FORCE_TOL = 0.10
"""The measured pair force may exceed ``max_force`` by at most this fraction (control-step samples)."""


@dataclass
class Log:
    """Raw readings after every control step: TCP height (m), hand–body contact, its normal force (N) and the
    actuator controls."""

    z: list[float] = field(default_factory=list)
    touching: list[bool] = field(default_factory=list)
    force: list[float] = field(default_factory=list)
    command: list[np.ndarray] = field(default_factory=list)

    def first_contact(self) -> int:
        return self.touching.index(True)


def _geoms(m: mujoco.MjModel, name: str) -> np.ndarray:
    """Mask over geoms: the hand and finger bodies for ``"hand"``, else the bodies named ``name`` or
    ``name/...`` (an object instance's bodies, or the table)."""
    names = ("hand", "left_finger", "right_finger") if name == "hand" else (name,)
    return np.array([m.body(int(b)).name.split("/")[0] in names for b in m.geom_bodyid])


def _run(script: list[s.MotionSegment], body: str,
         mover: str = "hand") -> tuple[Executor, AttemptResult, Log, MemorySink]:
    """Run ``script`` on the carton scene, logging the raw contacts between ``mover`` and ``body``."""
    ScriptedSkeleton.SCRIPT = script
    ex = Executor(scripted_task(BOX), scripted_recipe(NEVER, horizon=1200), grasps=GraspDB({}), render=False)
    m, d = ex.scene.model, ex.scene.data
    hand, target = _geoms(m, mover), _geoms(m, body)
    tcp = m.site("TCP").id
    log = Log()
    step = ex.controller.step

    def logged_step() -> None:
        step()
        total, touching, f6 = 0.0, False, np.zeros(6)
        for i in range(d.ncon):
            g1, g2 = d.contact.geom[i]
            if (hand[g1] and target[g2]) or (hand[g2] and target[g1]):
                mujoco.mj_contactForce(m, d, i, f6)
                total, touching = total + f6[0], True
        log.z.append(float(d.site_xpos[tcp][2]))
        log.touching.append(touching)
        log.force.append(total)
        log.command.append(d.ctrl.copy())

    ex.controller.step = logged_step  # type: ignore[method-assign]
    sink = MemorySink()
    result = ex.run(0, sink, keep_failed=True)
    return ex, result, log, sink


@pytest.mark.parametrize(("body", "above"), [("box", ABOVE_BOX), ("table", FREE_SPOT)])
def test_touch_stops_at_first_contact_and_rests_without_pushing(body: str, above: Pose) -> None:
    down = s.guarded("down", (0.0, 0.0, -1.0), until=s.touch(body), max_distance=0.08, max_force=20.0,
                     gripper="close")
    script = [s.free("above", above), s.gripper("close", "close", steps=10), down,
              s.hold("rest", steps=20, gripper="close"), s.reverse("up", of="down", gripper="close")]
    ex, result, log, _ = _run(script, body)
    try:
        assert result.stage == "goal_not_reached", result.reason  # every segment ran
        first = log.first_contact()
        in_contact = np.array(log.z[first: first + 21])
        # the TCP moved less than 2 mm further after the first contact (it was approaching at ~4 mm/s)
        assert log.z[first] - in_contact.min() < 0.002
        assert max(log.force) <= 20.0 * (1 + FORCE_TOL)
        # resting on the surface, the arm does not keep pushing: the force decays below a few newtons
        assert np.mean(log.force[first + 5: first + 20]) < 3.0
        # the reverse lifts it back to where the guarded move began (the free segment's end)
        assert abs(log.z[-1] - above.pos[2]) < 0.01 and not log.touching[-1]
    finally:
        ex.close()


@pytest.mark.parametrize(("threshold", "bound"), [(8.0, 12.0), (25.0, 40.0)])
def test_force_reaches_the_threshold_and_never_exceeds_the_bound(threshold: float, bound: float) -> None:
    press = s.guarded("press", (0.0, 0.0, -1.0), until=s.force("box", threshold), max_distance=0.08,
                      max_force=bound, gripper="close")
    script = [s.free("above", ABOVE_BOX), s.gripper("close", "close", steps=10), press,
              s.hold("rest", steps=20, gripper="close")]
    ex, result, log, _ = _run(script, "box")
    try:
        assert result.stage == "goal_not_reached", result.reason
        force = np.array(log.force)
        reached = int(np.argmax(force >= threshold))
        assert force[reached] >= threshold  # the threshold was reached ...
        assert force.max() <= bound * (1 + FORCE_TOL)  # ... and the bound held over the whole attempt
        # after the stop the arm rests where it is: the force falls instead of climbing on
        assert force[reached + 2] < threshold and force[reached + 2:].max() < threshold
    finally:
        ex.close()


def test_a_move_that_meets_nothing_fails_at_the_distance_limit() -> None:
    down = s.guarded("down", (0.0, 0.0, -1.0), until=s.touch("box"), max_distance=0.03, max_force=20.0)
    settle = 20
    script = [s.free("beside", FREE_SPOT), s.hold("settle", steps=settle), down, s.hold("rest", steps=5)]
    ex, result, log, _ = _run(script, "box")
    try:
        assert result.stage == "guarded_no_contact" and result.segment == "down" and not result.kept
        assert "30.0 mm" in (result.reason or "")
        assert not any(log.touching)
        # the guarded move starts after the settle hold: the first run of `settle` identical commands
        start = _after_still_run(log.command, settle)
        assert start is not None
        travel = log.z[start - 1] - log.z[-1]
        assert travel == pytest.approx(0.03, abs=0.002), f"the TCP travelled {travel * 1000:.1f} mm"
    finally:
        ex.close()
    continuing = s.guarded("down", (0.0, 0.0, -1.0), until=s.touch("box"), max_distance=0.03,
                           max_force=20.0, on_miss="continue")
    ex, result, log, _ = _run([s.free("beside", FREE_SPOT), continuing, s.hold("rest", steps=5)], "box")
    try:
        assert result.stage == "goal_not_reached"  # the miss was allowed: the later segments ran
        # the command runs on without a jump from the free segment into the guarded one, although the arm
        # still lags the free segment's last sample (the move starts where that command brings it to rest)
        change = np.abs(np.diff(np.array(log.command)[:, :7], axis=0)).max(axis=1)
        slow = int(np.argmax(change < 0.002))  # the free segment has decelerated
        assert slow > 0 and change[slow:].max() < 0.002, change[slow:].max()
    finally:
        ex.close()


def _after_still_run(commands: list[np.ndarray], n: int) -> int | None:
    """Index of the step after the first run of ``n`` identical commands."""
    run = 1
    for i in range(1, len(commands)):
        run = run + 1 if np.array_equal(commands[i], commands[i - 1]) else 1
        if run == n:
            return i + 1
    return None


def test_same_draw_gives_the_same_joint_trajectory_and_the_outcome_is_left_for_the_skeleton(
        monkeypatch: pytest.MonkeyPatch) -> None:
    contexts = []

    def below(ctx: Context) -> Pose:  # a runtime target, 6 cm under the TCP (inside the carton)
        contexts.append(ctx)
        return Pose(ctx.tcp_pose().pos - [0.0, 0.0, 0.06], DOWN)

    monkeypatch.setattr(ScriptedSkeleton, "TARGETS", {"below": below})
    press = s.guarded("press", "below", until=s.force("box", 6.0), max_force=15.0, gripper="close")
    script = [s.free("above", ABOVE_BOX), s.gripper("close", "close", steps=5), press]
    runs = []
    for _ in range(2):
        ex, result, log, sink = _run(script, "box")
        ex.close()
        frames = sink.episodes[0][0]
        runs.append((np.array([f.state for f in frames]), np.array([f.action for f in frames]), result.steps))
    assert runs[0][2] == runs[1][2]
    assert np.array_equal(runs[0][0], runs[1][0]) and np.array_equal(runs[0][1], runs[1][1])
    outcome = contexts[-1].memo["guarded/press"]
    assert outcome.met and outcome.stage is None
    stop = int(np.argmax(np.array(log.force) >= 6.0))  # the step the condition held, read raw
    assert outcome.force == pytest.approx(log.force[stop], rel=1e-9) and outcome.force >= 6.0
    assert outcome.peak_force == pytest.approx(max(log.force[: stop + 1]), rel=1e-9)


@pytest.mark.parametrize(("kwargs", "message"), [
    ({"until": s.force("box", 20.0), "max_force": 20.0, "max_distance": 0.1}, "below max_force"),
    ({"until": s.touch("box"), "max_force": 20.0}, "needs max_distance"),
    ({"until": s.touch("box"), "max_force": 0.0, "max_distance": 0.1}, "max_force must be > 0"),
    ({"until": s.touch("box"), "max_force": 5.0, "max_distance": -0.1}, "max_distance must be > 0"),
])
def test_bad_guarded_options_are_rejected(kwargs: dict, message: str) -> None:
    with pytest.raises(ValueError, match=message):
        s.guarded("g", (0.0, 0.0, -1.0), **kwargs)
    with pytest.raises(ValueError, match="3 numbers"):
        s.guarded("g", (0.0, -1.0), until=s.touch("box"), max_force=5.0, max_distance=0.1)
    with pytest.raises(ValueError, match="not all 0"):
        s.guarded("g", (0.0, 0.0, 0.0), until=s.touch("box"), max_force=5.0, max_distance=0.1)


def test_blocked_by_another_body_the_move_stalls_without_pushing_harder_than_the_bound() -> None:
    # heading for the table through the carton: the hand lands on the carton and cannot advance
    down = s.guarded("down", (0.0, 0.0, -1.0), until=s.touch("table"), max_distance=0.08, max_force=15.0,
                     gripper="close", allow=(("hand", "box"),))
    script = [s.free("above", ABOVE_BOX), s.gripper("close", "close", steps=10), down]
    ex, result, log, _ = _run(script, "box")
    try:
        assert result.stage == "guarded_stalled" and result.segment == "down", result.reason
        assert any(log.touching) and max(log.force) <= 15.0 * (1 + FORCE_TOL)
    finally:
        ex.close()


def test_a_held_carton_is_seated_on_the_table_with_the_force_asked_for() -> None:
    hold_at, lift = TOP - 0.03, 0.02
    carry = (("hand", "box"), ("box", "table"))
    seat = s.guarded("seat", (0.0, 0.0, -1.0), until=s.force("table", 5.0), max_distance=0.05, max_force=15.0,
                     gripper="close", attached="box", allow=(("hand", "box"),))
    script = [s.free("above", Pose([0.5, 0.0, TOP + 0.05], DOWN)),
              s.linear("down", Pose([0.5, 0.0, hold_at], DOWN), allow=(("hand", "box"),)),
              s.gripper("close", "close", steps=15),
              s.linear("lift", Pose([0.5, 0.0, hold_at + lift], DOWN), gripper="close", attached="box",
                       allow=carry),
              s.hold("carry", steps=10, gripper="close"), seat]
    ex, result, log, _ = _run(script, "table", mover="box")
    try:
        assert result.stage == "goal_not_reached", result.reason
        force = np.array(log.force)
        lifted = int(np.argmax(~np.array(log.touching)))  # the first step with the carton off the table
        assert not any(log.touching[lifted: lifted + 10])
        seated = lifted + int(np.argmax(force[lifted:] >= 5.0))
        assert force[seated] >= 5.0 and force[lifted:].max() <= 15.0 * (1 + FORCE_TOL)
    finally:
        ex.close()
