"""``mgdata merge SHARD… --out OUT``: join the datasets of ``mgdata generate --shard i/N`` runs into the
dataset one run over all tasks would have written, byte for byte.

A single run commits attempts in the draw cursor's canonical order, which is ascending (draw index, task)
(the cursor always takes the task with the smallest next draw, ties by position; ``--shard`` requires the
tasks in ascending order), and a per-task quota makes the attempts of each task independent of the others.
So the merge re-stages every shard episode (frames, video packets copied without re-encoding, pixel
histograms, scene) and appends them sorted by (draw, task) with the ordinary writer, then records the
summed attempt count and the joined draw cursor. The shards must share the generator identity (family,
seed, inputs digest), schema and video settings, and no (task, draw) may appear twice. Labelled negatives
(``<shard>_failed``) are merged into ``<out>_failed`` the same way when every shard has them. Both are
built in ``.partial`` folders and renamed when complete, negatives first and ``out`` last, so ``out``
existing means the merge finished; a re-run after an interrupted merge replaces a leftover ``<out>_failed``.

Shards of ``mgdata corrections --shard i/N`` (their ``meta/mgdata_corrections.json`` records the shard,
:mod:`mgdata.generate.correction_report`) are joined the same way into the dataset the unsharded run
writes: one run commits each failed rollout's corrections in rollouts-dataset order, so the episodes are
appended sorted by their rollout's episode (each rollout's own in the order its shard committed them), and
the report's entries likewise. The shards must be ``0 … N−1`` of one ``N``, each complete, of one rollouts
dataset, ``--tasks`` and settings, with the same generator identity, schema and video settings.

``mgdata merge --concat A B … --out OUT`` (:func:`concat_datasets`) joins datasets of *different* runs of one
family (e.g. demos and their corrections, ``mgdata corrections``) into a training set: every episode of
``A``, then of ``B``, …, re-staged the same way. They must share schema, video settings, spec and gate; the
result records each input's generator identity under ``mgdata.joined`` and no generator of its own, so
``mgdata generate`` does not resume it.

Example::

    merge_shards([Path("ds/s0"), Path("ds/s1")], Path("ds/jar"))
    merge_shards([Path("ds/corr_0"), Path("ds/corr_1")], Path("ds/jar_corrections"))   # corrections shards
    concat_datasets([Path("ds/jar"), Path("ds/jar_corrections")], Path("ds/jar_round2"))
"""

from __future__ import annotations

import os
import shutil
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from mgdata.errors import DatasetError, OutputError
from mgdata.generate.correction_report import REPORT_FILE, CorrectionReport
from mgdata.generate.resume import RunState
from mgdata.generate.run import STATE_FILE, failed_path
from mgdata.lock import output_lock
from mgdata.record import layout
from mgdata.record.integrity import check_intact
from mgdata.record.reader import DatasetReader
from mgdata.record.restage import restage
from mgdata.record.writer import CARRIED_KEYS, RUN_IDENTITY, DatasetWriter


def merge_shards(shards: list[Path], out: Path) -> int:
    """Write the merged dataset (module docstring); returns its episode count. One merge at a time per
    ``out`` (:func:`mgdata.lock.output_lock`)."""
    out = Path(out)
    with output_lock(out):
        return _merge_shards(shards, out)


def _merge_shards(shards: list[Path], out: Path) -> int:
    if out.exists():
        raise OutputError(f"--out {out}: already exists; choose a new folder")
    if len(shards) < 1:
        raise DatasetError("merge needs at least one shard dataset")
    for shard in shards:  # damage would be copied into the merged dataset
        check_intact(Path(shard), "nothing was merged")
    readers = [DatasetReader(Path(s)) for s in shards]
    if any((r.root / REPORT_FILE).exists() for r in readers):
        return _merge_corrections(readers, out)
    states = [_state(r) for r in readers]
    _check_same(readers, states)
    failed = [failed_path(Path(s)) for s in shards]
    with_failed = all((f / layout.INFO_PATH).exists() for f in failed)
    joined = RunState(states[0].family, states[0].seed, states[0].inputs_digest,
                      next_draw={t: d for s in states for t, d in s.next_draw.items()},
                      attempts=sum(s.attempts for s in states))
    part = _build(readers, _draw_order(readers), out, joined)
    if with_failed:
        negatives = [DatasetReader(f) for f in failed]
        failed_part = _build(negatives, _draw_order(negatives), failed_path(out))
        shutil.rmtree(failed_path(out), ignore_errors=True)  # left by a merge stopped before its last rename
        os.replace(failed_part, failed_path(out))
    os.replace(part, out)
    return sum(r.num_episodes for r in readers)


def concat_datasets(datasets: list[Path], out: Path) -> int:
    """Write every episode of ``datasets``, in the order given, into a new dataset ``out`` (module
    docstring); returns its episode count."""
    out = Path(out)
    with output_lock(out):
        if out.exists():
            raise OutputError(f"--out {out}: already exists; choose a new folder")
        for root in datasets:
            check_intact(Path(root), "nothing was merged")
        readers = [DatasetReader(Path(d)) for d in datasets]
        first = readers[0]
        families = {rec.meta.family for r in readers for rec in r.records()}
        if len(families) > 1:
            raise DatasetError(f"the datasets hold episodes of {sorted(families)}; --concat joins one family")
        for r in readers[1:]:
            _check_like(r, first)
        joined = [{"dataset": r.root.name, "episodes": r.num_episodes,
                   "generator": r.info["mgdata"].get("generator")} for r in readers]
        part = out.with_name(out.name + ".partial")
        shutil.rmtree(part, ignore_errors=True)
        with DatasetWriter.create_like(part, first, mgdata={"joined": joined}, identity=False) as writer:
            stage = writer.root / layout.WORK_DIR / "merge"
            for r in readers:
                for rec in r.records():
                    writer.append_staged(restage(r, rec.index, stage))
        os.replace(part, out)
        return sum(r.num_episodes for r in readers)


def _check_like(r: DatasetReader, first: DatasetReader) -> None:
    if r.schema != first.schema or r.video != first.video or r.spec != first.spec or \
            (r.hold_steps, r.kept_only) != (first.hold_steps, first.kept_only):
        raise DatasetError(f"{r.root}: its schema, video settings, spec or gate differ from "
                           f"{first.root}'s")


def _state(reader: DatasetReader) -> RunState:
    state = RunState.load(reader.root / STATE_FILE)
    if state is None:
        raise DatasetError(f"{reader.root}: no {STATE_FILE}; only datasets of mgdata generate --shard merge")
    return state


def _check_same(readers: list[DatasetReader], states: list[RunState]) -> None:
    first, s0 = readers[0], states[0]
    seen: dict[tuple[int, int], Path] = {}
    for r, s in zip(readers, states, strict=True):
        if (s.family, s.seed, s.inputs_digest) != (s0.family, s0.seed, s0.inputs_digest):
            raise DatasetError(f"{r.root}: generated as {s.family!r} seed {s.seed} inputs "
                               f"{s.inputs_digest}, {first.root} as {s0.family!r} seed {s0.seed} inputs "
                               f"{s0.inputs_digest}: shards of one run must agree")
        _check_like(r, first)
        for rec in r.records():
            key = (rec.meta.task_id, rec.meta.draw_index)
            if key in seen:
                raise DatasetError(f"task {key[0]} draw {key[1]} is in both {seen[key]} and {r.root}: the "
                                   "shards overlap")
            seen[key] = r.root
        if any(t in other.next_draw for other in states if other is not s for t in s.next_draw):
            raise DatasetError(f"{r.root}: shares tasks with another shard; give each shard its own "
                               "--shard i/N")


def _draw_order(readers: list[DatasetReader]) -> list[tuple[int, int]]:
    """(reader, episode) of every shard episode in a generate run's commit order: by (draw, task)."""
    order = sorted(((rec.meta.draw_index, rec.meta.task_id, k, rec.index)
                    for k, r in enumerate(readers) for rec in r.records()))
    return [(k, e) for _, _, k, e in order]


def _merge_corrections(readers: list[DatasetReader], out: Path) -> int:
    """Join the shards of one ``mgdata corrections --shard`` run (module docstring)."""
    reports = [CorrectionReport.load(r.root / REPORT_FILE) for r in readers]
    _check_correction_shards(readers, reports)
    order = sorted((_parent(rec.meta.variation), k, rec.index) for k, r in enumerate(readers)
                   for rec in r.records())
    # the run's own info.json keys, in the order it wrote them (create_like would put the rest first)
    mg = readers[0].info["mgdata"]
    own = {k: v for k, v in mg.items() if k in RUN_IDENTITY + CARRIED_KEYS}
    part = _build(readers, [(k, e) for _, k, e in order], out, mgdata=own)
    entries = sorted((e for rep in reports for e in rep.rollouts), key=lambda e: int(e["parent"]["episode"]))
    CorrectionReport(entries).save(part / REPORT_FILE)
    os.replace(part, out)
    return len(order)


def _parent(variation: Mapping[str, Any]) -> int:
    """The rollouts-dataset episode a correction restarted from."""
    return int(variation["restart"]["parent"]["episode"])


def _check_correction_shards(readers: list[DatasetReader], reports: list[CorrectionReport]) -> None:
    first = readers[0]
    s0 = reports[0].shard
    given: dict[int, Path] = {}
    for r, rep in zip(readers, reports, strict=True):
        s = rep.shard
        if s is None or s0 is None:
            raise DatasetError(f"{r.root if s is None else first.root}: no shard in its {REPORT_FILE}; merge "
                               "joins the shards of one mgdata corrections --shard run (or of one mgdata "
                               "generate --shard run)")
        diffs = s0.differences(s)
        if r.info["mgdata"].get("generator") != first.info["mgdata"].get("generator"):
            diffs.append("generator (family, seed, inputs digest)")
        if diffs:
            raise DatasetError(f"{r.root}: shard {s.name} is of another corrections run than {first.root} "
                               f"({'; '.join(diffs)}, {first.root}'s first); shards of one run must agree")
        _check_like(r, first)
        if s.index in given:
            raise DatasetError(f"shard {s.name} is given twice: {given[s.index]} and {r.root}")
        given[s.index] = r.root
        done, mine = set(rep.episodes), set(s.episodes)
        if not done <= mine or not {_parent(rec.meta.variation) for rec in r.records()} <= mine:
            raise DatasetError(f"{r.root}: holds corrections of rollouts outside its shard {s.name}; it was "
                               "changed after its run: nothing was merged")
        if done != mine:
            raise DatasetError(f"{r.root}: shard {s.name} is incomplete ({len(done)} of {len(mine)} failed "
                               f"rollouts corrected); run its mgdata corrections --shard {s.name} command "
                               "again to finish it")
    assert s0 is not None
    missing = [f"{i}/{s0.count}" for i in range(s0.count) if i not in given]
    if missing:
        raise DatasetError(f"shard{'s' if len(missing) > 1 else ''} {', '.join(missing)} of the corrections "
                           f"run missing: give all {s0.count} shards")


def _build(readers: list[DatasetReader], order: list[tuple[int, int]], out: Path,
           state: RunState | None = None, mgdata: dict[str, Any] | None = None) -> Path:
    """The dataset of episodes ``order`` ((reader, episode) pairs) in ``<out>.partial``, written as
    ``readers[0]`` was (its identity, ``mgdata``'s keys first); returns that folder."""
    first = readers[0]
    part = out.with_name(out.name + ".partial")
    shutil.rmtree(part, ignore_errors=True)
    with DatasetWriter.create_like(part, first, mgdata=mgdata) as writer:
        stage = writer.root / layout.WORK_DIR / "merge"
        for k, e in order:
            writer.append_staged(restage(readers[k], e, stage))
        counts = [r.info["mgdata"].get("attempts") for r in readers]
        if any(c is not None for c in counts):  # negatives datasets record none
            writer.record_attempts(sum(c or 0 for c in counts))
    if state is not None:
        state.save(part / STATE_FILE)
    return part
