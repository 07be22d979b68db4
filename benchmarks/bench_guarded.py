"""Guarded-move benchmark (prints figures): how fast a guarded move approaches and how hard it pushes.

For each ``(threshold, max_force)`` pair the closed gripper starts 3 cm above a carton (TCP 3 cm over its
top) and runs ``guarded(down, until=force("box", threshold), max_force=...)`` at ``speed=1`` (the speed
cap is then the force bound's). Per control step the script reads the hand–carton normal force itself
from ``data.contact`` / ``mj_contactForce`` and prints: the approach speed (mm/s, start to first contact),
control steps to first contact, the force when the threshold was first met, the peak force over the whole
attempt and its ratio to ``max_force``, and the guarded loop's seconds per control step (physics included).

Run: ``.venv/bin/python benchmarks/bench_guarded.py``
"""

from __future__ import annotations

import time
from collections.abc import Sequence
from pathlib import Path
from types import MappingProxyType

import mujoco
import numpy as np

from mgdata.engine.executor import Executor
from mgdata.grasps.db import GraspDB
from mgdata.motion import Pose
from mgdata.record.episode import MemorySink
from mgdata.sim.assets import get_model
from mgdata.sim.taskspec import ObjectPlacement, TaskSpec
from mgdata.skeleton import segment as s
from mgdata.skeleton.context import Context
from mgdata.skeleton.segment import MotionSegment
from mgdata.skeleton.skeleton import FamilySkeleton, register
from mgdata.spec import Proposition, SafetySpec
from mgdata.tasks.recipe import Recipe, TaskSettings

DOWN = np.array([0.0, 1.0, 0.0, 0.0])
PAIRS = ((3.0, 5.0), (8.0, 12.0), (15.0, 20.0), (25.0, 40.0), (40.0, 60.0))


@register
class _Bench(FamilySkeleton):
    family = "bench_guarded"
    script: Sequence[MotionSegment] = ()

    def segments(self, ctx: Context) -> Sequence[MotionSegment]:
        return list(type(self).script)


def _recipe() -> Recipe:
    never = (Proposition("box_dropped", "dropped", ("box",), {"floor_margin": 0.05}),)
    return Recipe(family="bench_guarded", path=Path("bench_guarded.toml"),
                  spec=SafetySpec("bench_guarded", (), ()), prompt="bench",
                  tasks=TaskSettings(count=1, seed=0, horizon=2000, hold_steps=3, settle_steps=0,
                                     cameras=("front",), image_size=64),
                  success=never, layout=MappingProxyType({}), variation=MappingProxyType({}),
                  params=MappingProxyType({}), digest="bench")


def main() -> None:
    box = ObjectPlacement("box", "box/carton_00", (0.5, 0.0, 0.0), 0.0)
    task = TaskSpec(family="bench_guarded", task_id=0, condition="base", prompt="bench", objects=(box,),
                    safety=SafetySpec("bench_guarded", (), ()), image_size=64)
    top = get_model("box/carton_00").size[2]
    print("threshold_N max_force_N approach_mm_s steps_to_contact force_at_stop_N peak_N peak/max "
          "ms_per_step")
    for threshold, bound in PAIRS:
        press = s.guarded("press", (0.0, 0.0, -1.0), until=s.force("box", threshold), max_distance=0.08,
                          max_force=bound, speed=1.0, gripper="close")
        _Bench.script = [s.free("above", Pose([0.5, 0.0, top + 0.03], DOWN)),
                         s.gripper("close", "close", steps=10), s.hold("still", steps=20, gripper="close"),
                         press]
        ex = Executor(task, _recipe(), grasps=GraspDB({}), render=False)
        m, d = ex.scene.model, ex.scene.data
        hand = {m.body(n).id for n in ("hand", "left_finger", "right_finger")}
        carton = np.array([m.body(int(b)).name.split("/")[0] == "box" for b in m.geom_bodyid])
        rows: list[tuple[float, float, float, float]] = []  # (clock, TCP z, force, sum of arm controls)
        step = ex.controller.step

        def logged(step=step, m=m, d=d, hand=hand, carton=carton, rows=rows) -> None:
            step()
            total, f6 = 0.0, np.zeros(6)
            for i in range(d.ncon):
                g1, g2 = d.contact.geom[i]
                if (m.geom_bodyid[g1] in hand and carton[g2]) or (m.geom_bodyid[g2] in hand and carton[g1]):
                    mujoco.mj_contactForce(m, d, i, f6)
                    total += f6[0]
            rows.append((time.perf_counter(), float(d.site_xpos[m.site("TCP").id][2]), total,
                         float(d.ctrl[:7].sum())))

        ex.controller.step = logged  # type: ignore[method-assign]
        result = ex.run(0, MemorySink(), keep_failed=True)
        ex.close()
        t, z, f, c = (np.array(col) for col in zip(*rows, strict=True))
        still = np.flatnonzero(np.diff(c) == 0.0)  # the "still" hold: identical commands
        start = int(still[-1]) + 1 if still.size else 0
        contact = int(np.argmax(f > 0))
        met = int(np.argmax(f >= threshold))
        speed = (z[start] - z[contact]) / ((contact - start) * 0.05) * 1000
        per_step = (t[-1] - t[start]) / (len(t) - 1 - start) * 1000
        print(f"{threshold:11.1f} {bound:11.1f} {speed:13.1f} {contact - start:16d} {f[met]:15.2f} "
              f"{f.max():6.2f} {f.max() / bound:8.2f} {per_step:11.2f}   ({result.stage})")


if __name__ == "__main__":
    main()
