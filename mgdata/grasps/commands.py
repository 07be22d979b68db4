"""``mgdata grasps list | generate | validate``: inspect, create and check the grasp database.

* ``generate MODEL…``: candidate grasps from each model's geometry (``category/model`` or glob patterns such
  as ``'jar/*'``); replaces the model's *generated* grasps (a candidate whose id and pose are unchanged keeps
  its validation result; ``validate --all`` re-checks) and keeps annotated ones; rewrites only the files of
  the categories named.
* ``validate [MODEL…]``: run the in-simulation check on unvalidated grasps (``--all``: every grasp) and store
  each result; the file is rewritten atomically after every model, so an interrupted run keeps its progress.
* ``list [MODEL…]``: grasp counts per model and validation status.
* ``report [CATEGORY…]``: per category (default: all but particle sets), objects covered (at least one
  valid grasp) of the models in the asset library, and grasps valid / checked / total.
"""

from __future__ import annotations

import contextlib
import fnmatch
from collections.abc import Iterator
from pathlib import Path
from typing import Annotated

import numpy as np
import typer
from rich.table import Table

from mgdata.console import plain_console
from mgdata.errors import GraspDBError
from mgdata.grasps.db import Grasp, GraspDB
from mgdata.lock import output_lock
from mgdata.paths import grasps_dir

WELL_COVERED = 3
"""Valid grasps an object needs to count as well covered in ``grasps report`` (a family draws among them)."""

Dir = Annotated[Path | None, typer.Option("--dir", help="Grasp DB folder (default: the project's grasps/).")]
Models = Annotated[list[str] | None, typer.Argument(help="Models or globs, e.g. 'jar/*' (default: all).")]
All = Annotated[bool, typer.Option("--all", help="Re-check grasps that already have a result.")]
GraspIds = Annotated[list[str] | None, typer.Option(
    "--grasp", help="Only grasps whose id matches this glob, e.g. 'side_*_r1' (repeatable; default: all).")]


def _db_dir(directory: Path | None, create: bool = False) -> Path:
    """The grasp DB folder (``--dir`` or the project's), which must exist unless ``create``."""
    root = directory or grasps_dir()
    if root.exists() and not root.is_dir():
        raise GraspDBError(f"--dir {root}: is a file, not a folder")
    if not root.exists():
        if not create:
            raise GraspDBError(f"--dir {root}: no such grasp database folder")
        root.mkdir(parents=True)
    return root


def _match(patterns: list[str], names: list[str], what: str) -> list[str]:
    found = sorted({n for n in names for p in patterns if fnmatch.fnmatchcase(n, p)})
    if not found:
        raise GraspDBError(f"{' '.join(patterns)!r} matches no {what}")
    return found


POSE_TOLERANCE = 1e-6
"""m and quaternion units: a regenerated candidate this close to the stored one is the same grasp (the
file stores 6 and 8 decimals, and the last can flip between runs of the generator's arithmetic)."""


def _keep_result(g: Grasp, checked: dict[tuple[str, str], Grasp]) -> Grasp:
    """The stored generated grasp of ``g``'s id and frame (its pose and validation result) if its pose is
    ``g``'s within :data:`POSE_TOLERANCE`, else ``g``."""
    old = checked.get((g.id, g.frame))
    if old is not None and max(np.abs(np.subtract(old.pos, g.pos)).max(),
                               np.abs(np.subtract(old.quat, g.quat)).max()) <= POSE_TOLERANCE:
        return old
    return g


@contextlib.contextmanager
def _category_locks(root: Path, keys: list[str]) -> Iterator[None]:
    """Hold the one-writer lock (:func:`mgdata.lock.output_lock`) of each category file ``keys`` touch:
    runs on different categories go side by side; a second one on the same file is refused."""
    with contextlib.ExitStack() as stack:
        for category in sorted({k.split("/", 1)[0] for k in keys}):
            stack.enter_context(output_lock(root / f"{category}.json", "grasp file"))
        yield


def register(app: typer.Typer) -> None:
    grasps = typer.Typer(help="Inspect, generate and validate the grasp database (grasps/*.json).\n\n"
                         "Example: mgdata grasps generate 'jar/*' && mgdata grasps validate 'jar/*'",
                         no_args_is_help=True)
    app.add_typer(grasps, name="grasps")

    @grasps.command("list")
    def list_(models: Models = None, directory: Dir = None) -> None:
        """Grasp counts per model: total, valid, invalid, unvalidated.

        Example: mgdata grasps list 'jar/*'
        """
        db = GraspDB.load_dir(_db_dir(directory))
        keys = _match(models, list(db.keys), "model in the grasp DB") if models else list(db.keys)
        table = Table("model", "grasps", "valid", "invalid", "unvalidated", "sources")
        for key in keys:
            gs = db.grasps(key)
            counts = [sum(g.status == s for g in gs) for s in ("valid", "invalid", "unvalidated")]
            table.add_row(key, str(len(gs)), *map(str, counts), ", ".join(sorted({g.source for g in gs})))
        plain_console().print(table)

    @grasps.command("report")
    def report(categories: Annotated[list[str] | None, typer.Argument(
                   help="Categories (default: every category of the asset library but particle sets, "
                        "i.e. dust and liquid).")] = None,
               directory: Dir = None) -> None:
        """Coverage per category: objects with a valid grasp / models in the library; objects with at least
        three valid grasps; grasps valid / checked / total.

        Example: mgdata grasps report cup bowl cabinet
        """
        from mgdata.sim.assets import categories as library_categories
        from mgdata.sim.assets import get_model, model_names

        db = GraspDB.load_dir(_db_dir(directory))
        known = library_categories()
        wanted = categories or [c for c in known if get_model(model_names(c)[0]).particles is None]
        unknown = [c for c in wanted if c not in known]
        if unknown:
            raise GraspDBError(f"unknown object category {unknown[0]!r}; known: {', '.join(known)}")
        table = Table("category", "objects covered", f"with ≥ {WELL_COVERED} valid", "grasps valid",
                      "checked", "total")
        sums = [0, 0, 0, 0, 0, 0]
        for category in wanted:
            names = model_names(category)
            valid = [sum(g.status == "valid" for g in db.objects.get(n, ())) for n in names]
            grasps = [g for n in names for g in db.objects.get(n, ())]
            row = [sum(v > 0 for v in valid), len(names), sum(v >= WELL_COVERED for v in valid), sum(valid),
                   sum(g.status != "unvalidated" for g in grasps), len(grasps)]
            sums = [a + b for a, b in zip(sums, row, strict=True)]
            table.add_row(category, f"{row[0]} / {row[1]}", *map(str, row[2:]))
        table.add_row("all", f"{sums[0]} / {sums[1]}", *map(str, sums[2:]))
        plain_console().print(table)

    @grasps.command("generate")
    def generate(models: Annotated[list[str], typer.Argument(help="Models or glob patterns, e.g. 'jar/*'.")],
                 directory: Dir = None) -> None:
        """Generate candidate grasps from geometry (replaces generated grasps, keeping the validation result
        of any whose pose is unchanged; keeps annotated ones).

        Example: mgdata grasps generate 'jar/hinged_0*'
        """
        from mgdata.sim.assets import model_names

        root = _db_dir(directory, create=True)
        generate_grasps(root, _match(models, model_names(), "object model"))

    @grasps.command("validate")
    def validate(models: Models = None, all_: All = False, grasp_ids: GraspIds = None,
                 directory: Dir = None) -> None:
        """Check grasps in simulation (reach, close, then lift, or pull a drawer open) and record
        valid/invalid with the measurement. Only the files of the models checked are rewritten.

        Example: mgdata grasps validate 'cup/*' --grasp 'side_*_r1'
        """
        root = _db_dir(directory)
        db = GraspDB.load_dir(root)
        keys = _match(models, list(db.keys), "model in the grasp DB") if models else list(db.keys)
        validate_grasps(root, keys, all_=all_, grasp_ids=grasp_ids)


def generate_grasps(root: Path, keys: list[str]) -> GraspDB:
    """``grasps generate`` of the models ``keys`` into the grasp DB folder ``root`` (printing a line per
    model and file); returns the DB as written."""
    from mgdata.grasps.candidates import candidates
    from mgdata.grasps.config import load_grasp_config
    from mgdata.sim.assets import get_model

    cand_cfg = load_grasp_config().candidates
    with _category_locks(root, keys):
        db = GraspDB.load_dir(root)  # read under the locks: nobody else writes these files now
        for key in keys:
            old = db.objects.get(key, ())
            kept = [g for g in old if g.source != "generated"]
            ids = {g.id for g in kept}
            checked = {(g.id, g.frame): g for g in old if g.source == "generated"}
            new = [_keep_result(g, checked) for g in candidates(get_model(key), cand_cfg)
                   if g.id not in ids]
            if not kept and not new:  # its generated grasps of an earlier generator go too
                db = db.without_object(key)
                typer.echo(f"{key}: no candidate grasps (too wide for the hand, or no usable geometry)")
                continue
            db = db.with_object(key, kept + new)
            typer.echo(f"{key}: {len(new)} generated, {len(kept)} annotated kept")
        for path in db.write_dir(root, categories={k.split("/", 1)[0] for k in keys}):
            typer.echo(f"wrote {path}")
    return db


def validate_grasps(root: Path, keys: list[str], *, all_: bool = False,
                    grasp_ids: list[str] | None = None) -> tuple[int, int]:
    """``grasps validate`` of the models ``keys`` (each in the DB at ``root``), printing a line per grasp
    checked; returns (valid, total) over those models."""
    from mgdata.grasps.check import check_grasp
    from mgdata.grasps.config import load_grasp_config

    settings = load_grasp_config()
    with _category_locks(root, keys):
        db = GraspDB.load_dir(root)  # again, under the locks (another run may have written them)
        for key in keys:
            updated: list[Grasp] = []
            for g in db.grasps(key):
                chosen = not grasp_ids or any(fnmatch.fnmatchcase(g.id, p) for p in grasp_ids)
                if chosen and (g.status == "unvalidated" or all_):
                    status, detail = check_grasp(key, g, settings.check)
                    g = g.with_status(status, detail)
                    typer.echo(f"{key} {g.id}: {status} ({detail})")
                updated.append(g)
            db = db.with_object(key, updated)
            db.write_dir(root, categories=[key.split("/", 1)[0]])
    valid = sum(g.status == "valid" for k in keys for g in db.grasps(k))
    total = sum(len(db.grasps(k)) for k in keys)
    typer.echo(f"{valid} of {total} grasps valid over {len(keys)} model(s)")
    return valid, total
