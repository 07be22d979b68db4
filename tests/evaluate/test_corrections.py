"""``mgdata corrections`` (issue 43): demonstrations restarted where a policy's recorded rollout went wrong.

The failed rollouts are real: a policy server replays the unsafe negative (the jar lifted with its lid
open) in the jar scenarios, recorded with ``mgdata eval --record``. Where a correction may start is checked
from raw MuJoCo on the rollout's stored states (contacts of the hand's geoms), and the kept corrections
against the family contract, from the corrections dataset alone.
"""

from __future__ import annotations

import json
import re
import shutil
import threading
from collections.abc import Iterator
from pathlib import Path

import mujoco
import numpy as np
import pytest

from mgdata.errors import DatasetError
from mgdata.evaluate.policies import ReplayPolicy
from mgdata.evaluate.rollout import LoopSettings
from mgdata.evaluate.run import EvalJob, read_results, run_eval
from mgdata.evaluate.server import PolicyServer
from mgdata.generate.corrections import REPORT_FILE, CorrectionJob, correct
from mgdata.record.reader import DatasetReader
from mgdata.record.repair import repair_dataset
from mgdata.record.rerender import RenderJob, rerender
from mgdata.record.validate import validate_dataset
from tests.helpers.cli import mgdata_here
from tests.helpers.contract import check_kept_contract
from tests.helpers.generate import jar_recipe
from tests.helpers.rawdata import hand_touches
from tests.helpers.record import dataset_files

BACK, CANDIDATES, TRIES = 8, 3, 2


def _error_line(proc) -> str:  # type: ignore[no-untyped-def]
    """The one line a refused command prints (exit status 2, no traceback)."""
    lines = [line for line in (proc.stdout + proc.stderr).splitlines() if line.strip()]
    assert proc.returncode == 2 and len(lines) == 1 and "Traceback" not in lines[0], proc
    return lines[0]


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
    return {model.body(model.body_rootid[b]).name for b in hand_touches(model, d)}


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


def test_a_render_and_a_repair_keep_the_corrections_run(corrected, tmp_path: Path) -> None:  # type: ignore[no-untyped-def]
    """A copy of a corrections dataset still says which run made it: its settings and its ledger."""
    _, out = corrected
    source = DatasetReader(out)
    rendered = rerender(RenderJob(out, tmp_path / "rendered", size=32, cameras=("wrist",))).out
    repaired = repair_dataset(out, tmp_path / "repaired").out
    for copy in (rendered, repaired):
        reader = DatasetReader(copy)
        assert reader.num_episodes == source.num_episodes
        assert reader.info["mgdata"]["corrections"] == source.info["mgdata"]["corrections"]
        assert (copy / REPORT_FILE).read_bytes() == (out / REPORT_FILE).read_bytes()
        assert validate_dataset(copy).ok
    assert "observation.images.wrist" in DatasetReader(rendered).info["features"]


def test_info_tells_rollouts_from_demonstrations_and_counts_every_try(corrected, rollouts: Path) -> None:  # type: ignore[no-untyped-def]
    _, out = corrected
    shown = mgdata_here("info", rollouts)
    assert shown.returncode == 0, shown.stderr
    assert "episodes    2 (policy rollouts: 0 succeeded, 2 unsafe)" in shown.stdout, shown.stdout
    assert "yield       none: 2 policy rollouts (0 succeeded), no demonstrations" in shown.stdout
    tries = sum(len(entry["tries"]) for entry in json.loads((out / REPORT_FILE).read_text())["rollouts"])
    kept = DatasetReader(out).num_episodes
    shown = mgdata_here("info", out)
    assert f"({kept} kept of {tries} attempts)" in shown.stdout, shown.stdout


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
    assert dataset_files(other) == dataset_files(out)
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


@pytest.fixture(scope="module")
def shards(corrected, tmp_path_factory: pytest.TempPathFactory) -> list[Path]:  # type: ignore[no-untyped-def]
    """``--shard 0/2`` and ``1/2`` of the ``corrected`` run: one failed rollout each."""
    job, _ = corrected
    tmp = tmp_path_factory.mktemp("corr_shards")
    found = []
    for i in range(2):
        proc = mgdata_here("corrections", job.rollouts, "--out", tmp / f"corr_{i}", "--back", BACK,
                           "--candidates", CANDIDATES, "--tries", TRIES, "--recipe", job.recipe,
                           "--workers", 1, "--shard", f"{i}/2")
        assert proc.returncode == 0, proc.stdout + proc.stderr
        found.append(tmp / f"corr_{i}")
    return found


def test_shards_merge_into_the_unsharded_dataset_byte_for_byte(corrected, shards, tmp_path: Path) -> None:  # type: ignore[no-untyped-def]
    job, out = corrected
    for i, shard in enumerate(shards):
        record = json.loads((shard / REPORT_FILE).read_text())["shard"]
        assert (record["index"], record["count"], record["episodes"]) == (i, 2, [i])
        assert record["settings"] == job.settings() and record["tasks"] is None
        parents = {r.meta.variation["restart"]["parent"]["episode"] for r in DatasetReader(shard).records()}
        assert parents <= {i}
    merged = tmp_path / "merged"
    proc = mgdata_here("merge", shards[1], shards[0], "--out", merged)  # any order
    assert proc.returncode == 0, proc.stdout + proc.stderr
    assert dataset_files(merged) == dataset_files(out)
    # a shard with no failed rollout of its own is written empty and completes its run: shards 0/3 and 1/3
    # hold what 0/2 and 1/2 hold (found[0::3] = found[0::2] for two failed rollouts), their reports N = 3
    empty = tmp_path / "corr_2of3"
    assert "an empty shard" in correct(CorrectionJob(job.rollouts, empty, back=BACK, candidates=CANDIDATES,
                                                     tries=TRIES, recipe=job.recipe, shard=(2, 3))).stopped
    assert DatasetReader(empty).num_episodes == 0
    thirds = []
    for i, shard in enumerate(shards):
        thirds.append(tmp_path / f"corr_{i}of3")
        shutil.copytree(shard, thirds[-1])
        report = json.loads((thirds[-1] / REPORT_FILE).read_text())
        report["shard"]["count"] = 3
        (thirds[-1] / REPORT_FILE).write_text(json.dumps(report, indent=2) + "\n")
    proc = mgdata_here("merge", *thirds, empty, "--out", tmp_path / "merged3")
    assert proc.returncode == 0, proc.stdout + proc.stderr
    assert dataset_files(tmp_path / "merged3") == dataset_files(out)


def test_a_shard_mismatch_is_one_error_line_and_writes_nothing(corrected, shards, tmp_path: Path) -> None:  # type: ignore[no-untyped-def]
    job, out = corrected
    other = tmp_path / "corr_1_back9"  # shard 1/2 of a run with other settings (its report says so)
    shutil.copytree(shards[1], other)
    report = json.loads((other / REPORT_FILE).read_text())
    report["shard"]["settings"]["back"] = BACK + 1
    (other / REPORT_FILE).write_text(json.dumps(report, indent=2) + "\n")
    unfinished = tmp_path / "corr_1_unfinished"  # shard 1/2 stopped before its rollout was committed
    shutil.copytree(shards[1], unfinished)
    report = json.loads((unfinished / REPORT_FILE).read_text())
    report["rollouts"] = []
    (unfinished / REPORT_FILE).write_text(json.dumps(report, indent=2) + "\n")
    cases = [((shards[0],), "shard 1/2 of the corrections run missing"),
             ((shards[0], shards[0]), "shard 0/2 is given twice"),
             ((shards[0], other), "settings {'back': 8"),
             ((shards[0], unfinished), "shard 1/2 is incomplete (0 of 1"),
             ((shards[0], out), "no shard in its meta/mgdata_corrections.json")]
    merged = tmp_path / "merged"
    for args, message in cases:
        assert message in _error_line(mgdata_here("merge", *args, "--out", merged)), args
        assert not merged.exists() and not list(tmp_path.glob("merged*")), args
    # a shard resumes only as itself; an unsharded dataset only unsharded
    before = dataset_files(shards[0])
    for where, shard, message in ((shards[0], (1, 2), "shard 0/2 vs 1/2"), (shards[0], None, "--shard 0/2"),
                                  (out, (0, 2), "without --shard")):
        with pytest.raises(DatasetError, match=re.escape(message)):
            correct(CorrectionJob(job.rollouts, where, back=BACK, candidates=CANDIDATES, tries=TRIES,
                                  recipe=job.recipe, shard=shard))
    assert dataset_files(shards[0]) == before
    for text, message in (("1of2", "expected i/N"), ("2/2", "0 <= i < N")):
        line = _error_line(mgdata_here("corrections", job.rollouts, "--out", tmp_path / "c", "--shard", text))
        assert message in line and not (tmp_path / "c").exists(), line
