"""The ``[recovery]`` table: demonstrations that show a policy how to come back to its path.

A planner's demonstration never leaves its path, so a policy that drifts a centimetre is in states no
demonstration covers. Two mechanisms put such states, and the way back, into the data
(:mod:`mgdata.engine.perturbation` draws the offsets; docs/train.md measures what each teaches):

* ``mode = "dart"`` (DART, Laskey et al. 2017): every planned motion segment is executed with a smooth,
  bounded, seeded offset added to its joint targets, while the recorded ``action`` stays the plan's target:
  each perturbed state is labelled with the motion back to the path.
* ``mode = "replan"`` (perturb and replan): in every planned segment long enough, at a drawn step the arm's
  targets are pushed off the plan over ``push_steps`` control steps (labelled, as in DART, with the plan's
  targets), and the rest of the segment is planned again from where the arm was pushed: the recovery
  motion itself is the demonstration.

Either way the executed command is stored too (``sim.executed_action``), so the physics replays exactly.

Keys (all optional; a recipe without the table has recovery off, and its datasets keep their bytes)::

    [recovery]
    mode = "dart"        # "off" (default), "dart" or "replan"
    amplitude = 0.03     # rad: the largest offset of any arm joint target (default 0.03: up to ~2 cm at
                         # the hand)
    push_steps = 10      # replan: control steps the push takes (default 10, 0.5 s)

``mgdata generate --recovery dart`` sets the mode for one run without editing the recipe.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

from mgdata.errors import DatasetError, RecipeError

MODES: tuple[str, ...] = ("off", "dart", "replan")
MAX_AMPLITUDE = 0.2
"""rad: the largest offset a recipe may ask for (beyond it the "recovery" is a different motion)."""


@dataclass(frozen=True)
class RecoverySettings:
    """``mode``: ``"off"``, ``"dart"`` or ``"replan"``; ``amplitude``: the offset's bound per arm joint
    (rad); ``push_steps``: the replan push's length (control steps)."""

    mode: str = "off"
    amplitude: float = 0.03
    push_steps: int = 10

    @property
    def perturbs(self) -> bool:
        """Whether executed commands differ from the recorded actions."""
        return self.mode != "off"

    def to_info(self) -> dict[str, Any]:
        """``info.json`` ``mgdata.recovery`` (written only when :attr:`perturbs`)."""
        return {"mode": self.mode, "amplitude": self.amplitude, "push_steps": self.push_steps}


def parse_recovery(table: Mapping[str, Any], where: str) -> RecoverySettings:
    """Check ``[recovery]``; every problem is a RecipeError naming the key."""
    known = {"mode", "amplitude", "push_steps"}
    if set(table) - known:
        raise RecipeError(f"{where} unknown key(s) {sorted(set(table) - known)}; expected {sorted(known)}")
    mode = table.get("mode", "off")
    if mode not in MODES:
        raise RecipeError(f"{where} mode = {mode!r}: expected one of {list(MODES)}")
    amplitude = table.get("amplitude", RecoverySettings.amplitude)
    if isinstance(amplitude, bool) or not isinstance(amplitude, int | float) or not math.isfinite(amplitude) \
            or not 0 < amplitude <= MAX_AMPLITUDE:
        raise RecipeError(f"{where} amplitude = {amplitude!r}: expected radians in (0, {MAX_AMPLITUDE}]")
    push = table.get("push_steps", RecoverySettings.push_steps)
    if isinstance(push, bool) or not isinstance(push, int) or not 1 <= push <= 100:
        raise RecipeError(f"{where} push_steps = {push!r}: expected an integer in [1, 100] (control steps)")
    return RecoverySettings(str(mode), float(amplitude), push)


def recovery_from_info(info: Mapping[str, Any], where: str) -> RecoverySettings | None:
    """The ``mgdata.recovery`` block of a dataset's ``info.json`` (``None``: its demos were not perturbed)."""
    raw = info.get("mgdata", {}).get("recovery")
    if raw is None:
        return None
    try:
        return parse_recovery(raw, f"{where}: mgdata.recovery")
    except (RecipeError, AttributeError, TypeError) as err:
        raise DatasetError(f"{where}: malformed mgdata.recovery {raw!r} ({err})") from None
