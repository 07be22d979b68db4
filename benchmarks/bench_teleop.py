"""Teleop benchmark (prints figures; targets from issue 14).

- sync-read rate of both drivers through the real SDKs against the emulated buses (target >= 1 kHz);
- the 20 Hz session loop on one core (``sched_setaffinity``) while a headless Chromium streams the operator
  view: lateness of each control step against its schedule (p50/p99; target p99 <= 5 ms) and the step's
  compute time; the emulated leader runs in its own process, as a device would;
- the latency from the end of a control step to its monitor state appearing in the operator page's DOM (a
  MutationObserver timestamps each change; target p95 <= 100 ms), split into its stages;
- ``--screenshot PATH`` saves the operator view mid-episode (``docs/teleop.png``).

Run: ``.venv/bin/python benchmarks/bench_teleop.py [--steps 200] [--screenshot docs/teleop.png]``
(needs Debian ``chromium`` and the ``playwright`` Python package; no browser download).
"""

from __future__ import annotations

import argparse
import dataclasses
import os
import shutil
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

import numpy as np

import mgdata.teleop.bus
from mgdata.sim.robot import HOME_Q
from mgdata.teleop.bus import ServoBus
from mgdata.teleop.config import load_teleop_config
from mgdata.teleop.emulator.arms import ArmBuild, ManualClock
from mgdata.teleop.emulator.operator import calibrate_gello, gello_calibration_scripts
from mgdata.teleop.emulator.script import JointScript
from mgdata.teleop.gello import gello_motors
from mgdata.teleop.mapping import mapper_for
from mgdata.teleop.reader import LeaderReader
from mgdata.teleop.session import SessionJob, TeleopSession
from mgdata.teleop.so101.calibration import so101_motors
from mgdata.teleop.view import OperatorView

CHROMIUM = shutil.which("chromium") or "/usr/bin/chromium"
RECEIPT = """
(() => {
  // in every frame: count animation frames (the 3D view's, in viser's iframe); in the operator page:
  // timestamp each monitor event as it reaches the page's main thread (before the page's own handler)
  window.__frames = 0;
  const tick = () => { window.__frames += 1; requestAnimationFrame(tick); };
  requestAnimationFrame(tick);
  window.__mgRecv = [];
  const Base = window.EventSource;
  window.EventSource = class extends Base {
    constructor(...args) {
      super(...args);
      this.addEventListener('message', (e) => {
        const t = Date.now() / 1000;
        window.__mgRecv.push([JSON.parse(e.data).step, t]);
      });
    }
  };
})();
"""
OBSERVER = """
() => {
  // each monitor state's step, its step's end (Python), when it is in the DOM and the next frame after it
  window.__mg = [];
  const seen = new Set();
  const grab = () => {
    const el = document.querySelector('#mg-monitor');
    if (!el) return;
    const step = el.getAttribute('data-step');
    if (seen.has(step)) return;
    seen.add(step);
    const row = [Number(step), Number(el.getAttribute('data-sent')), Date.now() / 1000, 0];
    window.__mg.push(row);
    requestAnimationFrame(() => { row[3] = Date.now() / 1000; });
  };
  new MutationObserver(grab).observe(document.body, {subtree: true, childList: true, attributes: true,
                                                     characterData: true});
}
"""


def sync_read_rate(family: str, seconds: float = 2.0) -> float:
    build = ArmBuild.gello(seed=3) if family == "dynamixel" else ArmBuild.so101(seed=5)
    motors = gello_motors(True) if family == "dynamixel" else so101_motors()
    clock = ManualClock()
    with build.bus([JointScript.constant(0.1)] * len(motors), clock) as emu:
        bus = ServoBus(family, emu.port, motors)
        n, t0 = 0, time.perf_counter()
        while time.perf_counter() - t0 < seconds:
            bus.read_positions()
            n += 1
        rate = n / (time.perf_counter() - t0)
        bus.close()
    return rate


def thread_cpu() -> dict[str, float]:
    """CPU seconds so far per thread of this process, by name (Python's thread name, else the OS's)."""
    names = {t.native_id: t.name for t in threading.enumerate()}
    tick = os.sysconf("SC_CLK_TCK")
    out: dict[str, float] = {}
    for task in Path("/proc/self/task").iterdir():
        try:
            stat = (task / "stat").read_text()
        except OSError:  # the thread ended
            continue
        comm, fields = stat[stat.index("(") + 1:stat.rindex(")")], stat[stat.rindex(")") + 2:].split()
        name = names.get(int(task.name), comm)
        out[name] = out.get(name, 0.0) + (int(fields[11]) + int(fields[12])) / tick
    return out


def descendants(pid: int) -> list[int]:
    """Every process below ``pid`` (from ``/proc``)."""
    parent: dict[int, int] = {}
    for d in Path("/proc").iterdir():
        if d.name.isdigit():
            try:
                stat = (d / "stat").read_text()
            except OSError:
                continue
            parent[int(d.name)] = int(stat[stat.rindex(")") + 2:].split()[1])
    out, todo = [], [pid]
    while todo:
        p = todo.pop()
        kids = [c for c, pp in parent.items() if pp == p]
        out += kids
        todo += kids
    return out


def _pct(values: list[float] | np.ndarray, q: float) -> float:
    return float(np.percentile(np.asarray(values), q)) if len(values) else float("nan")


def session_loop(steps: int, screenshot: Path | None, port: int, scene_every: int | None,
                 shadows: bool | None, realtime: int, browser_nice: int, wire: bool, device_fifo: int
                 ) -> None:
    from playwright.sync_api import sync_playwright

    build = ArmBuild.gello(seed=3)
    clock = ManualClock()
    with build.bus(gello_calibration_scripts(HOME_Q), clock) as emu:
        bus = ServoBus("dynamixel", emu.port, gello_motors(True))
        cal = calibrate_gello(bus, clock, HOME_Q)
        bus.close()
    tmp = Path(tempfile.mkdtemp(prefix="bench_teleop_"))
    cal.save(tmp / "gello.json")
    text = (tmp / "gello.json").read_text()
    config = load_teleop_config()
    # the operator reaches forward and down towards the jar, closing the trigger half-way through
    reach = HOME_Q + np.array([0.0, 0.45, 0.0, 0.35, 0.0, -0.1, 0.0])
    duration = steps * 0.05
    scripts = [JointScript([0, 1.0, duration], [HOME_Q[k], HOME_Q[k], reach[k]]) for k in range(7)]
    scripts.append(JointScript([0, duration * 0.6, duration * 0.7], [0.0, 0.0, 0.6]))
    live = ManualClock()
    with build.bus(scripts, live) as emu:  # forked before this process is pinned: the device has its own core
        if device_fifo and emu.pid is not None:  # hardware answers whatever the load; an emulator may not
            os.sched_setscheduler(emu.pid, os.SCHED_FIFO, os.sched_param(device_fifo))
        mapper = mapper_for("gello", text, config)
        bus = ServoBus("dynamixel", emu.port, mapper.motors)
        # the reader's process too, like the device: on a user's machine it is not confined to the loop's core
        reader = LeaderReader(bus, config.leader.reader_hz, stale_s=2.0)
        all_cores = os.sched_getaffinity(0)
        # pin this thread; the session's threads created from here on inherit the one core
        os.sched_setaffinity(0, {sorted(all_cores)[0]})
        session: TeleopSession | None = None
        shot_at = steps * 3 // 4
        shot_ready = threading.Event()

        def on_step(k: int) -> None:
            live.t = k * 0.05
            if k == shot_at:
                shot_ready.set()
            if k >= steps and session is not None:
                session.command("stop")

        job = SessionJob("gello", "jar", 0, tmp / "ds", keep_failed=True, episodes=1)
        ready, go = threading.Event(), threading.Event()
        box: dict[str, object] = {}

        def drive() -> None:
            # the session (and its GL context) lives in this thread; the browser (playwright) in the main one
            nonlocal session
            session = TeleopSession(job, mapper, text, reader, on_step=on_step)
            session.realtime_priority = realtime
            view_config = config.view
            if scene_every is not None:
                view_config = dataclasses.replace(view_config, scene_every=scene_every)
            if shadows is not None:
                view_config = dataclasses.replace(view_config, shadows=shadows)
            view = OperatorView(session, "127.0.0.1", port, view_config)
            session.on_status = view.update
            box["session"], box["view"] = session, view
            ready.set()
            go.wait()
            session.command("record")
            box["t0"] = time.perf_counter()
            box["r0"] = reader.now()
            box["reads0"] = reader.reads
            cpu0, thread0 = time.process_time(), time.thread_time()
            box["threads0"] = thread_cpu()
            try:
                session.run()
            finally:
                box["wall"] = time.perf_counter() - float(box["t0"])  # type: ignore[arg-type]
                box["reads"] = reader.reads - int(box["reads0"])  # type: ignore[call-overload]
                box["cpu"] = time.process_time() - cpu0
                box["control_cpu"] = time.thread_time() - thread0
                box["threads"] = thread_cpu()
                shot_ready.set()

        worker = threading.Thread(target=drive, name="control loop")
        worker.start()
        ready.wait()
        os.sched_setaffinity(0, all_cores)  # the browser stands for the operator's machine: not on that core
        view: OperatorView = box["view"]  # type: ignore[assignment]
        with sync_playwright() as p:
            browser = p.chromium.launch(executable_path=CHROMIUM, headless=True,
                                        args=["--no-sandbox", "--disable-gpu", "--use-gl=swiftshader"])
            if browser_nice:
                for pid in descendants(os.getpid()):  # the browser's processes (and playwright's driver)
                    os.setpriority(os.PRIO_PROCESS, pid, browser_nice)
            page = browser.new_page(viewport={"width": 1400, "height": 900})
            page.add_init_script(RECEIPT)
            probe = None
            if wire:  # a second client that timestamps the wire, in its own process (not on the loop's core)
                script = str(Path(__file__).with_name("monitor_wire_probe.py"))
                probe = subprocess.Popen([sys.executable, script, view.url], stdout=subprocess.PIPE,
                                         text=True)
            page.goto(view.url)
            page.wait_for_selector("#mg-monitor[data-step='0']", timeout=120000)  # the stream is open
            page.frame_locator("#scene").locator("canvas").first.wait_for(timeout=120000)  # the 3D view
            page.evaluate(OBSERVER)
            go.set()
            if screenshot is not None:
                shot_ready.wait(timeout=1200)
                time.sleep(0.5)
                screenshot.parent.mkdir(parents=True, exist_ok=True)
                page.screenshot(path=str(screenshot))
            worker.join()
            wall = float(box["wall"])  # type: ignore[arg-type]
            time.sleep(0.5)
            seen = page.evaluate("() => window.__mg")
            recv = {int(k): float(t) for k, t in page.evaluate("() => window.__mgRecv")}
            scene = next(f for f in page.frames if f != page.main_frame)  # viser's iframe
            frames = scene.evaluate("() => window.__frames")
            browser.close()
        view.close()
        wire_at: dict[int, float] = {}
        if probe is not None:
            out, _ = probe.communicate(timeout=30)
            wire_at = {int(a): float(b) for a, b in (line.split() for line in out.splitlines())}
        rate = int(box["reads"]) / float(box["wall"])  # type: ignore[call-overload, arg-type]
        rate_life = reader.rate_hz
        reader.close()
        bus.close()
    starts, due = np.array(session.step_times), np.array(session.step_due)
    late = (starts - due) * 1000  # against the absolute schedule t0 + k * 50 ms
    busy = np.array(session.step_busy) * 1000
    timings = session.runner.timings
    seen = [row for row in seen if row[1] > 0]  # states of control steps (not the idle state before)
    lat = [(shown - sent) * 1000 for _step, sent, shown, _painted in seen]
    painted = [(p - sent) * 1000 for _step, sent, _shown, p in seen if p > 0]
    flushed = dict(view.flushed)
    sent_at = {int(k): float(sent) for k, sent, _shown, _p in seen}
    to_flush = [(flushed[k] - sent_at[k]) * 1000 for k in sent_at if k in flushed]
    to_page = [(recv[k] - flushed[k]) * 1000 for k in recv if k in flushed]
    to_wire = [(wire_at[k] - flushed[k]) * 1000 for k in wire_at if k in flushed]
    to_dom = [(shown - recv[int(k)]) * 1000 for k, _sent, shown, _p in seen if int(k) in recv]
    n = len(starts)
    print(f"session loop: {n} ticks in {wall:.1f} s ({n / wall:.1f} Hz, target 20 Hz) on one core, "
          f"{session.skipped} slots skipped after overruns; meanwhile the leader was read at {rate:.0f} Hz "
          f"(target >= 100; {rate_life:.0f} Hz over the reader's whole life)")
    t0, t1 = float(box["r0"]), float(box["r0"]) + wall  # type: ignore[arg-type]
    reads = [w * 1000 for t, w in reader.recent_reads if t0 <= t <= t1]
    print(f"  leader reads meanwhile (ms of wall time each): p50 {_pct(reads, 50):.1f}  "
          f"p95 {_pct(reads, 95):.1f}  max {max(reads, default=float('nan')):.1f}; "
          f"{reader.retried} sync reads failed and were retried (over the whole run)")
    print(f"  lateness against the absolute schedule (ms): p50 {_pct(late, 50):.1f}  "
          f"p99 {_pct(late, 99):.1f}  max {late.max():.1f} (target p99 <= 5)")
    print(f"  step compute (ms): p50 {_pct(busy, 50):.1f}  p99 {_pct(busy, 99):.1f}  max {busy.max():.1f} "
          f"of 50; per step on average: physics {timings.physics / n * 1000:.1f}, "
          f"render+label+encode {timings.rendering / n * 1000:.1f}")
    cpu, control_cpu = float(box["cpu"]), float(box["control_cpu"])  # type: ignore[arg-type]
    print(f"  CPU per control step (ms, the budget is 50): this process {cpu / n * 1000:.1f}, of which the "
          f"control thread {control_cpu / n * 1000:.1f} and the view publisher and viser threads "
          f"{(cpu - control_cpu) / n * 1000:.1f}")
    before, after = box["threads0"], box["threads"]  # type: ignore[assignment]
    per_thread = sorted(((after[k] - before.get(k, 0.0)) / n * 1000, k) for k in after)  # type: ignore[union-attr]
    print("  CPU per step by thread (ms): " + ", ".join(f"{name} {ms:.1f}" for ms, name in per_thread[::-1]
                                                     if ms >= 0.05))
    print(f"  operator view: {view.published} snapshots published, {view.superseded} superseded by a newer "
          f"one; the 3D view (viser's iframe) drew {frames / wall:.1f} frames/s")
    print(f"  monitor state in the page's DOM after the step (ms, {len(lat)} of {n} steps): p50 "
          f"{_pct(lat, 50):.0f}  p95 {_pct(lat, 95):.0f}  max {max(lat) if lat else float('nan'):.0f} "
          f"(target p95 <= 100); to the page's next frame p50 {_pct(painted, 50):.0f}  p95 "
          f"{_pct(painted, 95):.0f}")
    print(f"    of which (ms, p50/p95): step -> sent by the publisher {_pct(to_flush, 50):.0f}/"
          f"{_pct(to_flush, 95):.0f}; -> event on the page's main thread {_pct(to_page, 50):.0f}/"
          f"{_pct(to_page, 95):.0f}; -> in the DOM {_pct(to_dom, 50):.0f}/{_pct(to_dom, 95):.0f}")
    if wire:
        print(f"    a second client on the wire (ms, p50/p95, {len(to_wire)} states): sent -> received "
              f"{_pct(to_wire, 50):.0f}/{_pct(to_wire, 95):.0f}")
    if screenshot is not None:
        print(f"  screenshot: {screenshot}")
    shutil.rmtree(tmp, ignore_errors=True)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--steps", type=int, default=200)
    parser.add_argument("--screenshot", type=Path, default=None)
    parser.add_argument("--port", type=int, default=8765)
    parser.add_argument("--scene-every", type=int, default=None,
                        help="control steps between 3D scene updates (default: recipes/teleop.toml [view])")
    parser.add_argument("--shadows", action=argparse.BooleanOptionalAction, default=None,
                        help="shadow maps in the 3D view (default: recipes/teleop.toml [view] shadows)")
    parser.add_argument("--realtime", type=int, default=0, metavar="PRIO",
                        help="run the session SCHED_FIFO at PRIO (teleop.priority; root); 0: as configured")
    parser.add_argument("--browser-nice", type=int, default=0, metavar="N",
                        help="renice the headless browser's processes to N (e.g. -10: it stands for the "
                             "operator's own machine)")
    parser.add_argument("--wire", action="store_true",
                        help="also timestamp monitor states on the wire with a second client "
                             "(benchmarks/monitor_wire_probe.py)")
    parser.add_argument("--device-fifo", type=int, default=0, metavar="PRIO",
                        help="run the emulated leader's process SCHED_FIFO at PRIO (it stands for hardware, "
                             "which does not wait for the host's CPUs)")
    parser.add_argument("--skip-sync", action="store_true", help="skip the sync-read rates")
    args = parser.parse_args()
    print(f"load average: {os.getloadavg()[0]:.1f} on {os.cpu_count()} cores; reply latency allowance "
          f"{mgdata.teleop.bus.DEFAULT_LATENCY_MS:.0f} ms")
    if not args.skip_sync:
        for family, name in (("dynamixel", "GELLO 8 x XL330"), ("feetech", "SO-101 6 x STS3215")):
            print(f"sync read {name}: {sync_read_rate(family):.0f} reads/s (target >= 1000)")
    print(f"session: SCHED_FIFO priority {args.realtime}" if args.realtime else "session: normal scheduling",
          f"; browser nice {args.browser_nice}" if args.browser_nice else "; browser at default priority")
    session_loop(args.steps, args.screenshot, args.port, args.scene_every, args.shadows, args.realtime,
                 args.browser_nice, args.wire, args.device_fifo)


if __name__ == "__main__":
    main()
