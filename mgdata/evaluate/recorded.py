"""Recorded rollouts (``mgdata eval --record``): every rollout as an episode of a LeRobot v3.0 dataset.

With ``--record`` each rollout's episode is recorded as a generated one is (:mod:`mgdata.record`): per
step the measured state, the action executed (gripper thresholded), the labels, DFA states, violated
flags, engaged and success columns and the physics state (``sim.physics_state``), with the scenario's
compiled scene in ``meta/scenes``; no camera images (``mgdata render`` adds them from the physics states).
Its metadata: ``mgdata/source = rollout``, ``kept`` false, ``success``, ``t_engage``, ``t_violation`` (per
constraint) and ``variation.rollout`` (scenario, base seed, end, t_success, the policy's name);
``mgdata/seed`` is the rollout's seed and ``mgdata/draw_index`` its base seed.

Rollouts go to ``<out>/rollouts/<family>`` (one dataset per family: the families' schemas differ). A worker
stages its rollout's episode in ``<out>/rollouts/.stage/<rollout>`` before its record reaches
``rollouts.jsonl``; when every rollout of the run is in, the staged episodes are appended in plan order,
each removed once committed, so the datasets are the same for any worker count and an interrupted run's
staged rollouts are appended by the next. A rollout is then restored at any step by setting the scene from
``meta/scenes`` to its ``sim.physics_state`` (``mgdata corrections`` restarts demonstrations there).
"""

from __future__ import annotations

import shutil
from collections.abc import Sequence
from pathlib import Path

from mgdata.evaluate.restore import scenario_spec
from mgdata.record.recorder import schema_for
from mgdata.record.staging import EpisodeStager, StagedEpisode
from mgdata.record.writer import DatasetWriter
from mgdata.sim.scene import Scene

ROLLOUTS = "rollouts"
"""The recorded rollouts' folder in an eval's ``--out``."""
STAGE = ".stage"


def rollout_key(variation: dict) -> tuple[str, int]:
    """(scenario, base seed) of a recorded rollout's ``variation``."""
    origin = variation["rollout"]
    return origin["scenario"], int(origin["seed"])


def stager(record_dir: Path, name: str, scene: Scene) -> EpisodeStager:
    """The stager of one rollout (``name``: its file stem, e.g. ``jar_task_0000_base_seed0``); a staged
    folder of the same rollout left by an interrupted run is dropped (the rollout runs again)."""
    path = record_dir / STAGE / name
    for old in (path, path.with_name(path.name + ".partial")):
        shutil.rmtree(old, ignore_errors=True)
    path.parent.mkdir(parents=True, exist_ok=True)
    return EpisodeStager(path, schema_for(scene, scene.task.safety, None))


def append_staged(record_dir: Path, names: Sequence[str], scenarios: Path) -> int:
    """Append the staged rollouts ``names`` (plan order; those not staged are skipped) to their family's
    dataset under ``record_dir`` (a new one stores the spec of the first rollout's scenario, read from the
    set ``scenarios``); a rollout already in its dataset (a commit whose clean-up a kill cut
    short) is not appended again. Returns how many were appended."""
    writers: dict[str, DatasetWriter] = {}
    present: dict[str, set[tuple[str, int]]] = {}
    appended = 0
    try:
        for name in names:
            path = record_dir / STAGE / name
            if not path.is_dir():
                continue
            staged = StagedEpisode.load(path)
            family = staged.meta.family
            if family not in writers:
                root = record_dir / family
                if root.exists() and any(p.name != ".work" for p in root.iterdir()):
                    writers[family] = DatasetWriter.open(root)
                    present[family] = {rollout_key(dict(m.variation))
                                       for m in writers[family].episodes_meta()}
                else:
                    spec = scenario_spec(scenarios / rollout_key(dict(staged.meta.variation))[0])
                    writers[family] = DatasetWriter.create(root, staged.schema, spec=spec,
                                                           mgdata={"source": "rollouts"})
                    present[family] = set()
            if rollout_key(dict(staged.meta.variation)) in present[family]:
                shutil.rmtree(path)
                continue
            writers[family].append_staged(path)
            present[family].add(rollout_key(dict(staged.meta.variation)))
            appended += 1
    finally:
        for writer in writers.values():
            writer.close()
    stage = record_dir / STAGE
    if stage.is_dir() and not any(stage.iterdir()):
        stage.rmdir()
    return appended
