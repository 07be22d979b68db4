"""``observation.environment_state`` for an existing dataset, derived from its stored physics states.

Every frame stores the MuJoCo state its observation was taken from (``sim.physics_state``) and every episode
names its compiled scene (:mod:`mgdata.record.scenes`), so the environment state
(:mod:`mgdata.sim.environment_state`) of each frame is recomputed exactly: the state is set
(``mj_setState``), positions are recomputed (``mj_kinematics``) and the layout of the episode's scene is read.
Used by ``mgdata export DATASET OUT --format state`` (a camera-free LeRobot v3.0 view for state-only
training) and ``--add environment_state`` (the feature added to another v3.0 view, e.g. ``smolvla``).

Example::

    env = EnvironmentStates(DatasetReader(Path("datasets/jar")))
    table = env.add_to_data(read_parquet(path))     # + the column, after observation.state
"""

from __future__ import annotations

import mujoco
import numpy as np
import pyarrow as pa

from mgdata.errors import DatasetError
from mgdata.record import layout
from mgdata.record.physics import model_from_bytes
from mgdata.record.reader import DatasetReader
from mgdata.record.stats import STAT_KEYS, FeatureStats, merge_stats, numeric_stats
from mgdata.sim.environment_state import FEATURE, EnvironmentLayout, feature_info


class EnvironmentStates:
    """Environment states of a dataset's frames, their per-episode and dataset stats and the feature entry.

    Raises:
        DatasetError: the dataset stores no physics states, or its scenes have different layouts.
    """

    def __init__(self, reader: DatasetReader) -> None:
        if reader.physics_spec is None:
            raise DatasetError(f"{reader.root}: stores no physics states; the environment state is derived "
                               "from them (generate the dataset with mgdata generate)")
        self.reader = reader
        self._spec = int(reader.physics_spec)
        self._models: dict[str, tuple[mujoco.MjModel, mujoco.MjData, EnvironmentLayout]] = {}
        self.episode_stats: dict[int, FeatureStats] = {}
        self.names: tuple[str, ...] | None = None
        self.instances: tuple[str, ...] = ()

    def _model(self, episode: int) -> tuple[mujoco.MjModel, mujoco.MjData, EnvironmentLayout]:
        scene = self.reader.record(episode).scene
        assert scene is not None
        if scene not in self._models:
            model = model_from_bytes(self.reader.scenes().mjb(scene))
            env = EnvironmentLayout(model)
            if self.names is None:
                self.names, self.instances = env.names, env.instances
            elif env.names != self.names:
                raise DatasetError(f"{self.reader.root}: scene {scene} has environment-state layout "
                                   f"{list(env.names)}, an earlier scene {list(self.names)}; one dataset "
                                   "needs "
                                   "one layout")
            self._models[scene] = (model, mujoco.MjData(model), env)
        return self._models[scene]

    def episode_values(self, episode: int, states: np.ndarray) -> np.ndarray:
        """(T, width) float32 environment states of episode ``episode`` from its (T, n) physics states."""
        model, data, env = self._model(episode)
        out = np.empty((len(states), len(env)), np.float32)
        for t, state in enumerate(np.ascontiguousarray(states, dtype=np.float64)):
            mujoco.mj_setState(model, data, state, self._spec)
            mujoco.mj_kinematics(model, data)
            out[t] = env.compute(model, data)
        return out

    def add_to_data(self, table: pa.Table) -> pa.Table:
        """A data file's table with the column inserted after ``observation.state`` (episode stats kept)."""
        episodes = table.column("episode_index").to_numpy()
        physics = table.column(layout.PHYSICS_STATE)
        flat = physics.combine_chunks().flatten().to_numpy(zero_copy_only=False)
        states = flat.reshape(table.num_rows, -1)
        parts: list[np.ndarray] = []
        for e in dict.fromkeys(episodes.tolist()):
            rows = np.flatnonzero(episodes == e)
            values = self.episode_values(int(e), states[rows])
            self.episode_stats[int(e)] = numeric_stats(values)
            parts.append(values)
        values = np.concatenate(parts) if parts else np.zeros((0, len(self.names or ())), np.float32)
        width = values.shape[1]
        column = pa.FixedSizeListArray.from_arrays(pa.array(values.reshape(-1), pa.float32()), width)
        at = table.column_names.index(layout.STATE) + 1
        return table.add_column(at, FEATURE, column)

    def add_to_episodes(self, table: pa.Table) -> pa.Table:
        """An episodes table with ``stats/observation.environment_state/<stat>`` columns."""
        rows = [self.episode_stats[int(e)] for e in table.column("episode_index").to_numpy()]
        for stat in STAT_KEYS:
            kind = pa.list_(pa.int64()) if stat == "count" else pa.list_(pa.float64())
            table = table.append_column(f"stats/{FEATURE}/{stat}",
                                        pa.array([r[stat].tolist() for r in rows], kind))
        return table

    def dataset_stats(self) -> FeatureStats:
        """Dataset stats, merged over the episodes in episode order (as the writer merges every feature)."""
        total: FeatureStats | None = None
        for e in sorted(self.episode_stats):
            total = merge_stats(total, self.episode_stats[e])
        assert total is not None
        return total

    def feature(self) -> dict[str, object]:
        """The feature's ``info.json`` entry."""
        names = list(self.names or ())
        model_env = next(iter(self._models.values()))[2]
        return {"dtype": "float32", "shape": [len(names)], "names": names, "info": feature_info(model_env)}
