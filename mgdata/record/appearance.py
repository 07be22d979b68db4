"""An episode's appearance draw from its stored frames: the draw of :mod:`mgdata.sim.appearance_draw` for the
scene, seeded from the episode's recorded ``seed``, ``task_id`` and ``draw_index``, with distractors kept
clear of everything that moves in those frames (the arm, the objects it carries). Generation (draw
``k = 0``) and
``mgdata render --appearance K`` (``k = 0 … K-1``) both come here, so they draw the same.

Example::

    draw = episode_appearance(recipe.appearance, model, states, meta, k=0)
    rig.set_appearance(draw)
"""

from __future__ import annotations

from collections.abc import Sequence

import mujoco
import numpy as np

from mgdata.record.episode import EpisodeMeta
from mgdata.record.physics import set_physics_state
from mgdata.sim.appearance_draw import (
    AppearanceDraw,
    AppearanceSettings,
    draw_appearance,
    episode_seed,
    moving_spheres,
)

SWEEP_EVERY = 2
"""Every this many frames count for the arm's sweep (20 Hz: 10 per second; the hand moves < 2 cm between)."""


def episode_appearance(settings: AppearanceSettings, model: mujoco.MjModel, states: Sequence[np.ndarray],
                       meta: EpisodeMeta, k: int = 0, extra: int = 0) -> AppearanceDraw:
    """Draw ``k`` for the episode whose per-frame physics states are ``states`` (``extra``: a user seed)."""
    data = mujoco.MjData(model)
    sweep = []
    for state in states[::SWEEP_EVERY]:
        set_physics_state(model, data, state)
        sweep.append(moving_spheres(model, data))
    set_physics_state(model, data, states[0])
    seed = episode_seed(meta.seed, meta.task_id, meta.draw_index, k, extra)
    return draw_appearance(settings, model, data, seed,
                           k, np.concatenate(sweep) if sweep else None)
