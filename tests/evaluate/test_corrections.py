"""``mgdata corrections`` (issue 43): demonstrations restarted where a policy's recorded rollout went wrong.

The failed rollouts are real: a policy server replays the unsafe negative (the jar lifted with its lid
open) in the jar scenarios, recorded with ``mgdata eval --record``. Where a correction may start is checked
from raw MuJoCo on the rollout's stored states (contacts of the hand's geoms), and the kept corrections
against the family contract, from the corrections dataset alone.
"""

from __future__ import annotations

import json
import threading
from collections.abc import Iterator
from pathlib import Path

import mujoco
import numpy as np
import pytest

from mgdata.evaluate.policies import ReplayPolicy
from mgdata.evaluate.rollout import LoopSettings
from mgdata.evaluate.run import EvalJob, read_results, run_eval
from mgdata.evaluate.server import PolicyServer
from mgdata.generate.corrections import REPORT_FILE, CorrectionJob, correct
from mgdata.record.reader import DatasetReader
from mgdata.record.validate import validate_dataset
from tests.helpers.cli import mgdata_here
from tests.helpers.contract import check_kept_contract
from tests.helpers.generate import jar_recipe

HAND = ("hand", "left_finger", "right_finger")
BACK, CANDIDATES, TRIES = 8, 3, 2


@pytest.fixture(scope="module")
def rollouts(scenario_set: Path, unsafe_demo: Path,
             tmp_path_factory: pytest.TempPathFactory) -> Iterator[Path]:
    """The recorded rollouts of the unsafe negative replayed in jar task 0's base and target scenarios."""
    server = PolicyServer(ReplayPolicy(unsafe_demo, chunk=16, scenarios=scenario_set), port=0)
    threading.Thread(target=server.serve_forever, daemon=True).start()
    out = tmp_path_factory.mktemp("eval")
    settings = LoopSettings(server.url, convention="state", chunk_steps=8, horizon=100,
                            record_dir=out / "rollouts")
    summary = run_eval(EvalJob(scenario_set, settings, (0,), out, families=("jar",)))
    server.shutdown()
    assert all(r["t_violation"] is not None for r in read_results(summary.results))  # both failed
    yield out / "rollouts" / "jar"


@pytest.fixture(scope="module")
def corrected(rollouts: Path, tmp_path_factory: pytest.TempPathFactory) -> tuple[CorrectionJob, Path]:
    tmp = tmp_path_factory.mktemp("corrections")
    job = CorrectionJob(rollouts, tmp / "jar_corrections", back=BACK, candidates=CANDIDATES, tries=TRIES,
                        recipe=jar_recipe(tmp / "recipe"))
    summary = correct(job)
    assert summary.stopped == "every failed rollout tried" and summary.kept >= 1, summary
    return job, job.out


def _hand_touches(model: mujoco.MjModel, state: np.ndarray, spec: int) -> set[str]:
    """Root bodies of the objects a hand or finger geom touches in ``state`` (raw MuJoCo contacts)."""
    d = mujoco.MjData(model)
    mujoco.mj_setState(model, d, state, spec)
    mujoco.mj_forward(model, d)
    hand = {model.body(b).id for b in HAND}
    touched = set()
    for c in d.contact[: d.ncon]:
        b1, b2 = int(model.geom_bodyid[c.geom1]), int(model.geom_bodyid[c.geom2])
        for a, b in ((b1, b2), (b2, b1)):
            root = int(model.body_rootid[b])
            if a in hand and root != int(model.body_rootid[a]):
                touched.add(model.body(root).name)
    return touched


def test_corrections_restart_before_the_failure_where_the_hand_is_free(corrected, rollouts: Path) -> None:  # type: ignore[no-untyped-def]
    job, out = corrected
    report = json.loads((out / REPORT_FILE).read_text())
    source = DatasetReader(rollouts)
    spec = source.physics_spec
    assert spec is not None
    assert [e["parent"]["episode"] for e in report["rollouts"]] == list(range(source.num_episodes))
    refused = kept = 0
    for entry in report["rollouts"]:
        i = entry["parent"]["episode"]
        ep = source.episode(i)
        first = min(t for t in ep.meta.t_violation.values() if t is not None)
        assert entry["failure"] == "unsafe" and entry["failure_step"] == first
        steps = [t["step"] for t in entry["tries"]]
        assert steps == sorted(steps, reverse=True) and set(steps) <= set(range(first - BACK, 0, -BACK))
        tried = {t["step"] for t in entry["tries"] if t["stage"] != "restart_refused"}
        assert len(tried) <= CANDIDATES and (entry["corrections"] or len(tried) == CANDIDATES)
        model = mujoco.MjModel.from_binary_path("s.mjb", {"s.mjb": source.scene_mjb(i)})
        for t in entry["tries"]:
            touched = _hand_touches(model, ep.physics_state[t["step"]], spec)
            if t["stage"] == "restart_refused":
                refused += 1
                assert t["reason"].startswith("restart.holding") and touched, t  # an object in the hand
            else:
                assert not touched, t  # a restart is tried only with a free hand
            kept += t["kept"]
        assert sum(t["kept"] for t in entry["tries"]) == entry["corrections"] <= job.per_failure
    assert refused >= 1, "a candidate with the jar in the hand is refused"
    reader = DatasetReader(out)
    assert reader.num_episodes == kept >= 1
    for k in range(reader.num_episodes):
        ep = reader.episode(k)
        restart = ep.meta.variation["restart"]
        parent = source.episode(restart["parent"]["episode"])
        assert ep.meta.source == "correction" and ep.meta.kept
        assert restart["parent"]["scenario"] == parent.meta.variation["rollout"]["scenario"]
        assert restart["parent"]["policy"] == "replay" and restart["phases"]
        # the correction starts in the very state the policy left the scene in at its restart frame
        assert ep.physics_state[0].tobytes() == parent.physics_state[restart["step"]].tobytes()
        assert reader.scene_mjb(k) == source.scene_mjb(restart["parent"]["episode"])


def test_kept_corrections_keep_the_family_contract_and_validate(corrected) -> None:  # type: ignore[no-untyped-def]
    _, out = corrected
    check_kept_contract("jar", out)
    report = validate_dataset(out)
    assert report.ok, report.problems


def test_a_second_run_resumes_and_changes_nothing(corrected) -> None:  # type: ignore[no-untyped-def]
    job, out = corrected
    before = {p: p.read_bytes() for p in out.rglob("*") if p.is_file() and ".work" not in p.parts}
    summary = correct(job)
    assert summary.stopped == "every failed rollout was corrected before" and summary.attempts == 0
    assert {p: p.read_bytes() for p in out.rglob("*") if p.is_file() and ".work" not in p.parts} == before


def test_two_workers_write_the_same_bytes(corrected, tmp_path: Path) -> None:  # type: ignore[no-untyped-def]
    job, out = corrected
    other = tmp_path / "jar_corrections"
    proc = mgdata_here("corrections", job.rollouts, "--out", other, "--back", BACK, "--candidates",
                       CANDIDATES, "--tries", TRIES, "--recipe", job.recipe, "--workers", 2)
    assert proc.returncode == 0, proc.stdout + proc.stderr

    def files(root: Path) -> dict[str, bytes]:
        return {p.relative_to(root).as_posix(): p.read_bytes() for p in root.rglob("*")
                if p.is_file() and ".work" not in p.parts}
    assert files(other) == files(out)
    # demos and their corrections join into one training set (here: the two copies), in the order given
    joined = tmp_path / "joined"
    proc = mgdata_here("merge", "--concat", out, other, "--out", joined)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    a, b, j = DatasetReader(out), DatasetReader(other), DatasetReader(joined)
    assert j.num_episodes == a.num_episodes + b.num_episodes
    for k in range(j.num_episodes):
        src, e = (a, k) if k < a.num_episodes else (b, k - a.num_episodes)
        assert j.episode(k).physics_state.tobytes() == src.episode(e).physics_state.tobytes()
        assert j.episode(k).meta == src.episode(e).meta
    assert validate_dataset(joined).ok
    proc = mgdata_here("generate", "--family", "jar", "--n", "3", "--out", joined, "--recipe", job.recipe)
    assert proc.returncode != 0 and "records no generator inputs" in proc.stdout + proc.stderr


def test_bad_input_is_one_error_line_and_writes_nothing(rollouts: Path, demo: Path, tmp_path: Path) -> None:
    out = tmp_path / "c"
    cases = [((demo,), "is no recorded rollout"), ((rollouts, "--tasks", "999"), "--tasks"),
             ((tmp_path / "missing",), "no such rollouts folder"), ((rollouts, "--back", "0"), "--back")]
    for args, message in cases:
        proc = mgdata_here("corrections", *args, "--out", out)
        assert proc.returncode != 0 and message in proc.stdout + proc.stderr, (args, proc)
        assert "Traceback" not in proc.stdout + proc.stderr
        assert not out.exists(), args
    proc = mgdata_here("corrections", rollouts, "--out", rollouts)
    assert proc.returncode != 0 and "not into the rollouts" in proc.stdout + proc.stderr
