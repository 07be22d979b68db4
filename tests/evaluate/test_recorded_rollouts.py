"""``mgdata eval --record`` (issue 43): rollouts as LeRobot episodes that restore bit for bit at any step."""

from __future__ import annotations

import json
from pathlib import Path

import mujoco

from mgdata.evaluate.config import RandomConfig
from mgdata.evaluate.policies import RandomPolicy, ReplayPolicy
from mgdata.evaluate.rollout import LoopSettings
from mgdata.evaluate.run import EvalJob, read_results, run_eval
from mgdata.record.reader import DatasetReader
from mgdata.record.validate import validate_dataset
from tests.helpers.rawdata import raw_step


def test_recorded_rollouts_hold_the_records_and_restore_at_every_step(scenario_set: Path, demo: Path,
                                                                      tmp_path: Path, serving) -> None:  # type: ignore[no-untyped-def]
    url = serving(ReplayPolicy(demo, chunk=16, scenarios=scenario_set))
    out = tmp_path / "eval"
    settings = LoopSettings(url, convention="state", chunk_steps=8, horizon=120, record_dir=out / "rollouts")
    summary = run_eval(EvalJob(scenario_set, settings, (0,), out, families=("jar",)))
    records = read_results(summary.results)
    root = out / "rollouts" / "jar"
    reader = DatasetReader(root)
    assert reader.num_episodes == len(records) == 2
    assert not (out / "rollouts" / ".stage").exists()  # every staged rollout was appended
    demo_ep = DatasetReader(demo).episode(0)
    for i, rec in enumerate(records):  # plan order
        ep = reader.episode(i)
        meta = ep.meta
        assert meta.source == "rollout" and not meta.kept
        assert meta.variation["rollout"]["scenario"] == rec["scenario"]
        assert meta.variation["rollout"]["end"] == rec["end"] == "timeout"
        assert meta.seed == rec["episode_seed"] and meta.t_engage == rec["t_engage"]
        assert dict(meta.t_violation) == rec["t_violation_by"]
        assert ep.length == rec["steps"] + 1  # every observation, the final one included
        # the replayed demo's states, bit for bit: the rollout is the demo's first 120 steps
        assert ep.physics_state.tobytes() == demo_ep.physics_state[: ep.length].tobytes()
        # restored at step k (scene from meta/scenes, state k) and stepped with the next action's
        # stored controls, raw MuJoCo gives state k + 1 exactly
        model = mujoco.MjModel.from_binary_path("s.mjb", {"s.mjb": reader.scene_mjb(i)})
        substeps = round(0.05 / model.opt.timestep)
        for k in range(ep.length - 1):
            got = raw_step(model, ep.physics_state[k], ep.physics_state[k + 1], substeps)
            assert got.tobytes() == ep.physics_state[k + 1].tobytes(), k
    report = validate_dataset(root)
    assert report.ok, report.problems


def test_recording_does_not_change_the_records_and_workers_give_the_same_dataset(
        scenario_set: Path, tmp_path: Path, serving) -> None:  # type: ignore[no-untyped-def]
    url = serving(RandomPolicy(3, RandomConfig(chunk=16, joint_step=0.05, gripper_flip=0.05)))
    plain = LoopSettings(url, chunk_steps=4, horizon=30)
    base = run_eval(EvalJob(scenario_set, plain, (0, 1), tmp_path / "plain"))
    texts = []
    for workers in (1, 2):
        out = tmp_path / f"rec{workers}"
        settings = LoopSettings(url, chunk_steps=4, horizon=30, record_dir=out / "rollouts")
        run_eval(EvalJob(scenario_set, settings, (0, 1), out, workers=workers))
        assert (out / "rollouts.jsonl").read_text() == base.results.read_text()
        root = out / "rollouts" / "jar"
        files = sorted(p for p in root.rglob("*") if p.is_file() and ".work" not in p.parts)
        texts.append({p.relative_to(out).as_posix(): p.read_bytes() for p in files})
        assert json.loads((out / "eval.json").read_text())["loop"]["record"] is True
    assert texts[0].keys() == texts[1].keys() and texts[0] == texts[1]
