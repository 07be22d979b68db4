"""A scripted teleop session: an emulated leader replays joint scripts on the session's simulated clock."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path

from mgdata.teleop.bus import ServoBus
from mgdata.teleop.config import load_teleop_config
from mgdata.teleop.emulator.arms import ArmBuild, ManualClock
from mgdata.teleop.emulator.script import JointScript
from mgdata.teleop.mapping import mapper_for
from mgdata.teleop.reader import LeaderReader
from mgdata.teleop.session import SessionJob, TeleopSession

FAMILY = {"gello": "dynamixel", "so101": "feetech"}


def run_scripted_session(arm: str, build: ArmBuild, calibration: str, scripts: Sequence[JointScript],
                         out: Path, *, family: str = "jar", task: int = 0, stop_at: int | None = None,
                         keep_failed: bool = True, presses: Mapping[int, Sequence[str]] | None = None
                         ) -> TeleopSession:
    """Record one episode: the leader follows ``scripts`` on the simulated clock (t = steps · 50 ms); the
    operator presses Stop after ``stop_at`` steps (``None``: the episode ends by itself). With ``presses``
    (step n → buttons pressed after step n; 0: before the first) the operator presses buttons, and the
    episode starts with the ``record`` among them instead of by itself."""
    config = load_teleop_config()
    clock = ManualClock()
    with build.bus(scripts, clock) as emu:
        mapper = mapper_for(arm, calibration, config)
        bus = ServoBus(FAMILY[arm], emu.port, mapper.motors)
        if arm == "so101":
            mapper.cal.apply(bus)  # type: ignore[attr-defined]
        reader = LeaderReader(bus, config.leader.reader_hz, stale_s=5.0)  # a loaded CI host stalls threads
        session: TeleopSession | None = None

        def on_step(k: int) -> None:
            clock.t = k * 0.05
            if session is None:
                return
            if stop_at is not None and k == stop_at:
                session.command("stop")
            for name in (presses or {}).get(k, ()):
                session.command(name)

        job = SessionJob(arm, family, task, out, keep_failed=keep_failed, episodes=1,
                         autostart=presses is None)
        session = TeleopSession(job, mapper, calibration, reader, on_step=on_step)
        for name in (presses or {}).get(0, ()):
            session.command(name)
        try:
            session.run()
        finally:
            reader.close()
            bus.close()
    return session
