"""Recovery perturbations: smooth, bounded, seeded offsets on a planned segment's joint targets.

``dart`` (:meth:`Perturbation.segment`): executing a planned segment of ``n`` control steps, step ``k``
(``s = (k + 1) / n``) commands the plan's target plus

    δ(s) = A/2 · (u · sin²(πs) + v · sin(πs) · sin(2πs)),   u, v ~ U[-1, 1]⁷ per segment,

so ``|δ_j| ≤ A`` (the recipe's ``[recovery] amplitude``), the offset and its rate start and end at zero
(the arm leaves the path and comes back within the segment, and every segment starts and ends on the plan:
grasps close and objects are released where the planner put them), and ``u``, ``v`` come from the attempt's
variation (``rng("perturb/<i>/<segment>")``): the draws are recorded per episode and reproduce from its
seed. The recorded ``action`` stays the plan's target (the label: the motion back to the path); the
executed command is stored beside it.

``replan`` (:meth:`Perturbation.push`): one push per segment, ``A · u · sin²(π/2 · j / m)`` over ``m =
push_steps`` steps from a drawn step on (labelled with the plan's targets too), after which the executor plans
the rest of the segment again from the pushed configuration (:mod:`mgdata.engine.executor`).

Example::

    pert = Perturbation(recipe.recovery)
    offsets = pert.segment(3, "approach", var.rng("perturb/3/approach"), steps=40, start=112)  # (40, 7)
    pert.as_meta()   # {"mode": "dart", "amplitude": 0.03, "push_steps": 10, "segments": [...]}
"""

from __future__ import annotations

from typing import Any

import numpy as np

from mgdata.tasks.recovery import RecoverySettings


def offset_profile(u: np.ndarray, v: np.ndarray, amplitude: float, steps: int) -> np.ndarray:
    """δ at ``s = 1/steps … 1`` (``steps`` × 7): the formula of the module docstring."""
    s = np.arange(1, steps + 1, dtype=np.float64) / steps
    bump, wave = np.sin(np.pi * s) ** 2, np.sin(np.pi * s) * np.sin(2 * np.pi * s)
    return 0.5 * amplitude * (bump[:, None] * u[None, :] + wave[:, None] * v[None, :])


class Perturbation:
    """The offsets of one attempt's planned segments, and the record of their draws."""

    def __init__(self, settings: RecoverySettings) -> None:
        self.settings = settings
        self.draws: list[dict[str, Any]] = []

    def reset(self) -> None:
        """A new attempt: forget the previous one's draws."""
        self.draws = []

    def segment(self, index: int, name: str, rng: np.random.Generator, steps: int, start: int) -> np.ndarray:
        """Offsets (``steps`` × 7, rad) for the ``steps`` targets of segment ``index`` (``name``), whose
        first one is the episode's action ``start``."""
        u, v = rng.uniform(-1.0, 1.0, 7), rng.uniform(-1.0, 1.0, 7)
        self.draws.append({"segment": name, "index": index, "start": start, "steps": steps, "u": u.tolist(),
                           "v": v.tolist()})
        return offset_profile(u, v, self.settings.amplitude, steps)

    def push(self, index: int, name: str, rng: np.random.Generator, steps: int, start: int
             ) -> tuple[int, np.ndarray]:
        """The replan push of a segment of ``steps`` targets (the first is action ``start``): the target
        ``k0`` it starts at (drawn in ``[steps // 5, steps - 2 · push_steps]``) and its offsets
        (``push_steps`` × 7: ``A · u · sin²(π/2 · j / push_steps)``, ``j = 1 … push_steps``, so the push
        ends at ``A · u``)."""
        m = self.settings.push_steps
        k0 = int(rng.integers(steps // 5, steps - 2 * m + 1))
        u = rng.uniform(-1.0, 1.0, 7)
        self.draws.append({"segment": name, "index": index, "start": start + k0, "steps": m, "u": u.tolist()})
        ramp = np.sin(0.5 * np.pi * np.arange(1, m + 1) / m) ** 2
        return k0, self.settings.amplitude * ramp[:, None] * u[None, :]

    def replanned(self, steps: int) -> None:
        """The last push's segment was planned again: ``steps`` targets from the pushed configuration."""
        self.draws[-1]["replanned_steps"] = steps

    def as_meta(self) -> dict[str, Any]:
        """The episode's ``variation["perturbation"]``."""
        return {**self.settings.to_info(), "segments": list(self.draws)}
