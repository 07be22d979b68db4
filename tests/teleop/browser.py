"""A live session on an emulated GELLO at rest, served to a real headless Chromium (Debian's ``chromium``,
driven by playwright), for the operator-view tests."""

from __future__ import annotations

import contextlib
import shutil
import socket
import threading
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import pytest

from mgdata.sim.robot import HOME_Q
from mgdata.teleop.bus import ServoBus
from mgdata.teleop.config import load_teleop_config
from mgdata.teleop.emulator.arms import ManualClock
from mgdata.teleop.emulator.script import JointScript
from mgdata.teleop.gello import GelloCalibration
from mgdata.teleop.mapping import mapper_for
from mgdata.teleop.reader import LeaderReader
from mgdata.teleop.session import SessionJob, TeleopSession
from mgdata.teleop.view import OperatorView
from tests.helpers.teleop import GELLO_BUILD


def chromium() -> str:
    path = shutil.which("chromium") or shutil.which("chromium-browser")
    if path is None:
        pytest.fail("Debian's chromium is not installed: run scripts/setup.sh --dev")
    return path


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def wait(predicate: Callable[[], object], what: str, timeout: float = 240.0) -> None:
    """Poll ``predicate``; the generous timeout is for a saturated CI host (docs/teleop.md, Benchmark)."""
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        if predicate():
            return
        time.sleep(0.05)
    pytest.fail(f"timed out after {timeout} s waiting for {what}")


@dataclass
class Served:
    session: TeleopSession
    view: OperatorView
    worker: threading.Thread
    errors: list[BaseException]


@contextlib.contextmanager
def served_session(cal: GelloCalibration, tmp_path: Path,
                   on_step: Callable[[TeleopSession, int], None] | None = None) -> Iterator[Served]:
    """A jar task 0 session (``keep_failed``) whose leader rests at the Panda's home, with its operator view,
    running in its own thread (the session and its GL context live in one thread, as in ``mgdata teleop``);
    ``on_step(session, step)`` runs in that thread after every control step. Quits it on exit."""
    cal_file = tmp_path / "gello.json"
    cal.save(cal_file)
    text = cal_file.read_text()
    config = load_teleop_config()
    scripts = [JointScript.constant(a) for a in HOME_Q] + [JointScript.constant(0.0)]
    with GELLO_BUILD.bus(scripts, ManualClock()) as emu:
        mapper = mapper_for("gello", text, config)
        bus = ServoBus("dynamixel", emu.port, mapper.motors)
        reader = LeaderReader(bus, config.leader.reader_hz, stale_s=5.0)
        box: dict[str, object] = {}
        errors: list[BaseException] = []
        ready = threading.Event()

        def drive() -> None:
            try:
                session: TeleopSession | None = None

                def step(k: int) -> None:
                    if on_step is not None and session is not None:
                        on_step(session, k)

                job = SessionJob("gello", "jar", 0, tmp_path / "jar_teleop", keep_failed=True)
                session = TeleopSession(job, mapper, text, reader, on_step=step)
                view = OperatorView(session, "127.0.0.1", free_port(), scene_port=free_port())
                session.on_status = view.update
                box["session"], box["view"] = session, view
                ready.set()
                session.run()
            except BaseException as err:  # surfaced in the test thread
                errors.append(err)
                ready.set()

        worker = threading.Thread(target=drive, daemon=True)
        worker.start()
        try:
            ready.wait(240)
            assert not errors, errors
            served = Served(box["session"], box["view"], worker, errors)  # type: ignore[arg-type]
            yield served
        finally:
            if worker.is_alive() and "session" in box:
                box["session"].command("quit")  # type: ignore[attr-defined]
                worker.join(240)
            if "view" in box:
                box["view"].close()  # type: ignore[attr-defined]
            reader.close()
            bus.close()
    assert not errors, errors


def open_operator_page(pw: Any, url: str) -> tuple[Any, Any]:
    """(browser, page): headless Chromium on the operator page at ``url``, once its monitor stream is open."""
    browser = pw.chromium.launch(executable_path=chromium(), headless=True,
                                 args=["--no-sandbox", "--disable-gpu", "--no-first-run"])
    page = browser.new_page(viewport={"width": 1280, "height": 800})
    page.goto(url)
    page.wait_for_selector("#mg-monitor[data-step='0']", timeout=240_000)  # the stream is open
    return browser, page
