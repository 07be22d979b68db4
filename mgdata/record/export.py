"""``mgdata export``: write a loader view of a dataset (the formats of :mod:`mgdata.record.views`; the v2.1
layout by :mod:`mgdata.record.export_v21`) as a new dataset.

Example::

    export_dataset(Path("datasets/jar"), Path("datasets/jar_smolvla"), "smolvla", overview="front")
"""

from __future__ import annotations

import os
import shutil
from dataclasses import replace
from pathlib import Path

from mgdata.errors import DatasetError
from mgdata.record.export_v21 import write_v21
from mgdata.record.reader import DatasetReader
from mgdata.record.views import view_for, write_v30_view


def export_dataset(root: Path, out: Path, fmt: str, *, overview: str | None = None, wrist: str | None = None,
                   cameras: tuple[str, ...] | None = None, add_environment_state: bool = False) -> Path:
    """Write the ``fmt`` view of the dataset at ``root`` into ``out`` (which must not exist); returns ``out``.
    ``add_environment_state`` adds ``observation.environment_state`` to a v3.0 view (``smolvla``).

    The export is built in ``<out>.partial`` and renamed into place when complete.
    """
    out = Path(out)
    if out.exists():
        raise DatasetError(f"{out}: already exists; choose a new output folder")
    reader = DatasetReader(Path(root))
    if not reader.num_episodes:
        raise DatasetError(f"{root}: the dataset has no episodes to export")
    view = view_for(fmt, reader.schema, overview=overview, wrist=wrist, cameras=cameras)
    if add_environment_state:
        if view.version != "v3.0":
            raise DatasetError(f"--add environment_state needs a LeRobot v3.0 view (smolvla, state), "
                               f"not {fmt}")
        view = replace(view, environment_state=True)
    partial = out.with_name(out.name + ".partial")
    shutil.rmtree(partial, ignore_errors=True)
    partial.mkdir(parents=True)
    if view.version == "v3.0":
        write_v30_view(reader, partial, view)
    else:
        write_v21(reader, partial, view)
    os.replace(partial, out)
    return out
