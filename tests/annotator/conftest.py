"""Fixtures of the annotator's browser tests: one app server (in this process, so the test reads its
server-side event times) and one real headless Chromium (Debian's ``chromium``, driven by playwright)."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import pytest

from mgdata.annotator.app import Annotator
from mgdata.annotator.catalog import Catalog
from mgdata.annotator.store import GraspStore
from tests.helpers.annotator import START, chromium_path, free_port


@pytest.fixture(scope="module")
def grasp_dir(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return tmp_path_factory.mktemp("grasps")


@pytest.fixture(scope="module")
def app(grasp_dir: Path) -> Iterator[Annotator]:
    session = Annotator(Catalog.build("jar", "jar"), GraspStore(grasp_dir), port=free_port(), start=START)
    yield session
    session.close()


@pytest.fixture(scope="module")
def browser() -> Iterator[object]:
    from playwright.sync_api import sync_playwright

    with sync_playwright() as pw:
        b = pw.chromium.launch(executable_path=chromium_path(), headless=True,
                               args=["--no-sandbox", "--disable-gpu", "--no-first-run"])
        yield b
        b.close()


@pytest.fixture(scope="module")
def page(app: Annotator, browser):
    page = browser.new_page(viewport={"width": 1280, "height": 800})
    page.goto(f"http://127.0.0.1:{app.server.get_port()}/")
    page.get_by_text("live check:").wait_for(timeout=30_000)
    yield page
    page.close()
