"""Particle sets: liquid as free spheres in a container, dust as visual specks that wiping removes.

MuJoCo 4 has no particle composites, so each sphere is its own body.

* **Liquid** instance ``water`` (model ``liquid/…``): an anchor body ``water`` at the placement point and
  free bodies ``water/p000``… (geoms of the same names) packed in hexagonal layers into the cavity of the
  container whose cavity holds the placement point. The scene switches to CG + elliptic cone (see
  ``world.Physics``). ``spilled`` counts the spheres outside that cavity.
* **Dust** instance ``dust`` (model ``dust/…``): mocap bodies ``dust/d000``… carrying flat visual discs
  (no contacts) on a *host*: the object whose footprint holds the placement point (:func:`dust_host`), or
  the table. After every control step (:meth:`DustField.update`) each remaining speck is put back at its
  place in the host's frame (measured once the scene has settled), so dust moves and tilts with the plate
  or tray it lies on. A speck is wiped only by a ``sponge`` **in contact with its host**: when a sponge geom
  touches a host geom (a ``data.contact`` entry) and the speck lies inside that sponge geom (5 mm margin),
  it is parked far below the floor. Mocap positions are part of MuJoCo's integration state (and of the
  dataset's ``sim.physics_state``), so snapshots, resets, replay and determinism cover the dust too: the
  state width is fixed by the speck count, and a wiped speck is its parked height.
"""

from __future__ import annotations

from collections.abc import Mapping

import mujoco
import numpy as np

from mgdata.errors import SceneError
from mgdata.sim.assets import ObjectModel
from mgdata.sim.taskspec import TaskSpec

PARK_Z = -10.0
"""Height (m) where wiped dust specks are parked (far below the floor, out of every camera's view)."""
WIPE_MARGIN = 0.005
FILL_CLEARANCE = 0.0015
DUST_THICKNESS = 0.0008
WIPER_CATEGORY = "sponge"
LIQUID_SOLREF = (0.004, 1.0)
"""Contact time constant of liquid spheres: at MuJoCo's default 0.02 s a 10-sphere column squeezes the
bottom spheres into each other by a quarter of their diameter; 0.004 s (2 timesteps) keeps them apart."""
LIQUID_CONDIM = 1
"""Liquid spheres touch frictionlessly (normal force only), as a liquid's parcels do: with pyramidal or
elliptic friction each of the ~60 spheres' dozens of contacts adds 3–5 constraint rows, which made the
liquid scene step ~50× slower than the plain one. ``LIQUID_PRIORITY`` makes the sphere's ``condim`` win
in its contacts with the container, the table and the gripper too (MuJoCo takes the higher-priority geom's
contact parameters)."""
LIQUID_PRIORITY = 1


def particle_models(models: Mapping[str, ObjectModel]) -> dict[str, ObjectModel]:
    """The particle instances among ``models``."""
    return {name: m for name, m in models.items() if m.particles is not None}


def _yaw_rot(yaw: float) -> np.ndarray:
    c, s = np.cos(yaw), np.sin(yaw)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def _host(task: TaskSpec, models: Mapping[str, ObjectModel], name: str) -> tuple[str, np.ndarray]:
    """The container instance whose cavity holds the liquid's placement point, and that point locally."""
    point = np.asarray(task.object(name).pos, dtype=np.float64)
    for obj in task.objects:
        cavity = models[obj.name].cavity
        if cavity is None:
            continue
        local = _yaw_rot(obj.yaw).T @ (point - np.asarray(obj.pos))
        if cavity.contains(local[None, :], margin=1e-6, headroom=0.0)[0]:
            return obj.name, local
    raise SceneError(f"liquid {name!r} at {tuple(point)} is not inside any container's cavity")


def _pack(model: ObjectModel, host: ObjectModel, local: np.ndarray, name: str) -> np.ndarray:
    """Local (host-frame) centres of the liquid's spheres, hexagonally packed from the cavity floor up."""
    assert model.particles is not None and host.cavity is not None
    cav, r = host.cavity, model.particles.radius
    pitch = 2.0 * r + 0.0005
    z = max(cav.floor_z, local[2]) + r + 0.001
    centres: list[np.ndarray] = []
    layer = 0
    while len(centres) < model.particles.count:
        if z + r > cav.rim_z:
            raise SceneError(
                f"liquid {name!r} ({model.particles.count} spheres of {r * 1000:.1f} mm) does not fit in "
                f"{host.name}'s cavity (rim at {cav.rim_z:.3f} m); use fewer spheres or a larger container"
            )
        n = int(np.ceil(0.3 / pitch))
        i, j = np.meshgrid(np.arange(-n, n + 1), np.arange(-n, n + 1), indexing="ij")
        row = pitch * np.sqrt(3.0) / 2.0
        grid = np.column_stack([((i + 0.5 * (j % 2)) * pitch + 0.5 * pitch * (layer % 2)).ravel(),
                                (j * row + row / 3.0 * (layer % 2)).ravel()])
        pts = np.column_stack([grid, np.full(len(grid), z)])
        if cav.shape == "round":
            t = (z - cav.floor_z) / (cav.rim_z - cav.floor_z)
            rad = (cav.radius_floor + t * (cav.radius_rim - cav.radius_floor)) * np.cos(np.pi / 16)
            ok = np.hypot(pts[:, 0], pts[:, 1]) <= rad - r - FILL_CLEARANCE
        else:
            ok = (np.abs(pts[:, 0]) <= cav.half_x - r - FILL_CLEARANCE) & (
                np.abs(pts[:, 1]) <= cav.half_y - r - FILL_CLEARANCE)
        pts = pts[ok]
        pts = pts[np.lexsort((pts[:, 1], pts[:, 0], np.hypot(pts[:, 0], pts[:, 1]).round(9)))]
        centres.extend(pts[: model.particles.count - len(centres)])
        z += pitch
        layer += 1
    return np.array(centres)


def fill_top(model: ObjectModel, host: ObjectModel) -> float | None:
    """Height (m, host frame) of the top of liquid ``model`` poured into ``host``'s cavity from its floor, or
    None if it does not fit below the rim."""
    if model.particles is None or host.cavity is None:
        return None
    try:
        centres = _pack(model, host, np.array([0.0, 0.0, host.cavity.floor_z]), model.name)
    except SceneError:
        return None
    return float(centres[:, 2].max() + model.particles.radius)


def add_particles(spec: mujoco.MjSpec, task: TaskSpec, models: Mapping[str, ObjectModel],
                  particles: Mapping[str, ObjectModel]) -> None:
    """Add the bodies of every particle instance (see module docstring) to ``spec``."""
    for name, model in particles.items():
        p = model.particles
        assert p is not None
        placement = task.object(name)
        spec.worldbody.add_body(name=name, pos=list(placement.pos)).add_site(name=f"{name}/anchor", group=4)
        if p.kind == "liquid":
            host_name, local = _host(task, models, name)
            host = task.object(host_name)
            centres = _pack(model, models[host_name], local, name)
            world = centres @ _yaw_rot(host.yaw).T + np.asarray(host.pos)
            for i, c in enumerate(world):
                body = spec.worldbody.add_body(name=f"{name}/p{i:03d}", pos=c.tolist())
                body.add_freejoint(name=f"{name}/p{i:03d}/free")
                body.add_geom(name=f"{name}/p{i:03d}", type=mujoco.mjtGeom.mjGEOM_SPHERE,
                              size=[p.radius, 0.0, 0.0], mass=p.mass, rgba=list(model.rgba),
                              friction=[model.friction, 0.0, 0.0], group=0, solref=list(LIQUID_SOLREF),
                              condim=LIQUID_CONDIM, priority=LIQUID_PRIORITY)
        else:
            assert p.layout is not None
            xy = p.layout @ _yaw_rot(placement.yaw)[:2, :2].T + np.asarray(placement.pos[:2])
            for i, (x, y) in enumerate(xy):
                body = spec.worldbody.add_body(name=f"{name}/d{i:03d}", mocap=True,
                                               pos=[float(x), float(y), placement.pos[2] + DUST_THICKNESS])
                body.add_geom(name=f"{name}/d{i:03d}", type=mujoco.mjtGeom.mjGEOM_CYLINDER,
                              size=[p.radius, DUST_THICKNESS / 2.0, 0.0], rgba=list(model.rgba),
                              contype=0, conaffinity=0, group=2, mass=0.0)


class LiquidSet:
    """The spheres of one liquid instance: ``body_ids`` (count,)."""

    def __init__(self, model: mujoco.MjModel, name: str, count: int) -> None:
        self.name = name
        self.body_ids = np.array([model.body(f"{name}/p{i:03d}").id for i in range(count)], dtype=np.int32)

    def positions(self, data: mujoco.MjData) -> np.ndarray:
        return data.xpos[self.body_ids]


def dust_host(task: TaskSpec, models: Mapping[str, ObjectModel], name: str) -> str | None:
    """The instance dust ``name`` lies on: the first non-particle object whose bounding box footprint (at
    its placement) holds the dust's placement point, from 5 mm below its base to 1 cm above its top; None if
    it lies on the table."""
    point = np.asarray(task.object(name).pos, dtype=np.float64)
    for obj in task.objects:
        model = models[obj.name]
        if model.particles is not None:
            continue
        d = _yaw_rot(obj.yaw).T @ (point - np.asarray(obj.pos))
        sx, sy, sz = model.size
        if abs(d[0]) <= sx / 2 and abs(d[1]) <= sy / 2 and -0.005 <= d[2] <= sz + 0.01:
            return obj.name
    return None


class DustField:
    """The dust specks of every dust instance in a scene, their hosts and the sponge geoms that wipe them.

    Args:
        model: the compiled model.
        dust: dust instance -> speck count.
        wiper_geoms: the colliding geoms of every sponge.
        hosts: dust instance -> (host body id, boolean mask over geoms of the host's colliding geoms).
    """

    def __init__(self, model: mujoco.MjModel, dust: Mapping[str, int], wiper_geoms: np.ndarray,
                 hosts: Mapping[str, tuple[int, np.ndarray]] | None = None) -> None:
        self.mocap_ids = {
            name: np.array([model.body_mocapid[model.body(f"{name}/d{i:03d}").id] for i in range(n)],
                           dtype=np.int32)
            for name, n in dust.items()
        }
        self._all = np.concatenate(list(self.mocap_ids.values())) if dust else np.zeros(0, dtype=np.int32)
        self.wiper_geoms = np.asarray(wiper_geoms, dtype=np.int32)
        self._half = model.geom_aabb[self.wiper_geoms, 3:] + WIPE_MARGIN
        self._centre = model.geom_aabb[self.wiper_geoms, :3]
        world = np.zeros(model.ngeom, dtype=bool)
        self.hosts = {name: (hosts or {}).get(name, (0, world)) for name in self.mocap_ids}
        self._local: dict[str, np.ndarray] = {}

    def bind(self, data: mujoco.MjData) -> None:
        """Fix every speck's place in its host's frame from the current (settled) state."""
        for name, ids in self.mocap_ids.items():
            body = self.hosts[name][0]
            rot = data.xmat[body].reshape(3, 3)
            self._local[name] = (data.mocap_pos[ids] - data.xpos[body]) @ rot

    def follow(self, data: mujoco.MjData) -> None:
        """Put every remaining speck at its place on its host (the host's current pose)."""
        for name, ids in self.mocap_ids.items():
            if name not in self._local:
                continue
            body = self.hosts[name][0]
            live = data.mocap_pos[ids, 2] > PARK_Z / 2.0
            rot = data.xmat[body].reshape(3, 3)
            data.mocap_pos[ids[live]] = data.xpos[body] + self._local[name][live] @ rot.T
            data.mocap_quat[ids[live]] = data.xquat[body]

    def _touching(self, data: mujoco.MjData) -> np.ndarray:
        """(wipers, hosts) booleans: wiper geom k has a contact with dust instance j's host."""
        names = list(self.mocap_ids)
        out = np.zeros((len(self.wiper_geoms), len(names)), dtype=bool)
        n = data.ncon
        if n == 0:
            return out
        pairs = data.contact.geom[:n]
        for k, g in enumerate(self.wiper_geoms):
            other = np.concatenate([pairs[pairs[:, 0] == g, 1], pairs[pairs[:, 1] == g, 0]])
            for j, name in enumerate(names):
                out[k, j] = bool(self.hosts[name][1][other].any())
        return out

    def remaining_fraction(self, data: mujoco.MjData, name: str) -> float:
        """Fraction of ``name``'s specks not yet wiped."""
        ids = self.mocap_ids[name]
        return float(np.count_nonzero(data.mocap_pos[ids, 2] > PARK_Z / 2.0)) / len(ids)

    def update(self, data: mujoco.MjData) -> int:
        """Move the specks with their hosts, then park every speck covered by a wiper geom that touches the
        speck's host; returns how many were wiped. Reads ``data``'s positions and contacts (after
        ``mj_step``/``mj_forward``)."""
        if not len(self._all):
            return 0
        self.follow(data)
        if not len(self.wiper_geoms):
            return 0
        touching = self._touching(data)
        wiped = 0
        for j, ids in enumerate(self.mocap_ids.values()):
            pos = data.mocap_pos[ids]
            hit = np.zeros(len(ids), dtype=bool)
            for k in np.flatnonzero(touching[:, j]):
                g = self.wiper_geoms[k]
                local = (pos - data.geom_xpos[g]) @ data.geom_xmat[g].reshape(3, 3) - self._centre[k]
                hit |= np.all(np.abs(local) <= self._half[k], axis=1)
            gone = ids[hit & (pos[:, 2] > PARK_Z / 2.0)]
            data.mocap_pos[gone, 2] = PARK_Z
            wiped += len(gone)
        return wiped
