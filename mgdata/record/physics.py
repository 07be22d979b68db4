"""What makes a dataset self-contained: the compiled MuJoCo scene and the physics state of every frame.

Per base task the dataset stores the compiled model as MJB bytes (``meta/scenes/chunk-*/file-*.parquet``,
:mod:`mgdata.record.scenes`; MuJoCo's own binary format, exact and byte-deterministic across processes for
the same model and MuJoCo version); per frame it
stores the MuJoCo state (``sim.physics_state``, float64) from which that frame's observation was taken, in
the state layout :data:`STATE_SPEC`. Frame 0's state is the episode's initial state. With only ``mujoco``
and ``pyarrow`` anyone can restore any frame, re-render it or re-label it, and re-simulate: setting the state
of frame ``t``, applying action ``t`` and stepping one control period gives frame ``t + 1``'s state bit for
bit (see ``docs/dataset-format.md``).

Example::

    state = physics_state(scene.model, scene.data)          # float64 (state_size(model),)
    mjb = model_bytes(scene.model)                          # MJB; mujoco.MjModel.from_binary_path reads it
"""

from __future__ import annotations

import mujoco
import numpy as np

_S = mujoco.mjtState
STATE_SPEC: int = int(_S.mjSTATE_INTEGRATION) & ~int(_S.mjSTATE_QFRC_APPLIED | _S.mjSTATE_XFRC_APPLIED)
"""``mjSTATE_INTEGRATION`` (time, qpos, qvel, act, history, plugin state, ctrl, eq_active, mocap, userdata
and the solver warmstart) without the applied forces, which mgdata never sets (always zero: 6 values per
body would triple the size). The warmstart is what makes re-simulation bit-identical."""


def feature_info() -> dict[str, object]:
    """The ``info`` entry of the ``sim.physics_state`` feature in ``info.json``."""
    return {
        "mujoco_state_spec": STATE_SPEC, "mujoco_version": mujoco.__version__,
        "layout": "mujoco.mj_getState(model, data, state, mujoco_state_spec): the mjtState components in "
                  "MuJoCo's order (time, qpos, qvel, act, qacc_warmstart, ctrl, eq_active, mocap_pos, "
                  "mocap_quat, userdata, plugin state, history)",
        "scene": "the compiled model (MJB): the meta/scenes/chunk-*/file-*.parquet row (meta/scenes.parquet "
                 "in datasets written before chunked scenes) named by the episodes-table column mgdata/scene",
    }


def state_size(model: mujoco.MjModel) -> int:
    """Values per frame of :func:`physics_state` for ``model``."""
    return int(mujoco.mj_stateSize(model, STATE_SPEC))


def physics_state(model: mujoco.MjModel, data: mujoco.MjData) -> np.ndarray:
    """The current state in the :data:`STATE_SPEC` layout, float64 (``state_size(model)``,)."""
    out = np.empty(state_size(model), dtype=np.float64)
    mujoco.mj_getState(model, data, out, STATE_SPEC)
    return out


def set_physics_state(model: mujoco.MjModel, data: mujoco.MjData, state: np.ndarray) -> None:
    """Set a state saved by :func:`physics_state` and recompute positions and contacts (``mj_forward``)."""
    mujoco.mj_setState(model, data, np.ascontiguousarray(state, dtype=np.float64), STATE_SPEC)
    mujoco.mj_forward(model, data)


def model_bytes(model: mujoco.MjModel) -> bytes:
    """The compiled model as MJB bytes (``mujoco.mj_saveModel``)."""
    buf = np.empty(mujoco.mj_sizeModel(model), dtype=np.uint8)
    mujoco.mj_saveModel(model, None, buf)
    return buf.tobytes()


def model_from_bytes(mjb: bytes) -> mujoco.MjModel:
    """The model of MJB bytes (as :func:`model_bytes` or :meth:`mgdata.record.scenes.Scenes.mjb` give)."""
    return mujoco.MjModel.from_binary_path("scene.mjb", {"scene.mjb": mjb})
