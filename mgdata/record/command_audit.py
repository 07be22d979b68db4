"""The executed-command audit of a perturbed dataset (``sim.executed_action``, :mod:`mgdata.tasks.recovery`).

A perturbed demonstration records two commands per frame: ``action``, the plan's target (what a policy
learns), and ``sim.executed_action``, what the controller ran. From the stored scene and states alone, with
raw MuJoCo, :func:`audit_commands` checks that

* the arm's controls stored with frame ``t + 1`` are ``executed_action[t]`` clipped to the actuators'
  ranges (the states are the executed command's: the physics replays from it exactly);
* the executed command differs from the action only on the arm joints, by at most the recorded
  ``[recovery] amplitude`` (the gripper command is never perturbed).

Example::

    problems = audit_commands(reader.episode(i), model, amplitude=0.03)
"""

from __future__ import annotations

import mujoco
import numpy as np

from mgdata.record.physics import set_physics_state
from mgdata.record.reader import EpisodeData
from mgdata.sim import robot

OFFSET_TOL = 1e-6
"""rad: float32 rounding of the two stored commands (the offsets themselves are millradians and up)."""


def audit_commands(ep: EpisodeData, model: mujoco.MjModel, amplitude: float | None) -> list[str]:
    """Problems with episode ``ep``'s executed commands (none if they are what ran and within
    ``amplitude`` rad of the actions; ``None``: the offset is not bounded)."""
    if ep.executed_action is None or ep.physics_state is None:
        return []
    where = f"episode {ep.index}"
    executed, action = ep.executed_action.astype(np.float64), ep.action.astype(np.float64)
    if not np.array_equal(executed[:, 7], action[:, 7]):
        t = int(np.flatnonzero(executed[:, 7] != action[:, 7])[0])
        return [f"{where}: frame {t}: the executed gripper command {executed[t, 7]} is not the action's "
                f"{action[t, 7]} (only arm targets are perturbed)"]
    offset = np.abs(executed[:, :7] - action[:, :7]).max(axis=1)
    if amplitude is not None and offset.max() > amplitude + OFFSET_TOL:
        t = int(np.argmax(offset))
        return [f"{where}: frame {t}: the executed arm targets are {offset[t]:.4f} rad off the action, more "
                f"than the recorded amplitude {amplitude} rad"]
    act = robot.arm_actuator_ids(model)[:7]
    lo, hi = model.actuator_ctrlrange[act, 0], model.actuator_ctrlrange[act, 1]
    data = mujoco.MjData(model)
    for t in range(ep.length - 1):
        set_physics_state(model, data, ep.physics_state[t + 1])
        if not np.array_equal(data.ctrl[act], np.clip(executed[t, :7], lo, hi)):
            return [f"{where}: frame {t + 1}'s stored arm controls are not frame {t}'s executed command "
                    f"(off by {np.abs(data.ctrl[act] - np.clip(executed[t, :7], lo, hi)).max():.3g} rad): "
                    "the states were not stepped with it"]
    return []
