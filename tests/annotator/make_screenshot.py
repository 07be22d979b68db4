"""Take docs/annotator.png: the annotator in use (a side grasp on a jar placed by clicking, live badges,
the sim check's verdict, saved), rendered by Debian's headless Chromium. Not a test; run it by hand:

    .venv/bin/python tests/annotator/make_screenshot.py [docs/annotator.png]
"""

from __future__ import annotations

import shutil
import sys
import tempfile
import time
from pathlib import Path

from playwright.sync_api import sync_playwright

from mgdata.annotator.app import Annotator
from mgdata.annotator.catalog import Catalog
from mgdata.annotator.store import GraspStore
from mgdata.sim.assets import get_model
from tests.helpers.annotator import project

VIEWPORT = (1280, 940)


def main(out: Path) -> None:
    with tempfile.TemporaryDirectory() as tmp:
        app = Annotator(Catalog.build("jar", "jar"), GraspStore(Path(tmp)), port=8781, start="jar/hinged_03")
        try:
            with sync_playwright() as pw:
                browser = pw.chromium.launch(executable_path=shutil.which("chromium"),
                                             args=["--no-sandbox", "--disable-gpu"])
                page = browser.new_page(viewport={"width": VIEWPORT[0], "height": VIEWPORT[1]})
                page.goto("http://127.0.0.1:8781/")
                page.get_by_text("live check:").wait_for(timeout=30_000)
                page.get_by_label("approach", exact=True).click()
                page.get_by_role("option", name="side from -Y", exact=True).click()
                r = float(get_model("jar/hinged_03").geometry["outer_radius"])
                page.mouse.click(*project(app, (0.0, -r, 0.07), VIEWPORT))  # the jar's wall, facing -Y
                time.sleep(1.0)
                page.get_by_role("button", name="check in sim (C)").click()
                page.get_by_text("sim check: ", exact=False).last.wait_for(timeout=5_000)
                while "running" in app.sim_line.content:
                    time.sleep(0.2)
                page.keyboard.press("Enter")  # saved with the sim check's verdict
                for close in page.locator("button.mantine-Notification-closeButton").all():
                    close.click()
                time.sleep(1.5)
                page.screenshot(path=str(out))
                browser.close()
        finally:
            app.close()
    print(f"wrote {out}")


if __name__ == "__main__":
    main(Path(sys.argv[1]) if len(sys.argv) > 1 else Path("docs/annotator.png"))
