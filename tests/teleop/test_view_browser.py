"""The operator view in a real headless Chromium (Debian's ``chromium``, driven by playwright): the hotkeys
reach the live session (start/stop recording, discard, mark done, reset the task, quit) and the monitor panel
in the page follows the session's state."""

from __future__ import annotations

import shutil
import socket
import threading
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest

from mgdata.sim.robot import HOME_Q
from teleop.bus import ServoBus
from teleop.config import load_teleop_config
from teleop.emulator.arms import ManualClock
from teleop.emulator.script import JointScript
from teleop.gello import GelloCalibration
from teleop.mapping import mapper_for
from teleop.reader import LeaderReader
from teleop.session import SessionJob, TeleopSession
from tests.teleop.conftest import GELLO_BUILD

pytest.importorskip("playwright", reason="playwright is part of the dev setup")


def _chromium() -> str:
    path = shutil.which("chromium") or shutil.which("chromium-browser")
    if path is None:
        pytest.fail("Debian's chromium is not installed: run scripts/setup.sh --dev")
    return path


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _wait(predicate: Callable[[], object], what: str, timeout: float = 240.0) -> None:
    """Poll ``predicate``; the generous timeout is for a saturated CI host, where the browser's DOM can lag
    the session by tens of seconds (docs/teleop.md, Benchmark)."""
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        if predicate():
            return
        time.sleep(0.05)
    pytest.fail(f"timed out after {timeout} s waiting for {what}")


def test_browser_hotkeys_drive_the_session(gello_cal: GelloCalibration, tmp_path: Path) -> None:
    from playwright.sync_api import sync_playwright

    from teleop.view import OperatorView

    cal_file = tmp_path / "gello.json"
    gello_cal.save(cal_file)
    text = cal_file.read_text()
    config = load_teleop_config()
    scripts = [JointScript.constant(a) for a in HOME_Q] + [JointScript.constant(0.0)]  # the leader rests
    out = tmp_path / "jar_teleop"
    with GELLO_BUILD.bus(scripts, ManualClock()) as emu:
        mapper = mapper_for("gello", text, config)
        bus = ServoBus("dynamixel", emu.port, mapper.motors)
        reader = LeaderReader(bus, config.leader.reader_hz, stale_s=5.0)
        box: dict[str, object] = {}
        ready = threading.Event()

        def drive() -> None:  # the session and its GL context live in one thread, as in `mgdata teleop`
            try:
                session = TeleopSession(SessionJob("gello", "jar", 0, out, keep_failed=True), mapper, text,
                                        reader)
                view = OperatorView(session, "127.0.0.1", _free_port())
                session.on_status = view.update
                box["session"], box["view"] = session, view
                ready.set()
                session.run()
            except BaseException as err:  # surfaced in the test thread
                box["error"] = err
                ready.set()

        worker = threading.Thread(target=drive, daemon=True)
        worker.start()
        try:
            ready.wait(240)
            assert "error" not in box, box.get("error")
            session: TeleopSession = box["session"]  # type: ignore[assignment]
            view: OperatorView = box["view"]  # type: ignore[assignment]
            with sync_playwright() as pw:
                browser = pw.chromium.launch(executable_path=_chromium(), headless=True,
                                             args=["--no-sandbox", "--disable-gpu", "--no-first-run"])
                page = browser.new_page(viewport={"width": 1280, "height": 800})
                page.goto(view.url)
                page.wait_for_selector("#mg-monitor", timeout=240_000)
                page.locator("body").click(position={"x": 5, "y": 5})  # focus the page, not a widget

                def mode() -> str:
                    return page.locator("#mg-monitor b").first.inner_text()

                def press(key: str) -> None:
                    page.keyboard.press(key)

                press("r")  # start recording
                _wait(lambda: session.status.recording and mode() == "recording", "r: recording")
                press("d")  # discard it
                _wait(lambda: not session.status.recording and "dropped (discard)" in session.status.message,
                      "d: discarded")
                _wait(lambda: mode() == "idle", "the page to show idle")
                assert not np.array_equal(session.scene.snapshot(), session.scene._initial)  # the arm moved
                press("t")  # reset the task: back to its settled initial state
                _wait(lambda: np.array_equal(session.scene.snapshot(), session.scene._initial), "t: reset")
                press("r")
                _wait(lambda: session.status.recording, "r again")
                press("t")  # reset while recording: the episode is dropped too
                _wait(lambda: "dropped (reset)" in session.status.message, "t: episode dropped")
                press("r")
                _wait(lambda: session.status.recording and session.status.step > 3, "r and a few steps")
                press("m")  # mark done: the arm holds still for the gate, then the episode ends
                _wait(lambda: session.status.settling and mode() == "settling", "m: settling")
                _wait(lambda: session.status.failed == 1, "the marked episode to end")
                press("r")
                _wait(lambda: session.status.recording, "r for the last episode")
                press("s")  # stop recording: stored (failed: the jar is not in the goal)
                _wait(lambda: session.status.failed == 2 and not session.status.recording, "s: stopped")
                press("q")  # quit
                worker.join(240)
                assert not worker.is_alive(), "q did not end the session"
                browser.close()
            view.close()
        finally:
            if worker.is_alive() and "session" in box:
                box["session"].command("quit")  # type: ignore[attr-defined]
                worker.join(240)
            reader.close()
            bus.close()
    assert "error" not in box, box.get("error")
    assert session.stored == [(False, 0), (False, 1)]
