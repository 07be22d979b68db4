"""The ``mgdata`` command line.

Each command lives next to the code it drives (``mgdata/<area>/commands.py``) and is registered below, so
this file stays a table of contents. User errors (:class:`mgdata.errors.MgdataError`) and operating-system
errors (a path that cannot be read or written, a full disk) print one literal ``error:`` line and exit with
status 2, and so do click's usage errors (a missing option, an extra argument: no framed panel); anything
else is a bug and keeps its traceback.
"""

from __future__ import annotations

import os
import sys
from pathlib import Path

import typer

from mgdata import __version__
from mgdata.console import print_error
from mgdata.errors import MgdataError
from mgdata.paths import ROOT_ENV

try:  # typer >= 0.29 carries its own copy of click, whose exceptions derive from this
    from typer import TyperException as UsageError
except ImportError:  # older typer: click's
    from click import ClickException as UsageError  # type: ignore[assignment]

app = typer.Typer(
    name="mgdata",
    help=(
        "Generate safety-annotated robot-manipulation demonstrations in MuJoCo and export them as LeRobot "
        "datasets.\n\nExample: mgdata generate --family jar --n 40\n\n"
        "Exit status: 0 done; 1 the answer is no (validate found problems, generate stopped short of --n); "
        "2 bad input or unwritable output (one 'error:' line, nothing written is lost)."
    ),
    no_args_is_help=True,
    add_completion=False,
    pretty_exceptions_enable=False,
)


def _version(value: bool) -> None:
    if value:
        typer.echo(f"mgdata {__version__}")
        raise typer.Exit()


@app.callback()
def _root(
    version: bool = typer.Option(False, "--version", help="Print the version and exit.", callback=_version,
                                 is_eager=True),
    root: Path | None = typer.Option(None, "--root", help="Folder holding recipes/, grasps/ (and skeletons/, "  # noqa: B008
                                     "datasets/) to use instead of the installed ones; same as MGDATA_ROOT."),
) -> None:
    """mgdata: safety-annotated manipulation demonstrations."""
    if root is not None:
        os.environ[ROOT_ENV] = str(root)  # the environment: worker processes see it too


# --- command registry: one line per command module -------------------------------------------------------
# (each module exposes ``register(app)``; this top layer composes the layers below it, which never import it)
def _register_all() -> None:
    from mgdata.annotator import commands as annotator
    from mgdata.evaluate import commands as evaluate
    from mgdata.evaluate import metrics_commands
    from mgdata.generate import commands as generate
    from mgdata.grasps import commands as grasps
    from mgdata.ltl import commands as ltl
    from mgdata.objects import commands as objects
    from mgdata.record import commands as record
    from mgdata.scenarios import commands as scenarios
    from mgdata.teleop import commands as teleop

    for module in (grasps, objects, generate, scenarios, evaluate, record, ltl, metrics_commands, annotator,
                   teleop):
        module.register(app)


OPTIONAL_VALUES = {"--ray": "local"}
"""Options whose value may be left out (``--ray`` or ``--ray ADDRESS``), with the value that stands for it;
typer has no optional-value options, so :func:`main` fills it in."""


def fill_optional_values(argv: list[str]) -> list[str]:
    """``argv`` with the stand-in value after each :data:`OPTIONAL_VALUES` option given without one."""
    out: list[str] = []
    for k, arg in enumerate(argv):
        out.append(arg)
        nxt = argv[k + 1] if k + 1 < len(argv) else None
        if arg in OPTIONAL_VALUES and (nxt is None or nxt.startswith("-")):
            out.append(OPTIONAL_VALUES[arg])
    return out


def usage_error_line(err: UsageError) -> str:
    """A click usage error as one line: the command it concerns, then click's message with its line breaks
    folded (``mgdata merge: Missing option '--out'.``)."""
    ctx = getattr(err, "ctx", None)
    where = f"{ctx.command_path}: " if ctx is not None else ""
    return where + " ".join(err.format_message().split())


def main() -> None:
    """Console-script entry point: run the app, turning user errors into one line and exit status 2."""
    _register_all()
    try:
        # not standalone: click's usage errors come here as exceptions instead of typer's framed panels
        code = app(args=fill_optional_values(sys.argv[1:]), prog_name="mgdata", standalone_mode=False)
    except UsageError as err:  # unknown option, missing or extra argument, a value of the wrong type …
        if type(err).__name__ == "NoArgsIsHelpError":  # `mgdata` or `mgdata scenarios` alone: the help
            typer.echo(err.ctx.get_help())  # type: ignore[attr-defined]
        else:
            print_error(usage_error_line(err))
        sys.exit(2)
    except typer.Abort:  # end of input at a prompt
        print_error("aborted")
        sys.exit(1)
    except MgdataError as err:
        print_error(err)
        sys.exit(2)
    except OSError as err:  # the environment: a path that cannot be read or written, a full disk …
        where = f"{err.filename}: " if err.filename else ""
        print_error(f"{where}{err.strerror or err}")
        sys.exit(2)
    sys.exit(code if isinstance(code, int) else 0)
