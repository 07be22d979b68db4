"""``mgdata teleop``: record demonstrations with a leader arm; ``calibrate`` a leader; ``replay`` a stream.

Registered in ``mgdata/cli.py`` like every command module (``register(app)``). The SDKs and viser are the
``teleop`` extra and are imported only when a command runs.
"""

from __future__ import annotations

import sys
import threading
from pathlib import Path
from typing import Annotated

import typer

from mgdata.errors import RecipeError

teleop_app = typer.Typer(invoke_without_command=True, no_args_is_help=False, add_completion=False,
                         pretty_exceptions_enable=False,
                         help="Teleoperate the Panda with a GELLO or SO-101 leader arm into a LeRobot "
                         "dataset.")

ARM_HELP = "Leader arm: gello or so101."


def _check_arm(arm: str) -> None:
    if arm not in ("gello", "so101"):
        raise RecipeError(f"--arm {arm!r}: expected gello or so101")


def _say(text: str) -> None:
    typer.echo(text)


@teleop_app.callback()
def teleop(
    ctx: typer.Context,
    arm: Annotated[str | None, typer.Option(help=ARM_HELP)] = None,
    family: Annotated[str, typer.Option(help="Task family.")] = "jar",
    task: Annotated[int, typer.Option(help="Base task id.")] = 0,
    out: Annotated[Path | None, typer.Option(help="Dataset folder (created or appended to).")] = None,
    calibration: Annotated[Path | None, typer.Option(
        help="Calibration JSON of the device (default: teleop-<arm>.json).")] = None,
    port: Annotated[str | None, typer.Option(help="Serial port (default: the calibration file's).")] = None,
    keep_failed: Annotated[bool, typer.Option(help="Also store failed/unsafe episodes, in <out>_failed.")]
    = False,
    episodes: Annotated[int | None, typer.Option(help="Stop after this many finished episodes.")] = None,
    autostart: Annotated[bool, typer.Option(help="Start recording at once and after each episode.")] = False,
    view: Annotated[bool, typer.Option(help="Serve the operator view in the browser.")] = True,
    host: Annotated[str, typer.Option(help="Operator view address (127.0.0.1: this machine only).")]
    = "127.0.0.1",
    http_port: Annotated[int, typer.Option(
        help="Operator page port (viser's 3D view: the next free port above it).")] = 8080,
) -> None:
    """Record demonstrations with a leader arm: the same recorder, monitor and gate as generation.

    Example: mgdata teleop --arm gello --family jar --task 0 --out datasets/jar_teleop
    """
    if ctx.invoked_subcommand is not None:
        return
    if arm is None or out is None:
        raise RecipeError("mgdata teleop needs --arm (gello or so101) and --out DATASET "
                          "(or a subcommand: calibrate, replay)")
    _check_arm(arm)
    from mgdata.teleop.live import LiveOptions, run_live

    run_live(LiveOptions(arm=arm, family=family, task=task, out=out,
                         calibration=calibration or Path(f"teleop-{arm}.json"), port=port,
                         keep_failed=keep_failed, episodes=episodes, autostart=autostart, view=view,
                         host=host,
                         http_port=http_port), _say)


@teleop_app.command()
def calibrate(
    arm: Annotated[str, typer.Option(help=ARM_HELP)],
    port: Annotated[str, typer.Option(help="Serial port of the leader, e.g. /dev/ttyUSB0.")],
    out: Annotated[Path | None, typer.Option(help="Calibration file (default: teleop-<arm>.json).")] = None,
    pose: Annotated[str | None, typer.Option(
        help="GELLO: the known Panda pose, 7 comma-separated angles in rad (default: the Panda's home).")]
    = None,
    no_trigger: Annotated[bool, typer.Option(help="GELLO: the device has no gripper-trigger servo.")] = False,
    scale: Annotated[float, typer.Option(help="SO-101: Panda metres per leader metre.")] = 1.5,
) -> None:
    """Calibrate a leader arm step by step and write its calibration JSON.

    Example: mgdata teleop calibrate --arm gello --port /dev/ttyUSB0 --out teleop-gello.json
    """
    _check_arm(arm)
    from mgdata.teleop.calibrate_cli import calibrate_gello_interactive, calibrate_so101_interactive
    from mgdata.teleop.config import load_teleop_config

    baud = load_teleop_config().leader.baudrate
    path = out or Path(f"teleop-{arm}.json")
    if arm == "gello":
        from mgdata.sim.robot import HOME_Q

        q = HOME_Q if pose is None else _floats(pose, "--pose", 7)
        cal = calibrate_gello_interactive(port, baud, q, not no_trigger, _prompt, _say)
    else:
        if not scale > 0:
            raise RecipeError(f"--scale {scale}: must be > 0")
        cal = calibrate_so101_interactive(port, baud, scale, _prompt, _say)
    cal.save(path)
    _say(f"wrote {path}")


@teleop_app.command()
def replay(
    dataset: Annotated[Path, typer.Argument(help="Dataset holding the teleoperated episode.")],
    episode: Annotated[int, typer.Option(help="Episode index in that dataset.")],
    out: Annotated[Path, typer.Option(help="Dataset to re-simulate the episode into.")],
) -> None:
    """Re-simulate a teleoperated episode from its raw leader stream (no device needed).

    Example: mgdata teleop replay datasets/jar_teleop --episode 0 --out /tmp/jar_replayed
    """
    from mgdata.teleop.live import replay_episode

    _say(replay_episode(dataset, episode, out))


def _floats(text: str, option: str, n: int) -> list[float]:
    try:
        values = [float(v) for v in text.split(",")]
    except ValueError:
        values = []
    if len(values) != n:
        raise RecipeError(f"{option} {text!r}: expected {n} comma-separated numbers")
    return values


def _prompt(text: str, until_enter: threading.Event | None = None) -> None:
    """Show ``text`` and wait for Enter (setting ``until_enter`` when it comes)."""
    typer.echo(text + " [Enter]", nl=False)
    sys.stdin.readline()
    if until_enter is not None:
        until_enter.set()


def register(app: typer.Typer) -> None:
    app.add_typer(teleop_app, name="teleop")
