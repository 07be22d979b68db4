"""``observation.environment_state``: the task's objects, goal and articulations as one float32 vector.

LeRobot's convention for privileged simulator state, read by low-dimensional policies (a state-only ACT
trains on a CPU). The layout is derived from the compiled model alone (so it can be recomputed from a
dataset's stored scene and ``sim.physics_state`` without the recipe) and is fixed per scene:

* the **instances**: every body that is a child of the world, is not part of the robot, the ``table`` or the
  ``goal`` and has a joint, body or geom named ``<body>/…`` (the scene builder names an instance's parts so).
  In model order: the
  task's objects in the recipe's role order, then particle instances (liquids, dust) in the same order.
  Per instance, in this order:

  - a rigid object: ``<name>.pos.{x,y,z}`` (m) and ``<name>.quat.{w,x,y,z}`` of its root body, in the
    **robot base frame** (the quaternion's sign made ``w >= 0``);
  - a liquid (bodies ``<name>/pNNN``): ``<name>.centroid.{x,y,z}`` of its spheres, base frame;
  - dust (mocap bodies ``<name>/dNNN``): ``<name>.left``, the fraction of specks not yet wiped;
  - then each hinge or slide joint of the instance (``<name>/<joint>``, model order): ``<name>.<joint>``,
    the joint's value (rad or m): the lid hinge, a drawer's slide …

* the **goal** region, if the scene has a ``goal`` body: ``goal.{x,y,z}`` (base frame) and ``goal.radius``.

Example::

    layout = EnvironmentLayout(model)
    layout.names                          # ('jar.pos.x', …, 'jar.quat.z', 'jar.lid_hinge', …, 'goal.radius')
    vec = layout.compute(model, data)     # float32 (len(layout.names),), after mj_kinematics / mj_forward
"""

from __future__ import annotations

import mujoco
import numpy as np

from mgdata.sim import robot

FEATURE = "observation.environment_state"
GOAL_BODY = "goal"
PARK_HALF_Z = -5.0
"""Dust specks below this height (m) are parked, i.e. wiped (``mgdata.sim.particles.PARK_Z`` / 2)."""

_ARTICULATED = (int(mujoco.mjtJoint.mjJNT_HINGE), int(mujoco.mjtJoint.mjJNT_SLIDE))
NOT_INSTANCES = ("table", "goal")
"""World bodies that are never a task object: the table and the goal region (listed apart)."""
_POSE = ("pos.x", "pos.y", "pos.z", "quat.w", "quat.x", "quat.y", "quat.z")


def _prefixed(model: mujoco.MjModel, kind: mujoco.mjtObj, count: int, prefix: str) -> list[int]:
    return [i for i in range(count) if (mujoco.mj_id2name(model, kind, i) or "").startswith(prefix)]


class EnvironmentLayout:
    """The environment-state layout of one compiled model (see the module docstring).

    Attributes:
        names: the feature's names, one per value.
        instances: the instance names, in layout order.
    """

    def __init__(self, model: mujoco.MjModel) -> None:
        robot_bodies = set(robot.robot_body_ids(model).tolist())
        self._base = model.body(robot.ROOT_BODY).id
        names: list[str] = []
        self._parts: list[tuple[str, object]] = []
        instances: list[str] = []
        obj = mujoco.mjtObj
        for b in range(1, model.nbody):
            name = model.body(b).name
            if (model.body_parentid[b] != 0 or b in robot_bodies or not name or "/" in name
                    or name in NOT_INSTANCES):
                continue
            prefix = f"{name}/"
            bodies = _prefixed(model, obj.mjOBJ_BODY, model.nbody, prefix)
            joints = _prefixed(model, obj.mjOBJ_JOINT, model.njnt, prefix)
            geoms = _prefixed(model, obj.mjOBJ_GEOM, model.ngeom, prefix)
            if not (bodies or joints or geoms):
                continue
            instances.append(name)
            particles = [i for i in bodies if model.body(i).name[len(prefix):][:1] in "pd"
                         and model.body(i).name[len(prefix) + 1:].isdigit()]
            if particles and model.body_mocapid[particles[0]] >= 0:
                self._parts.append(("dust", np.array([model.body_mocapid[i] for i in particles])))
                names.append(f"{name}.left")
            elif particles:
                self._parts.append(("liquid", np.array(particles)))
                names += [f"{name}.centroid.{a}" for a in "xyz"]
            else:
                self._parts.append(("pose", b))
                names += [f"{name}.{p}" for p in _POSE]
            for j in joints:
                if int(model.jnt_type[j]) in _ARTICULATED:
                    self._parts.append(("joint", int(model.jnt_qposadr[j])))
                    names.append(f"{name}.{model.joint(j).name[len(prefix):]}")
        goal = mujoco.mj_name2id(model, obj.mjOBJ_BODY, GOAL_BODY)
        if goal >= 0:
            gid = mujoco.mj_name2id(model, obj.mjOBJ_GEOM, GOAL_BODY)
            radius = float(model.geom_size[gid, 0]) if gid >= 0 else 0.0
            self._parts.append(("goal", (goal, radius)))
            names += ["goal.x", "goal.y", "goal.z", "goal.radius"]
        self.names: tuple[str, ...] = tuple(names)
        self.instances: tuple[str, ...] = tuple(instances)

    def __len__(self) -> int:
        return len(self.names)

    def compute(self, model: mujoco.MjModel, data: mujoco.MjData) -> np.ndarray:
        """The vector of ``data``'s current state (positions must be current: call after ``mj_forward`` or
        ``mj_kinematics``), float32 (``len(self)``,)."""
        origin = data.xpos[self._base]
        rot = data.xmat[self._base].reshape(3, 3)
        inv = np.empty(4)
        mujoco.mju_negQuat(inv, data.xquat[self._base])
        out: list[float] = []
        for kind, ref in self._parts:
            if kind == "pose":
                b = int(ref)  # type: ignore[call-overload]
                q = np.empty(4)
                mujoco.mju_mulQuat(q, inv, data.xquat[b])
                q = -q if q[0] < 0 else q
                out += [*((data.xpos[b] - origin) @ rot), *q]
            elif kind == "liquid":
                out += [*((data.xpos[ref].mean(axis=0) - origin) @ rot)]
            elif kind == "dust":
                ids = np.asarray(ref)
                out.append(float(np.mean(data.mocap_pos[ids, 2] > PARK_HALF_Z)))
            elif kind == "joint":
                out.append(float(data.qpos[int(ref)]))  # type: ignore[call-overload]
            else:
                goal, radius = ref  # type: ignore[misc]
                out += [*((data.xpos[goal] - origin) @ rot), radius]
        return np.asarray(out, dtype=np.float32)


def feature_info(layout: EnvironmentLayout) -> dict[str, object]:
    """The ``info`` entry of the feature in ``info.json``."""
    return {"frame": "robot base (body 'base'); quaternions w, x, y, z with w >= 0; m, rad",
            "instances": list(layout.instances),
            "layout": "docs/dataset-format.md#environment-state"}
