"""``mgdata scenarios build|list|show|verify``: the locked OOD scenarios (docs/scenarios.md)."""

from __future__ import annotations

import json
import time
from pathlib import Path
from typing import Annotated

import typer

from mgdata.console import plain_console
from mgdata.errors import OutputError, RecipeError

DEFAULT_OUT = Path("scenarios")


def register(app: typer.Typer) -> None:
    group = typer.Typer(
        help="Locked evaluation scenarios: each base task × {base, target, language, "
        "location, environment}, frozen on disk.",
        no_args_is_help=True,
    )
    app.add_typer(group, name="scenarios")

    @group.command("build")
    def build(
        out: Annotated[Path, typer.Option(help="Output folder.")] = DEFAULT_OUT,
        family: Annotated[
            list[str] | None, typer.Option(help="Family (repeatable); default: every family.")
        ] = None,
        tasks: Annotated[str, typer.Option(help="Base tasks: 'all' or e.g. '0-3,7'.")] = "all",
        condition: Annotated[
            list[str] | None,
            typer.Option(
                help="Condition (repeatable): base, target, language, location, environment; default: all."
            ),
        ] = None,
        workers: Annotated[int, typer.Option(help="Processes building tasks in parallel.")] = 1,
        recipe: Annotated[Path | None, typer.Option(
            help="Build from this family recipe file (e.g. a camera-free copy for state-only evaluation) "
                 "instead of the family's own; its family is the one built.")] = None,
    ) -> None:
        """Build (or resume) the locked scenarios of the chosen families into OUT, then rewrite
        OUT/manifest.json. Complete scenarios with the same inputs are kept; the bytes are deterministic.
        A camera-free recipe (cameras = []) builds state-only scenarios: nothing is rendered.

        Example: mgdata scenarios build --out scenarios --family jar --tasks 0-3
        """
        from mgdata.lock import output_lock
        from mgdata.options import parse_ids
        from mgdata.scenarios.store import build_family, write_manifest
        from mgdata.skeleton.skeleton import load_family_recipe
        from mgdata.tasks.recipe import family_recipes
        from mgdata.tasks.variants import CONDITIONS

        if workers < 1:
            raise RecipeError(f"--workers must be at least 1, got {workers}")
        if out.exists() and not out.is_dir():
            raise OutputError(f"--out {out}: exists and is not a folder")
        conditions = tuple(condition or CONDITIONS)
        bad = [c for c in conditions if c not in CONDITIONS]
        if bad:
            raise RecipeError(f"--condition {bad[0]!r}: expected one of {', '.join(CONDITIONS)}")
        if recipe is not None:
            recipes = [load_family_recipe(recipe)]
            others = [f for f in family or () if f != recipes[0].family]
            if others:
                raise RecipeError(f"--family {others[0]}: --recipe {recipe} is a {recipes[0].family} recipe")
        else:
            recipes = [load_family_recipe(f) for f in (family or family_recipes())]
        chosen = parse_ids(tasks)
        for recipe in recipes:
            ids = chosen or tuple(range(recipe.tasks.count))
            wrong = [k for k in ids if not 0 <= k < recipe.tasks.count]
            if wrong:
                raise RecipeError(
                    f"--tasks: {recipe.family} has tasks 0 … {recipe.tasks.count - 1}, not {wrong[0]}"
                )
        console = plain_console()
        start = time.perf_counter()
        n = 0
        with output_lock(out):  # one build per --out
            for recipe in recipes:
                ids = chosen or tuple(range(recipe.tasks.count))
                for entry in build_family(recipe, out, ids, conditions, workers):
                    n += 1
                    console.print(f"{entry['path']}  {entry['changes']}")
            write_manifest(out)
        console.print(f"{n} scenarios in {out} ({time.perf_counter() - start:.1f} s)")

    @group.command("list")
    def list_cmd(out: Annotated[Path, typer.Option(help="Scenario folder.")] = DEFAULT_OUT) -> None:
        """One line per scenario in OUT/manifest.json: family, task, condition, what changed."""
        from mgdata.scenarios.store import read_manifest

        console = plain_console()
        for e in read_manifest(out):
            console.print(f"{e['family']:<16} task {e['task_id']:>4}  {e['condition']:<12} {e['path']}")

    @group.command("show")
    def show(
        family: Annotated[str, typer.Argument(help="Family.")],
        task: Annotated[int, typer.Argument(help="Base task id.")],
        condition: Annotated[str, typer.Argument(help="Condition.")],
        out: Annotated[Path, typer.Option(help="Scenario folder.")] = DEFAULT_OUT,
    ) -> None:
        """A scenario's metadata: what changed, prompt forms, objects, goal, gate report, hashes (JSON)."""
        from mgdata.scenarios.store import read_scenario

        typer.echo(json.dumps(read_scenario(out, family, task, condition), indent=1, sort_keys=True))

    @group.command("render")
    def render(
        family: Annotated[str, typer.Argument(help="Family.")],
        task: Annotated[int, typer.Argument(help="Base task id.")],
        sheet: Annotated[Path, typer.Option(help="PNG to write.")],
        out: Annotated[Path, typer.Option(help="Scenario folder.")] = DEFAULT_OUT,
    ) -> None:
        """Draw one task's five conditions side by side (front and left cameras) from the stored snapshots.

        Example: mgdata scenarios render jar 0 --sheet jar_conditions.png
        """
        from mgdata.scenarios.store import write_sheet

        if sheet.is_dir() or not sheet.parent.is_dir():
            raise OutputError(f"--sheet {sheet}: expected a file path in an existing folder")
        plain_console().print(str(write_sheet(out, family, task, sheet)))

    @group.command("verify")
    def verify_cmd(
        out: Annotated[Path, typer.Option(help="Scenario folder.")] = DEFAULT_OUT,
        workers: Annotated[int, typer.Option(help="Processes checking scenarios in parallel.")] = 1,
    ) -> None:
        """Reload every scenario: model and state hashes, the state round trip and every camera's first
        observation. Exit status 1 if any differs."""
        from mgdata.scenarios.store import verify

        if workers < 1:
            raise RecipeError(f"--workers must be at least 1, got {workers}")
        console = plain_console()
        bad = n = 0
        for path, problem in verify(out, workers):
            n += 1
            if problem:
                bad += 1
                console.print(f"{path}: {problem}")
        console.print(f"{n - bad} of {n} scenarios verified")
        if bad:
            raise typer.Exit(1)
