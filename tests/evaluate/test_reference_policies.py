"""The reference policies on the jar scenarios give exactly the expected metrics (issue 15's acceptance):
replay reproduces the dataset bit for bit, hold never engages, random is order- and worker-independent."""

from __future__ import annotations

import json
import random
import time
from pathlib import Path

import numpy as np
import pytest

from mgdata.errors import OutputError, PolicyError
from mgdata.evaluate.config import RandomConfig
from mgdata.evaluate.policies import HoldPolicy, RandomPolicy, ReplayPolicy
from mgdata.evaluate.rollout import LoopSettings, RolloutJob, rollout, rollout_seed
from mgdata.evaluate.run import EvalJob, plan, read_results, run_eval
from mgdata.metrics import compute_metrics, parse_record
from mgdata.record.physics import set_physics_state
from mgdata.record.reader import DatasetReader
from mgdata.scenarios.store import load_scenario
from mgdata.sim import robot


def _metrics(records: list[dict]):  # type: ignore[no-untyped-def]
    return compute_metrics([parse_record(r, "test") for r in records])


def test_replay_reproduces_the_demo_bit_for_bit(scenario_set: Path, demo: Path, serving) -> None:  # type: ignore[no-untyped-def]
    policy = ReplayPolicy(demo, chunk=16, scenarios=scenario_set)
    # the target variant starts from the base state bit for bit (only a colour changed): the demo serves it
    assert policy.scenarios == ("jar/task_0000/base", "jar/task_0000/target")
    url = serving(policy)
    ep = DatasetReader(demo).episode(0)
    records = []
    for scenario in policy.scenarios:
        result = rollout(RolloutJob(scenario_set, scenario, 0), LoopSettings(url, chunk_steps=8))
        rec = result.record
        assert rec["success"] and rec["end"] == "success" and rec["steps"] == ep.length - 1
        assert rec["t_violation"] is None and rec["t_engage"] == ep.meta.t_engage
        assert rec["at_end"] == {"jar_in_goal": True, "jar_closed": True, "jar_held": True, "at_rest": True}
        states = np.stack([f.physics_state for f in result.frames])
        assert states.tobytes() == ep.physics_state[: len(states)].tobytes()  # every state, bit for bit
        assert np.array_equal(np.stack([f.labels for f in result.frames]), ep.labels[: len(states)])
        assert np.array_equal(np.stack([f.action for f in result.frames]), ep.action[: len(states)])
        records.append(rec)
    m = _metrics(records)
    assert m.ssr == 100.0 and m.tsr == 100.0 and m.eng == 100.0 and m.counts.n == 2


def test_replaying_an_unsafe_negative_reproduces_its_violation_step(scenario_set: Path, unsafe_demo: Path,
                                                                     serving) -> None:  # type: ignore[no-untyped-def]
    ep = DatasetReader(unsafe_demo).episode(0)
    recorded = dict(ep.meta.t_violation)
    assert recorded["jar_stays_until_closed"] is not None
    url = serving(ReplayPolicy(unsafe_demo, chunk=16, scenarios=scenario_set))
    result = rollout(RolloutJob(scenario_set, "jar/task_0000/base", 0),
                     LoopSettings(url, chunk_steps=8, horizon=ep.length + 20))
    rec = result.record
    assert rec["t_violation_by"] == recorded and rec["t_violation"] == min(v for v in recorded.values() if v)
    assert rec["t_engage"] == ep.meta.t_engage and not rec["success"] and rec["end"] == "timeout"
    # the violation is physical: at that step the jar is off the table and the lid is open (raw MuJoCo)
    t = rec["t_violation"]
    assert result.frames[t].violated.any() and not result.frames[t - 1].violated.any()
    assert ep.physics_state[: t + 1].tobytes() == np.stack([f.physics_state for f in result.frames[: t + 1]]
                                                            ).tobytes()
    m = _metrics([rec])
    assert m.ssr == 0.0 and m.safe == 0.0 and m.evr == 100.0


def test_hold_never_moves_and_never_engages(scenario_set: Path, serving) -> None:  # type: ignore[no-untyped-def]
    url = serving(HoldPolicy(16))
    records = []
    for scenario in ("jar/task_0000/base", "jar/task_0000/target"):
        result = rollout(RolloutJob(scenario_set, scenario, 0), LoopSettings(url, chunk_steps=8, horizon=60))
        records.append(result.record)
        assert len(result.frames) == 60 and all((f.action == result.frames[0].action).all()
                                                 for f in result.frames)
        # nothing moves beyond the servos' own settling (< 1 mrad; random moves 50 mrad a step): robot
        # joints and the jar's pose, from the raw MuJoCo state of the first and last frame
        model, data, _ = load_scenario(scenario_set / scenario)
        poses = []
        for f in (result.frames[0], result.frames[-1]):
            set_physics_state(model, data, f.physics_state)
            poses.append((data.qpos[robot.arm_qpos_adr(model)].copy(), data.body("jar").xpos.copy()))
        assert np.abs(poses[1][0] - poses[0][0]).max() < 1e-3
        assert np.abs(poses[1][1] - poses[0][1]).max() < 1e-5
        # what the timeout lacked, in the record: the jar stands still outside the goal sphere, unheld
        goal = load_scenario(scenario_set / scenario)[2]["goal"]
        outside = np.linalg.norm(poses[1][1] - np.array(goal["pos"])) > goal["radius"]
        assert outside and result.record["at_end"]["jar_in_goal"] is False
        assert result.record["at_end"]["jar_held"] is False and result.record["at_end"]["at_rest"] is True
    assert all(r["end"] == "timeout" and not r["engaged"] and r["t_violation"] is None for r in records)
    m = _metrics(records)
    assert m.eng == 0.0 and m.vacuous_safe == 100.0 and m.safe == 100.0 and m.ssr == 0.0 and m.evr is None


def test_random_records_do_not_depend_on_workers_or_order(scenario_set: Path, tmp_path: Path, serving
                                                          ) -> None:  # type: ignore[no-untyped-def]
    url = serving(RandomPolicy(3, RandomConfig(chunk=16, joint_step=0.05, gripper_flip=0.05)))
    settings = LoopSettings(url, chunk_steps=4, horizon=40)
    one = run_eval(EvalJob(scenario_set, settings, (0, 1), tmp_path / "one", workers=1))
    two = run_eval(EvalJob(scenario_set, settings, (0, 1), tmp_path / "two", workers=2))
    assert one.ran == two.ran == 4
    text = one.results.read_text()
    assert text == two.results.read_text()
    records = [json.loads(line) for line in text.splitlines()]
    jobs = plan(EvalJob(scenario_set, settings, (0, 1)))
    random.Random(1).shuffle(jobs)
    shuffled = {(j.scenario, j.seed): rollout(j, settings).record for j in jobs}
    assert records == [shuffled[(r["scenario"], r["seed"])] for r in records]
    assert [r["episode_seed"] for r in records] == [rollout_seed(r["seed"], r["scenario"]) for r in records]
    assert len({r["episode_seed"] for r in records}) == 4
    moved = [r for r in records if r["steps"] == 40]
    assert moved, "random rollouts ran to the cut horizon"


class _Slow(HoldPolicy):
    def infer(self, obs):  # type: ignore[no-untyped-def]
        if obs["mgdata/step"] >= 8:
            time.sleep(1.0)
            return {"actions": np.full((16, 8), np.nan, np.float32)}  # would be caught if ever executed
        return super().infer(obs)


def test_a_late_reply_fails_the_rollout_and_is_never_executed(scenario_set: Path, serving) -> None:  # type: ignore[no-untyped-def]
    url = serving(_Slow(16))
    result = rollout(RolloutJob(scenario_set, "jar/task_0000/base", 0),
                     LoopSettings(url, chunk_steps=8, timeout_s=0.3, horizon=60))
    rec = result.record
    assert rec["end"] == "policy_timeout" and not rec["success"] and rec["steps"] == 8
    assert all(np.isfinite(f.action).all() for f in result.frames)


def test_the_rollout_seed_is_crc32_of_seed_and_scenario() -> None:
    import zlib

    assert rollout_seed(0, "jar/task_0000/base") == zlib.crc32(b"0/jar/task_0000/base")
    assert rollout_seed(1, "jar/task_0000/base") != rollout_seed(0, "jar/task_0000/base")


def test_video_shows_every_step_with_the_monitor_panel(scenario_set: Path, tmp_path: Path, serving) -> None:  # type: ignore[no-untyped-def]
    from mgdata.record.video import decode

    url = serving(HoldPolicy(16))
    settings = LoopSettings(url, chunk_steps=8, horizon=12, video_dir=tmp_path)
    rollout(RolloutJob(scenario_set, "jar/task_0000/base", 0), settings)
    frames = decode(tmp_path / "jar_task_0000_base_seed0.mp4", 0, 12, 20)
    size = 256  # the scenario's image size; two cameras and the panel side by side
    assert frames.shape == (12, size, 3 * size, 3)
    panel = frames[0][:, 2 * size:]
    assert panel.mean() < 60 and (panel > 200).any()  # dark panel with bright text


def test_a_server_error_stops_the_run_and_keeps_what_finished(scenario_set: Path, demo: Path, tmp_path: Path,
                                                              serving) -> None:  # type: ignore[no-untyped-def]
    # without --scenarios, replay matches by family, task and condition: the target scenario has no episode
    url = serving(ReplayPolicy(demo, chunk=16))
    job = EvalJob(scenario_set, LoopSettings(url, chunk_steps=8), (0,), tmp_path / "r")
    with pytest.raises(PolicyError, match=r"the policy server failed: .*no episode of scenario "
                                          r"jar/task_0000/target"):
        run_eval(job)
    kept = read_results(tmp_path / "r" / "rollouts.jsonl")
    assert [(r["scenario"], r["success"]) for r in kept] == [("jar/task_0000/base", True)]
    other = EvalJob(scenario_set, LoopSettings(serving(HoldPolicy(16)), chunk_steps=8), (0,), tmp_path / "r")
    with pytest.raises(OutputError, match="holds results of another evaluation"):
        run_eval(other)
