"""The annotator in a real headless Chromium: clicks, sliders, gizmo drags, hotkeys and reloads reach the
server and change what the user relies on (the draft pose, the verdict badges, the grasp file).

Physical facts are checked from outside the code under test: the clicked contact point against the jar's
own parameters, the saved pose against the grasp file read back with the DB loader, latencies with the
server's monotonic event times (the latency bound excludes time the check's thread waited for a CPU on a
shared machine: ``wall - thread CPU`` of that check; both figures are printed).
"""

from __future__ import annotations

import time

import numpy as np

from mgdata.annotator.app import Annotator
from mgdata.annotator.catalog import Catalog
from mgdata.annotator.store import GraspStore
from mgdata.grasps.db import GraspDB
from mgdata.sim.assets import get_model
from tests.helpers.annotator import START, free_port, project, wait_for

VIEWPORT = (1280, 800)


def _jar_wall(app: Annotator) -> tuple[float, float]:
    """Pixel of the jar's wall half-way up, on the side facing the camera (+X, −Y)."""
    geo = get_model(START).geometry
    r = float(geo["outer_radius"])
    return project(app, (r * np.cos(-np.pi / 4), r * np.sin(-np.pi / 4), 0.45 * geo["height"]), VIEWPORT)


def _events(app: Annotator, kind: str, after: float) -> list[tuple[str, float, int, str]]:
    return [e for e in list(app.events) if e[0] == kind and e[1] > after]


def _slider_input(page, label: str):
    return page.locator(f"xpath=//label[text()='{label}']/ancestor::div[2]//input[@type='text']")


def _select(page, label: str, option: str) -> None:
    page.get_by_label(label, exact=True).click()
    page.get_by_role("option", name=option, exact=True).click()


def test_click_on_the_mesh_sets_the_contact_point_and_draft(app: Annotator, page) -> None:
    before = app.pose
    t0 = time.monotonic()
    page.mouse.click(*_jar_wall(app))
    wait_for(lambda: _events(app, "pose", t0), what="a pose from the click")
    contact = np.asarray(app.contact)
    geo = get_model(START).geometry  # the jar's wall from the asset library's own parameters
    r = float(np.hypot(contact[0], contact[1]))
    assert abs(r - geo["outer_radius"]) < 2e-3, f"contact {contact} is not on the jar's wall (r = {r:.4f} m)"
    assert 0.0 < contact[2] < geo["height"]
    pose = app.pose
    z = pose.rotation()[:, 2]
    assert np.allclose(pose.pos, contact + z * float(app.depth.value), atol=1e-9)
    assert not np.allclose(pose.pos, before.pos)


def test_slider_changes_the_pose(app: Annotator, page) -> None:
    y_before, z_before = app.pose.rotation()[:, 1], app.pose.rotation()[:, 2]
    box = _slider_input(page, "yaw (deg)")
    box.fill("90")
    box.press("Enter")
    wait_for(lambda: abs(float(app.yaw.value) - 90.0) < 1e-9, what="the yaw slider at 90")
    wait_for(lambda: abs(float(app.pose.rotation()[:, 1] @ y_before)) < 1e-6, what="the fingers turned 90°")
    assert np.allclose(app.pose.rotation()[:, 2], z_before), "yaw rolls about the approach, which stays"
    box.fill("0")
    box.press("Enter")
    wait_for(lambda: abs(float(app.pose.rotation()[:, 1] @ y_before) - 1.0) < 1e-6, what="yaw back at 0")


def test_gizmo_drag_updates_the_verdict_within_150_ms(app: Annotator, page) -> None:
    _select(page, "mode", "free")
    wait_for(lambda: app.mode.value == "free", what="free mode")
    app._open(app.index)  # the default top-down draft above the jar, a pose the gizmo sits at
    wait_for(lambda: app.verdict is not None and app.events[-1][0] == "verdict", what="the first verdict")
    z0 = float(app.pose.pos[2])
    shown = page.locator("[data-verdict]").inner_text()
    t0 = time.monotonic()
    # grab the gizmo's approach (blue, +Z) arrow part-way along and pull it back towards the gizmo's centre
    rot, origin = app.pose.rotation(), app.pose.pos
    x, y = project(app, origin + rot[:, 2] * 0.13, VIEWPORT)  # the arrow head
    x1, y1 = project(app, origin + rot[:, 2] * 0.08, VIEWPORT)
    page.mouse.move(x, y)
    page.mouse.down()
    for k in range(1, 11):
        time.sleep(0.03)
        page.mouse.move(x + (x1 - x) * k / 10, y + (y1 - y) * k / 10)
    page.mouse.up()  # at once: the last pose's checks are still running when the drag ends
    end = wait_for(lambda: _events(app, "drag_end", t0), what="the drag's end")[-1]
    final_seq = end[2]
    verdict = wait_for(lambda: [e for e in _events(app, "verdict", t0) if e[2] == final_seq],
                       what="the verdict of the dragged pose")[0]
    assert _events(app, "pose", t0), "the drag moved the draft"
    assert abs(float(app.pose.pos[2]) - z0) > 0.005, "dragging the approach arrow moved the hand"
    latency = max(0.0, verdict[1] - end[1])
    job = next(d for d in app.timings if d.seq == final_seq)
    starved = max(0.0, job.wall - job.cpu)  # time the OS ran other processes instead (shared CPUs)
    print(f"verdict shown {latency * 1000:.0f} ms after the drag ended (server clock); its check took "
          f"{job.wall * 1000:.0f} ms wall, {job.cpu * 1000:.0f} ms CPU")
    assert latency - starved <= 0.150, (f"verdict shown {latency * 1000:.0f} ms after the drag ended, "
                                        f"{starved * 1000:.0f} ms of it waiting for a CPU")
    wait_for(lambda: page.locator("[data-verdict]").inner_text() != shown, what="the badges to update")
    assert page.locator("[data-check]").count() == 6
    _select(page, "mode", "guided")
    wait_for(lambda: app.mode.value == "guided", what="guided mode")


def test_hotkey_save_reload_resume_and_delete_last(app: Annotator, page, grasp_dir) -> None:
    page.mouse.click(*_jar_wall(app))
    t0 = time.monotonic()
    page.keyboard.press("Enter")
    wait_for(lambda: _events(app, "saved", t0), what="the save")
    saved = GraspDB.load_dir(grasp_dir).grasps(START)
    assert len(saved) == 1 and saved[0].source == "annotated"
    assert np.allclose(saved[0].pos, app.pose.pos, atol=1e-6)
    assert np.allclose(np.abs(saved[0].quat), np.abs(app.pose.quat), atol=1e-6)
    page.get_by_text("4/16, 1 saved").wait_for(timeout=5_000)

    page.reload()
    page.get_by_text("live check:").wait_for(timeout=30_000)
    page.get_by_text("4/16, 1 saved").wait_for(timeout=5_000)
    assert page.get_by_text(START, exact=True).count() >= 1

    again = Annotator(Catalog.build("jar", "jar"), GraspStore(grasp_dir), port=free_port())
    try:  # a new session opens where the last one stopped
        assert again.key == START and len(again.store.annotated(START)) == 1
    finally:
        again.close()

    t1 = time.monotonic()
    page.get_by_role("button", name="delete last (Backspace)").click()
    wait_for(lambda: _events(app, "deleted", t1), what="the delete")
    assert GraspDB.load_dir(grasp_dir).grasps(START) == ()
    page.get_by_text("4/16, 0 saved").wait_for(timeout=5_000)


def test_search_and_jump(app: Annotator, page) -> None:
    search = page.locator("xpath=//label[text()='search']/ancestor::div[2]//input")
    search.fill("hinged_07")
    wait_for(lambda: app.jump.options == ("jar/hinged_07",), what="the search to filter the jump list")
    _select(page, "jump to", "jar/hinged_07")
    wait_for(lambda: app.key == "jar/hinged_07", what="the jump")
    page.get_by_text("8/16, 0 saved").wait_for(timeout=10_000)
    page.get_by_role("button", name="next ▶").click()
    wait_for(lambda: app.key == "jar/hinged_08", what="next")
