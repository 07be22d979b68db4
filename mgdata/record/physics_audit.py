"""The physics audit: what the gate promised about motion and contact, checked from the stored states alone.

A ``generate`` dataset records the gate's physical bounds in ``info.json`` (``mgdata.physics_gate``,
:class:`PhysicsGate`): the rest speeds and the instances they apply to, and the deepest contact overlap a
kept episode may show. :class:`PhysicsAuditor` restores every frame of an episode from its stored scene
(MJB) and physics state, with raw MuJoCo only, and checks:

* **penetration**: the deepest ``-contact.dist`` over the frames equals the episode's recorded
  ``max_penetration`` (within ``DEPTH_TOL``), and a kept episode's is within the bound;
* **at rest**: on a successful episode's last ``hold_steps`` frames, each rest subject moves at
  most ``rest_linear_speed`` × control period between consecutive frames (its centre of mass), and turns
  at most
  ``rest_angular_speed`` × period. The gate bounds the speed at every physics substep and MuJoCo integrates
  positions from those very speeds, so a demo that passed the gate moves less than that; a body rocking
  between control samples does not.

Example::

    auditor = PhysicsAuditor(gate, hold_steps=10, fps=20)
    problems = auditor.audit(episode, model)     # episode: reader.episode(i); model: its scene
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from dataclasses import asdict, dataclass
from typing import Any

import mujoco
import numpy as np

from mgdata.errors import DatasetError
from mgdata.record.physics import set_physics_state
from mgdata.record.reader import EpisodeData
from mgdata.sim.penetration import NONE, deepest_contact

DEPTH_TOL = 1e-6
"""m: the recomputed deepest overlap may differ from the recorded one by this much (another CPU's floating
point); far below the bounds' millimetres."""
MOTION_TOL = 1e-7
"""m (and rad): slack on the rest audit's displacement bound, for float rounding and the second-order
difference between a turning body's sampled and integrated centre of mass (< 1e-9 m at the rest speeds)."""


@dataclass(frozen=True)
class PhysicsGate:
    """The gate's physical bounds, as ``info.json`` ``mgdata.physics_gate`` stores them.

    Attributes:
        rest_linear_speed, rest_angular_speed: the recipe's rest speeds (m/s, rad/s).
        rest_subjects: the instances (names or prefix globs ``obstacle_*``) that must be at rest.
        max_penetration: the deepest contact overlap of a kept episode (m).
    """

    rest_linear_speed: float
    rest_angular_speed: float
    rest_subjects: tuple[str, ...]
    max_penetration: float

    def to_info(self) -> dict[str, Any]:
        return {**asdict(self), "rest_subjects": list(self.rest_subjects)}

    @classmethod
    def from_info(cls, info: Mapping[str, Any], where: str) -> PhysicsGate | None:
        """The block of ``info.json`` (``None``: the dataset records none, e.g. a teleop or older one)."""
        raw = info.get("mgdata", {}).get("physics_gate")
        if raw is None:
            return None
        try:
            gate = cls(float(raw["rest_linear_speed"]), float(raw["rest_angular_speed"]),
                       tuple(str(s) for s in raw["rest_subjects"]), float(raw["max_penetration"]))
        except (KeyError, TypeError, ValueError) as err:
            raise DatasetError(f"{where}: malformed mgdata.physics_gate {raw!r} ({err})") from None
        return gate


def _subject_bodies(model: mujoco.MjModel, subjects: tuple[str, ...]) -> list[int]:
    """Top-level bodies named by ``subjects`` (exact names, or prefixes for ``name*``)."""
    ids = []
    for b in range(1, model.nbody):
        if model.body_parentid[b] != 0:
            continue
        name = model.body(b).name
        if any(name == s or (s.endswith("*") and name.startswith(s[:-1])) for s in subjects):
            ids.append(b)
    return ids


def _turn(q0: np.ndarray, q1: np.ndarray) -> np.ndarray:
    """Rotation angle (rad) between unit quaternions, row-wise."""
    dot = np.abs(np.einsum("ij,ij->i", q0, q1))
    return 2.0 * np.arccos(np.clip(dot, -1.0, 1.0))


class PhysicsAuditor:
    """Audits episodes' stored states against a :class:`PhysicsGate` (see the module docstring)."""

    def __init__(self, gate: PhysicsGate, *, hold_steps: int | None, fps: int) -> None:
        self.gate = gate
        self.hold_steps = hold_steps or 1
        self.period = 1.0 / fps

    def audit(self, ep: EpisodeData, model: mujoco.MjModel) -> list[str]:
        """Problems with episode ``ep`` run in ``model`` (none if its states keep the gate's bounds)."""
        if ep.physics_state is None:
            return []
        where = f"episode {ep.index}"
        data = mujoco.MjData(model)
        deepest = NONE
        bodies = _subject_bodies(model, self.gate.rest_subjects)
        hold_from = ep.length - self.hold_steps if ep.meta.success else ep.length
        poses: list[tuple[np.ndarray, np.ndarray]] = []
        for t in range(ep.length):
            set_physics_state(model, data, ep.physics_state[t])
            p = deepest_contact(model, data)
            if p.depth > deepest.depth:
                deepest = dataclasses.replace(p, step=t)
            if t >= hold_from - 1 and bodies:
                poses.append((data.xipos[bodies].copy(), data.xquat[bodies].copy()))
        problems = []
        recorded = ep.meta.max_penetration
        if recorded is not None and abs(recorded - deepest.depth) > DEPTH_TOL:
            problems.append(f"{where}: mgdata/max_penetration is {recorded * 1000:.3f} mm, its states' "
                            f"deepest contact is {deepest.depth * 1000:.3f} mm ({deepest.bodies}, frame "
                            f"{deepest.step})")
        if ep.meta.kept and deepest.depth > self.gate.max_penetration + DEPTH_TOL:
            problems.append(f"{where}: kept, but {deepest.body1} and {deepest.body2} overlap by "
                            f"{deepest.depth * 1000:.2f} mm at frame {deepest.step} (max_penetration "
                            f"{self.gate.max_penetration * 1000:.2f} mm)")
        if ep.meta.success and len(poses) > 1:
            problems += self._rest(where, poses, ep.length - len(poses), model, bodies)
        return problems

    def _rest(self, where: str, poses: list[tuple[np.ndarray, np.ndarray]], first: int,
              model: mujoco.MjModel, bodies: list[int]) -> list[str]:
        g = self.gate
        max_move = g.rest_linear_speed * self.period + MOTION_TOL
        max_turn = g.rest_angular_speed * self.period + MOTION_TOL
        for k in range(1, len(poses)):
            (x0, q0), (x1, q1) = poses[k - 1], poses[k]
            move = np.linalg.norm(x1 - x0, axis=1)
            turn = _turn(q0, q1)
            for i, b in enumerate(bodies):
                if move[i] > max_move or turn[i] > max_turn:
                    return [f"{where}: not at rest in its hold: {model.body(b).name} moves "
                            f"{move[i] * 1000:.3f} mm and turns {np.rad2deg(turn[i]):.3f} deg from frame "
                            f"{first + k - 1} to {first + k} ({move[i] / self.period:.4f} m/s, "
                            f"{turn[i] / self.period:.4f} rad/s; rest is {g.rest_linear_speed} m/s, "
                            f"{g.rest_angular_speed} rad/s)"]
        return []
