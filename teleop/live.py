"""Wiring of a live session (device, reader, operator view, terminal keys) and of a replay."""

from __future__ import annotations

import os
import select
import sys
import termios
import threading
import tty
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from mgdata.errors import DatasetError, RecipeError
from mgdata.teleop.bus import ServoBus
from mgdata.teleop.config import load_teleop_config
from mgdata.teleop.mapping import mapper_for
from mgdata.teleop.reader import LeaderReader
from mgdata.teleop.session import SessionJob, TeleopSession
from mgdata.teleop.stream import LeaderStream, stream_path

_FAMILY = {"gello": "dynamixel", "so101": "feetech"}


@dataclass(frozen=True)
class LiveOptions:
    """``mgdata teleop``'s options."""

    arm: str
    family: str
    task: int
    out: Path
    calibration: Path
    port: str | None = None
    keep_failed: bool = False
    episodes: int | None = None
    autostart: bool = False
    view: bool = True
    host: str = "127.0.0.1"
    http_port: int = 8080


def _keys(session: TeleopSession, stop: threading.Event) -> None:
    """Terminal hotkeys (one letter, no Enter) while stdin is a terminal."""
    from mgdata.teleop.view import _BUTTONS

    keymap = {key: cmd for _label, cmd, key in _BUTTONS}
    fd = sys.stdin.fileno()
    old = termios.tcgetattr(fd)
    try:
        tty.setcbreak(fd)
        while not stop.is_set():
            if select.select([fd], [], [], 0.1)[0]:
                ch = os.read(fd, 1).decode(errors="ignore").lower()
                if ch in keymap:
                    session.command(keymap[ch])
    finally:
        termios.tcsetattr(fd, termios.TCSADRAIN, old)


def run_live(opts: LiveOptions, say: Callable[[str], None]) -> None:
    """Open the leader, serve the view, run the session until quit."""
    if not opts.calibration.is_file():
        raise RecipeError(f"calibration file {opts.calibration} does not exist; run `mgdata teleop calibrate "
                          f"--arm {opts.arm} --port PORT --out {opts.calibration}` first")
    config = load_teleop_config()
    text = opts.calibration.read_text(encoding="utf-8")
    mapper = mapper_for(opts.arm, text, config, str(opts.calibration))
    cal = mapper.cal
    port = opts.port or cal.port
    bus = ServoBus(_FAMILY[opts.arm], port, mapper.motors, baudrate=config.leader.baudrate)
    if opts.arm == "so101":
        cal.apply(bus)
    reader = LeaderReader(bus, config.leader.reader_hz, config.leader.stale_s)
    stop_keys = threading.Event()
    view = None
    session = None
    try:
        session = TeleopSession(SessionJob(opts.arm, opts.family, opts.task, opts.out, opts.keep_failed,
                                           opts.episodes, opts.autostart), mapper, text, reader)
        if opts.view:
            from mgdata.teleop.view import OperatorView

            view = OperatorView(session, opts.host, opts.http_port, config.view)
            session.on_status = view.update
            say(f"operator page: {view.url} (its 3D view: viser on port {view.server.get_port()})")
        if sys.stdin.isatty():
            threading.Thread(target=_keys, args=(session, stop_keys), daemon=True).start()
            say("keys: r record, s stop, m mark done, d discard, t reset task, c clutch, g gripper, q quit")
        session.run()
        say(f"{sum(k for k, _ in session.stored)} kept, {sum(not k for k, _ in session.stored)} failed "
            f"episode(s) stored; leader read at {reader.rate_hz:.0f} Hz")
    finally:
        stop_keys.set()
        if view is not None:
            view.close()
        reader.close()
        bus.close()


def replay_episode(dataset: Path, episode: int, out: Path) -> str:
    """Re-simulate ``dataset``'s episode ``episode`` from its leader stream into ``out``."""
    path = stream_path(dataset, episode)
    if not path.is_file():
        raise DatasetError(f"{dataset}: episode {episode} has no leader stream ({path} is missing); only "
                           "teleoperated episodes can be replayed")
    stream = LeaderStream.load(path)
    mapper = mapper_for(stream.arm, stream.calibration, load_teleop_config(), str(path))
    session = TeleopSession(SessionJob(stream.arm, stream.family, stream.task_id, out, keep_failed=True),
                            mapper, stream.calibration)
    try:
        session.replay(stream)
    finally:
        session.close()
    kept, index = session.stored[-1]
    where = out if kept else str(out) + "_failed"
    return f"replayed into {where} as episode {index} ({'kept' if kept else 'failed'})"
