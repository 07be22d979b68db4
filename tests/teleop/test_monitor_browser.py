"""The live monitor in the operator's page, in a real headless Chromium: every state the page shows is the
state the session recorded for that step (each constraint's DFA state and violation, engagement, success,
the gate), the first violation reaches the page with its banner, and the 3D view runs out of the page's
process. The test tips the jar against the gripper through raw MuJoCo state and checks the tilt and the
contact from the recorded physics state."""

from __future__ import annotations

import math
from pathlib import Path

import mujoco
import numpy as np
import pytest

from mgdata.generate.run import failed_path
from mgdata.record.physics import model_from_bytes, set_physics_state
from mgdata.record.reader import DatasetReader
from mgdata.teleop.gello import GelloCalibration
from mgdata.teleop.session import TeleopSession
from tests.teleop.browser import open_operator_page, served_session, wait

pytest.importorskip("playwright", reason="playwright is part of the dev setup")

TIP_AT = 6
"""Episode step after which the test tips the jar over (raw MuJoCo state, outside the session's code)."""

SHOWN = """
() => {
  // every monitor state the page puts into its DOM, as the operator reads it
  window.__shown = [];
  const text = (id) => document.getElementById(id).textContent;
  const grab = () => {
    const m = document.getElementById('mg-monitor');
    const banner = document.getElementById('mg-banner');
    const row = {step: Number(m.dataset.step), mode: text('mg-mode'), engaged: text('mg-engaged'),
                 success: text('mg-success'), gate: text('mg-gate'), failed: text('mg-failed'),
                 banner: banner.hidden ? null : banner.textContent,
                 rows: [...document.querySelectorAll('#mg-constraints tr')].map(
                   (tr) => [tr.dataset.constraint, tr.cells[1].textContent])};
    const last = window.__shown[window.__shown.length - 1];
    if (!last || JSON.stringify(last) !== JSON.stringify(row)) window.__shown.push(row);
  };
  grab();
  new MutationObserver(grab).observe(document.body, {subtree: true, childList: true, attributes: true,
                                                     characterData: true});
}
"""


def _tip_jar(session: TeleopSession, step: int) -> None:
    if step != TIP_AT or session.episode is None:
        return
    model, data = session.scene.model, session.scene.data
    adr = model.jnt_qposadr[mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, "jar/free")]
    finger = data.xpos[mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, "left_finger")]
    data.qpos[adr:adr + 3] = finger + np.array([0.0, 0.0, -0.06])  # against the gripper: contact
    data.qpos[adr + 3:adr + 7] = (math.cos(math.pi / 4), math.sin(math.pi / 4), 0.0, 0.0)  # 90° about x
    mujoco.mj_forward(model, data)


def _jar_tilt_and_touch(reader: DatasetReader, episode: int, frame: int) -> tuple[float, bool]:
    """From the raw MuJoCo state of a recorded frame: the jar's tilt from vertical (degrees), and whether a
    robot geom touches the jar's (``data.contact``)."""
    model = model_from_bytes(reader.scene_mjb(episode))
    data = mujoco.MjData(model)
    set_physics_state(model, data, reader.episode(episode).physics_state[frame])
    jar = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, "jar")
    z = data.xmat[jar].reshape(3, 3)[:, 2]
    robot = model.body_rootid[mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, "left_finger")]
    assert robot != model.body_rootid[jar]

    def owner(g: int) -> int:
        return int(model.body_rootid[model.geom_bodyid[g]])

    touch = any({owner(c.geom1), owner(c.geom2)} == {robot, int(model.body_rootid[jar])}
                for c in data.contact[:data.ncon])
    return math.degrees(math.acos(float(np.clip(z[2], -1.0, 1.0)))), touch


def test_page_shows_the_recorded_monitor_state(gello_cal: GelloCalibration, tmp_path: Path) -> None:
    from playwright.sync_api import sync_playwright

    with served_session(gello_cal, tmp_path, on_step=_tip_jar) as served:
        session = served.session
        with sync_playwright() as pw:
            browser, page = open_operator_page(pw, served.view.url)
            page.evaluate(SHOWN)
            page.get_by_role("button", name="Record").click()
            wait(lambda: session.status.failed == 1, "the tipped episode to end")
            wait(lambda: page.locator("#mg-failed").inner_text() == "1", "the page to show it failed")
            shown = page.evaluate("() => window.__shown")
            page.frame_locator("#scene").locator("canvas").first.wait_for(timeout=240_000)
            targets = page.context.new_cdp_session(page).send("Target.getTargets")["targetInfos"]
            scene_url = f"http://127.0.0.1:{served.view.server.get_port()}/"
            browser.close()
    # the 3D view (viser) is an out-of-process iframe: its WebGL frames do not hold up the monitor's thread
    assert any(t["type"] == "iframe" and t["url"].startswith(scene_url) for t in targets), targets

    reader = DatasetReader(failed_path(tmp_path / "jar_teleop"))
    ep = reader.episode(0)
    meta = ep.meta
    last = len(ep.dfa_state) - 1  # frame k: the state after step k (frame 0: the episode's start)
    assert meta.failure_stage == "unsafe" and last > TIP_AT  # it ends at the violation, after the tip
    tilt, touch = _jar_tilt_and_touch(reader, 0, last)
    assert tilt > 30.0 and touch  # tipped over (the jar's upright limit is 30°) against the gripper
    ids = list(session.status.constraints)

    def rows(frame: int) -> list[list[str]]:
        return [[cid, f"{'VIOLATED' if ep.violated[frame, k] else 'ok'} (q{ep.dfa_state[frame, k]})"]
                for k, cid in enumerate(ids)]

    recording = [s for s in shown if s["mode"] == "recording"]
    assert recording, shown
    for s in recording:  # whatever step the page shows, it shows that step's recorded state
        frame = s["step"]
        assert s["rows"] == rows(frame), s
        assert s["banner"] is None
        assert s["engaged"] == ("yes" if ep.engaged[frame] else "no")
        assert s["success"] == ("yes" if ep.success[frame] else "no")
    final = shown[-1]  # the violation step reached the page: the episode ended on it
    first = min((t, cid) for cid, t in meta.t_violation.items() if t is not None)[1]
    assert final["step"] == last == meta.t_violation[first] and final["mode"] == "idle"
    assert final["failed"] == "1"
    assert final["rows"] == rows(last) and "VIOLATED" in "".join(r[1] for r in final["rows"])
    assert final["banner"] is not None and first in final["banner"], (final, meta.t_violation)
    assert final["engaged"] == "yes" and ep.engaged[last]  # the gripper touches the jar
    assert final["gate"] == f"0/{session.status.hold_steps}"
