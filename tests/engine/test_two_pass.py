"""Two-pass generation: attempts run without cameras and only recorded episodes are rendered afterwards,
from their physics states. The datasets (kept and ``--keep-failed`` negatives) must be byte-identical to
rendering every step during execution."""

from __future__ import annotations

from pathlib import Path

from mgdata.generate.run import GenerateJob, failed_path, generate
from mgdata.record.reader import DatasetReader
from tests.helpers.generate import low_yield_recipe
from tests.helpers.record import dataset_files


def test_rendering_after_the_gate_writes_the_same_bytes(tmp_path: Path) -> None:
    recipe = low_yield_recipe(tmp_path)
    outs = {}
    for after in (True, False):
        out = tmp_path / ("after" if after else "during")
        summary = generate(GenerateJob(family="jar", n=3, out=out, tasks=(0,), keep_failed=True,
                                       max_attempts=4, recipe=recipe, render_after=after))
        outs[after] = (out, summary)
    (after, s_after), (during, s_during) = outs[True], outs[False]
    assert (s_after.kept, s_after.attempts) == (s_during.kept, s_during.attempts)
    kept, failed = DatasetReader(after), DatasetReader(failed_path(after))
    assert kept.num_episodes >= 1 and failed.num_episodes >= 1, (s_after.stages, s_after.kept)
    assert kept.frames(0, "front").std() > 5  # real pictures, not blank frames
    assert dataset_files(after) == dataset_files(during)
    assert dataset_files(failed_path(after)) == dataset_files(failed_path(during))
