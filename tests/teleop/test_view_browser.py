"""The operator view in a real headless Chromium (Debian's ``chromium``, driven by playwright): the hotkeys
reach the live session (start/stop recording, discard, mark done, reset the task, quit) and the operator
page's monitor follows the session's mode."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from mgdata.teleop.gello import GelloCalibration
from tests.teleop.browser import open_operator_page, served_session, wait

pytest.importorskip("playwright", reason="playwright is part of the dev setup")


def test_browser_hotkeys_drive_the_session(gello_cal: GelloCalibration, tmp_path: Path) -> None:
    from playwright.sync_api import sync_playwright

    with served_session(gello_cal, tmp_path) as served:
        session = served.session
        with sync_playwright() as pw:
            browser, page = open_operator_page(pw, served.view.url)
            page.locator("body").click(position={"x": 5, "y": 5})  # focus the page, not a widget

            def mode() -> str:
                return page.locator("#mg-monitor b").first.inner_text()

            def press(key: str) -> None:
                page.keyboard.press(key)

            press("r")  # start recording
            wait(lambda: session.status.recording and mode() == "recording", "r: recording")
            press("d")  # discard it
            wait(lambda: not session.status.recording and "dropped (discard)" in session.status.message,
                 "d: discarded")
            wait(lambda: mode() == "idle", "the page to show idle")
            assert not np.array_equal(session.scene.snapshot(), session.scene._initial)  # the arm moved
            press("t")  # reset the task: back to its settled initial state
            wait(lambda: np.array_equal(session.scene.snapshot(), session.scene._initial), "t: reset")
            press("r")
            wait(lambda: session.status.recording, "r again")
            press("t")  # reset while recording: the episode is dropped too
            wait(lambda: "dropped (reset)" in session.status.message, "t: episode dropped")
            press("r")
            wait(lambda: session.status.recording and session.status.step > 3, "r and a few steps")
            press("m")  # mark done: the arm holds still for the gate, then the episode ends
            wait(lambda: session.status.settling and mode() == "settling", "m: settling")
            wait(lambda: session.status.failed == 1, "the marked episode to end")
            press("r")
            wait(lambda: session.status.recording, "r for the last episode")
            press("s")  # stop recording: stored (failed: the jar is not in the goal)
            wait(lambda: session.status.failed == 2 and not session.status.recording, "s: stopped")
            press("q")  # quit
            served.worker.join(240)
            assert not served.worker.is_alive(), "q did not end the session"
            browser.close()
    assert session.stored == [(False, 0), (False, 1)]
