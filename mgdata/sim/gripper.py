"""GripperConfig: the Panda gripper's servo retuning and finger contact model (``recipes/sim.toml``
``[gripper]``); the robot model (:mod:`mgdata.sim.robot`) applies it.

Example::

    GripperConfig(closed_ctrl=-0.5).ctrl(1.0)   # the actuator control for "closed"
"""

from __future__ import annotations

from dataclasses import dataclass

from mgdata.errors import RecipeError


@dataclass(frozen=True)
class GripperConfig:
    """The gripper servo's retuning and the finger pads' contact model (``recipes/sim.toml`` ``[gripper]``).

    Attributes:
        open_ctrl: actuator control for "open": a target far beyond fully open (the fingers stop at their
            0.04 m limits); drives the tendon with ``50·open_ctrl`` N, like "closed" the other way.
        closed_ctrl: actuator control for "closed": the tendon servo ``50·ctrl − 100·length`` gives
            ``−140 − 100·length`` N, i.e. each finger presses what it holds with 70–72 N (Franka Hand: 70 N
            continuous grasp force; measured with ``mj_contactForce``, docs/sim.md).
        ctrl_range: the gripper actuator's control range; holds both commands.
        damping: velocity gain of the servo's bias (``biasprm[2] = -damping``): a free finger moves at
            ``50·|ctrl| / damping`` = 0.05 m/s (the hand's 0.1 m/s of opening width), so closing from fully
            open takes 0.8 s.
        finger_condim: contact dimension of the finger geoms: 3 sliding friction only, 4 adds torsional
            friction (6 rolling too).
        finger_torsional_friction: torsional friction coefficient of the finger pads (m).
        finger_solref: contact ``solref`` of the finger geoms (time constant s, damping ratio); the time
            constant must be at least two physics timesteps.
        finger_solimp: contact ``solimp`` of the finger geoms (dmin, dmax, width m): the impedance rises
            from dmin at contact to dmax at ``width`` of penetration (MuJoCo's default 0.9, 0.95, 0.001).
        finger_solmix: ``solmix`` weight of the finger geoms: a contact takes
            ``solmix / (solmix + other's solmix)`` of its ``solref`` from the fingers.
        peak_force: the most each finger can press (N; Franka Hand: 140 N peak). The actuator drives the
            ``split`` tendon, which hands each finger joint half its force, so its force range is
            ``±2·peak_force``. The "closed" command's own force (``closed_ctrl``) stays inside it: a clipped
            force loses the implicit integration of the servo's damping and the fingers chatter (±1.2 m/s).
    """

    open_ctrl: float = 2.8
    closed_ctrl: float = -2.8
    ctrl_range: tuple[float, float] = (-2.8, 2.8)
    damping: float = 2800.0
    finger_condim: int = 4
    finger_torsional_friction: float = 0.02
    finger_solref: tuple[float, float] = (0.004, 1.0)
    finger_solmix: float = 100.0
    finger_solimp: tuple[float, float, float] = (0.9, 0.95, 0.001)
    peak_force: float = 140.0

    def __post_init__(self) -> None:
        lo, hi = self.ctrl_range
        if not lo < hi:
            raise RecipeError(f"[gripper] ctrl_range = {list(self.ctrl_range)}: expected [low, high] with "
                              "low < high")
        for key in ("open_ctrl", "closed_ctrl"):
            if not lo <= getattr(self, key) <= hi:
                raise RecipeError(f"[gripper] {key} = {getattr(self, key)!r}: expected a value in ctrl_range "
                                  f"[{lo}, {hi}]")
        if not self.closed_ctrl < self.open_ctrl:
            raise RecipeError(f"[gripper] closed_ctrl = {self.closed_ctrl!r}: expected less than open_ctrl "
                              f"= {self.open_ctrl!r} (a lower control closes the fingers)")
        if self.damping < 0:
            raise RecipeError(f"[gripper] damping = {self.damping!r}: expected a number >= 0")
        if self.finger_condim not in (3, 4, 6):
            raise RecipeError(f"[gripper] finger_condim = {self.finger_condim!r}: expected 3, 4 or 6")
        if self.finger_torsional_friction < 0:
            raise RecipeError(f"[gripper] finger_torsional_friction = {self.finger_torsional_friction!r}: "
                              "expected a number >= 0")
        if not (self.finger_solref[0] > 0 and self.finger_solref[1] > 0):
            raise RecipeError(f"[gripper] finger_solref = {list(self.finger_solref)}: expected [time "
                              "constant s, damping ratio], both > 0")
        if not self.peak_force > 0:
            raise RecipeError(f"[gripper] peak_force = {self.peak_force!r}: expected a number > 0 (N)")
        dmin, dmax, width = self.finger_solimp
        if not (0 < dmin <= dmax < 1 and width > 0):
            raise RecipeError(f"[gripper] finger_solimp = {list(self.finger_solimp)}: expected "
                              "[dmin, dmax, width] with 0 < dmin <= dmax < 1 and width > 0")
        if not self.finger_solmix > 0:
            raise RecipeError(f"[gripper] finger_solmix = {self.finger_solmix!r}: expected a number > 0")

    def ctrl(self, command: float) -> float:
        """Map a gripper command (0 open … 1 closed, clipped) to the gripper actuator's control value."""
        c = min(max(float(command), 0.0), 1.0)
        return self.open_ctrl + c * (self.closed_ctrl - self.open_ctrl)

    def is_closed(self, ctrl: float) -> bool:
        """Whether an actuator control value is nearer "closed" than "open"."""
        return ctrl < (self.open_ctrl + self.closed_ctrl) / 2.0
