"""The predicate registry: evaluators of atomic propositions over a scene's MuJoCo state.

Each evaluator is compiled once per (subject, params) into a closure over precomputed ids, then called every
control step with a :class:`Contacts` view of the current contacts. Names, parameters and defaults are
declared once, in ``mgdata.spec.EVALUATORS``; this module implements exactly those. Definitions, thresholds
and the measurements behind them: ``docs/predicates.md``. In short:

* ``dropped(floor_margin=0.05)``: the lowest point of the object's collision geometry is below floor + margin;
* ``upright(max_tilt_deg)``: the object's +Z axis is within ``max_tilt_deg`` of world +Z;
* ``on(support, gap_tol=0.0005)``: the support pushes the object up through a contact (normal ≤ 45° from +Z,
  from the support into the object), or the object is at most ``gap_tol`` above it: for the table or floor
  its lowest point within ``gap_tol`` of the top face over it, for objects or the robot a pair of geoms at
  most ``gap_tol`` apart with the object's side above (≤ 45° from +Z). A sub-millimetre hop stays "on";
* ``seated(support, max_offset=0.004, max_gap=0.003, max_tilt_deg=8)``: a loose lid rests in its
  container's seat: in the container's frame the lid's origin is at most ``max_offset`` sideways from the
  axis and within ``max_gap`` of the seat height (the container model's ``geometry["seat_height"]``), the two
  axes are within ``max_tilt_deg``, and the two touch (a MuJoCo contact);
* ``open(min_fraction=0.5)`` / ``closed(max_fraction=0.05)``: articulation fraction ≥ min / ≤ max;
* ``touching(other, gap_tol=0.0)``: a contact between the two, or a gap of at most ``gap_tol``;
* ``spilled(container, max_fraction=0.15)``: more than ``max_fraction`` of a liquid's spheres are outside
  the ``container``'s cavity (5 mm sideways margin, 3 cm headroom above the rim);
* ``in_region(region="goal", mode="centre", min_fraction=0.5)``: the centre of the object's bounding box
  (world frame, rotation included) is inside the region sphere; ``contained``: all 8 corners are;
  ``fraction``: at least ``min_fraction`` of a fixed 8×8×8 grid of cell centres over the box is;
* ``held(gap_tol=0.0005, max_speed=0.02, max_angular_speed=0.3)``: a stable grasp: both fingers touch the
  object (or are within ``gap_tol``); nothing but the fingers pushes it up (a contact from anything else
  with the normal ≤ 45° from +Z into the object; objects riding on or in it press it down and do not count),
  nor does it stand within ``gap_tol`` of the table or floor; and it moves relative to the hand at most
  ``max_speed`` (m/s, at its bounding-box centre) and ``max_angular_speed`` (rad/s);
* ``covered(min_fraction=0.0)``: more than ``min_fraction`` of the dust specks on the object remain (the
  subject is the dusty object, e.g. a plate, whose footprint held the dust patches at build time; or a dust
  instance itself); ``clean(max_fraction=0.0)``: its complement (at most that fraction remains);
* ``inside(container, mode="contained", margin=0.005, headroom=0.0)``: the object is in the container's
  interior, in the frame that holds it (so it follows a drawer, or a tilted container): a drawer's inner box
  (geometry ``drawer_inner``, in the frame of the drawer link) or an open container's cavity
  (``Cavity.contains``). ``mode="contained"``: all 8 corners of the object's geom bounding box, at most
  ``margin`` outside sideways/below and ``headroom`` above the rim; ``mode="centre"``: the box's centre only;
* ``near_start(max_distance)``: the object's origin is less than ``max_distance`` from its placement.

``support``/``other`` name an instance, a prefix glob (``obstacle_*``), ``table``, ``floor`` or ``robot``.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from typing import Any

import mujoco
import numpy as np

from mgdata.errors import SpecError
from mgdata.sim import robot
from mgdata.sim.geometry import FlatTop, GeomGaps, LowestPoint, box_corners, box_grid
from mgdata.sim.scene import OWNER_FLOOR, OWNER_ROBOT, OWNER_TABLE, Scene

ON_NORMAL_MIN_Z = np.cos(np.deg2rad(45.0))
SPILL_MARGIN = 0.005
SPILL_HEADROOM = 0.03
IN_REGION_GRID = 8
"""Cells per axis of the fixed sample grid over the bounding box (``in_region`` mode ``fraction``): 512."""


class Contacts:
    """The current contacts (computed once per labelling step), queried by owner or geom masks.

    MuJoCo's contact normal (first row of ``contact.frame``) points from ``geom1`` to ``geom2``.
    """

    def __init__(self, scene: Scene) -> None:
        d = scene.data
        n = d.ncon
        geom = d.contact.geom[:n] if n else np.zeros((0, 2), dtype=np.int32)
        self.geom1, self.geom2 = geom[:, 0], geom[:, 1]
        self.owner1 = scene.geom_owner[self.geom1]
        self.owner2 = scene.geom_owner[self.geom2]
        self._nz = d.contact.frame[:n, 2] if n else np.zeros(0)

    def between(self, a: np.ndarray, b: np.ndarray) -> np.ndarray:
        """Mask of contacts between owner sets ``a`` and ``b`` (boolean lookup arrays over owners)."""
        return (a[self.owner1] & b[self.owner2]) | (b[self.owner1] & a[self.owner2])

    def touches(self, a: np.ndarray, b: np.ndarray) -> bool:
        """Is there a contact between the geom sets ``a`` and ``b`` (boolean masks over geoms)?"""
        return bool(((a[self.geom1] & b[self.geom2]) | (b[self.geom1] & a[self.geom2])).any())

    def resting(self, obj: np.ndarray, support: np.ndarray) -> bool:
        """Is there a contact where a ``support`` geom pushes an ``obj`` geom upward (normal from the support
        into the object within 45° of +Z)? Both are boolean masks over geoms."""
        up = (support[self.geom1] & obj[self.geom2] & (self._nz >= ON_NORMAL_MIN_Z)) | (
            obj[self.geom1] & support[self.geom2] & (-self._nz >= ON_NORMAL_MIN_Z))
        return bool(up.any())


Check = Callable[[Contacts], bool]
Factory = Callable[[Scene, str, Mapping[str, Any]], Check]


def resolve(scene: Scene, pattern: str, what: str) -> list[str]:
    """Instance names matching ``pattern`` (exact, or a prefix glob ending in ``*``), in scene order.

    Raises:
        SpecError: nothing matches (an empty set is never silently true or false).
    """
    if pattern.endswith("*"):
        names = [n for n in scene.object_names if n.startswith(pattern[:-1])]
    else:
        names = [pattern] if pattern in scene.object_names else []
    if not names:
        raise SpecError(f"{what} {pattern!r} matches no object in the scene; objects: "
                        f"{', '.join(scene.object_names) or 'none'}")
    return names


def owner_mask(scene: Scene, pattern: str, what: str) -> np.ndarray:
    """Boolean lookup over ``scene.owners`` (index −1, "no owner", maps to the last entry, always False)."""
    mask = np.zeros(len(scene.owners) + 1, dtype=bool)
    fixed = {"floor": OWNER_FLOOR, "table": OWNER_TABLE, "robot": OWNER_ROBOT}
    if pattern in fixed:
        mask[fixed[pattern]] = True
    else:
        for n in resolve(scene, pattern, what):
            mask[scene.owners.index(n)] = True
    return mask


def geom_mask(scene: Scene, owners: np.ndarray) -> np.ndarray:
    """Boolean mask over geoms of the geoms whose owner is in the owner mask ``owners``."""
    return owners[scene.geom_owner]


def _box(scene: Scene, name: str) -> tuple[int, np.ndarray, np.ndarray]:
    """Body id and local bounding box ``[lo, hi]`` of an instance (``ObjectModel.size``, origin at the bottom
    centre, articulation closed): the object's bounding volume."""
    m = scene.objects[name]
    lo = np.array([-m.size[0] / 2, -m.size[1] / 2, 0.0])
    hi = np.array([m.size[0] / 2, m.size[1] / 2, m.size[2]])
    return scene.object_body(name), lo, hi


def _world_box(scene: Scene, body: int, lo: np.ndarray, hi: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """World AABB of the local box [lo, hi] of ``body``."""
    rot = scene.data.xmat[body].reshape(3, 3)
    centre = scene.data.xpos[body] + rot @ ((lo + hi) / 2.0)
    half = np.abs(rot) @ ((hi - lo) / 2.0)
    return centre - half, centre + half


def _near_top(scene: Scene, subject: str, owner: int, gap: float) -> Callable[[], bool]:
    """Is the lowest point of ``subject`` within ``gap`` of the top face of the fixed support ``owner``
    (table or floor), with the object's bounding box over that face?"""
    tops = [FlatTop(scene.model, scene.data, g) for g in np.flatnonzero(scene.geom_owner == owner)]
    if not tops:
        return lambda: False
    lowest, box = LowestPoint(scene.model, scene.object_geom_ids(subject)), _box(scene, subject)

    def near() -> bool:
        if lowest.lower_bound(scene.data) > max(t.z for t in tops) + gap:
            return False
        low = lowest(scene.data)
        close = [t for t in tops if abs(low - t.z) <= gap]
        return bool(close) and any(t.overlaps(*_world_box(scene, *box)) for t in close)

    return near


def _dropped(scene: Scene, subject: str, p: Mapping[str, Any]) -> Check:
    limit = scene.floor_z + float(p["floor_margin"])
    lowest = LowestPoint(scene.model, scene.object_geom_ids(subject))
    return lambda c: lowest.below(scene.data, limit)


def _upright(scene: Scene, subject: str, p: Mapping[str, Any]) -> Check:
    body, cos_max = scene.object_body(subject), float(np.cos(np.deg2rad(float(p["max_tilt_deg"]))))
    return lambda c: bool(scene.data.xmat[body, 8] >= cos_max)


def _on(scene: Scene, subject: str, p: Mapping[str, Any]) -> Check:
    pattern, gap = str(p["support"]), float(p["gap_tol"])
    obj = geom_mask(scene, owner_mask(scene, subject, "subject"))
    support = geom_mask(scene, owner_mask(scene, pattern, "support"))
    if pattern in ("table", "floor"):
        near = _near_top(scene, subject, OWNER_TABLE if pattern == "table" else OWNER_FLOOR, gap)
        return lambda c: c.resting(obj, support) or near()
    gaps = GeomGaps(scene.model, np.flatnonzero(obj), np.flatnonzero(support), gap)

    def check(c: Contacts) -> bool:
        return c.resting(obj, support) or any(
            dist > 0.0 and up[2] >= ON_NORMAL_MIN_Z for dist, up in gaps.near(scene.data))

    return check


def _seated(scene: Scene, subject: str, p: Mapping[str, Any]) -> Check:
    support = str(p["support"])
    if support not in scene.object_names:
        raise SpecError(f"seated: support {support!r} is not an instance in the scene; objects: "
                        f"{', '.join(scene.object_names)}")
    seat = scene.object_model(support).geometry.get("seat_height")
    if seat is None:
        raise SpecError(f"seated: {support!r} ({scene.objects[support].name}) has no seat for a lid "
                        "(geometry seat_height)")
    lid, box = scene.object_body(subject), scene.object_body(support)
    obj = geom_mask(scene, owner_mask(scene, subject, "subject"))
    sup = geom_mask(scene, owner_mask(scene, support, "support"))
    offset, gap = float(p["max_offset"]), float(p["max_gap"])
    cos_max = float(np.cos(np.deg2rad(float(p["max_tilt_deg"]))))

    def check(c: Contacts) -> bool:
        d = scene.data
        rot = d.xmat[box].reshape(3, 3)
        local = rot.T @ (d.xpos[lid] - d.xpos[box])
        return bool(np.hypot(local[0], local[1]) <= offset and abs(local[2] - float(seat)) <= gap
                    and d.xmat[lid].reshape(3, 3)[:, 2] @ rot[:, 2] >= cos_max and c.touches(obj, sup))

    return check


def _fraction(scene: Scene, subject: str) -> Callable[[], float]:
    if scene.objects[subject].articulation is None:
        raise SpecError(f"open/closed: object {subject!r} ({scene.objects[subject].name}) "
                        "has no articulation")
    art, adr = scene.objects[subject].articulation, scene.articulation_qpos_adr(subject)
    return lambda: art.fraction(float(scene.data.qpos[adr]))


def _open(scene: Scene, subject: str, p: Mapping[str, Any]) -> Check:
    f, lo = _fraction(scene, subject), float(p["min_fraction"])
    return lambda c: f() >= lo


def _closed(scene: Scene, subject: str, p: Mapping[str, Any]) -> Check:
    f, hi = _fraction(scene, subject), float(p["max_fraction"])
    return lambda c: f() <= hi


def _touching(scene: Scene, subject: str, p: Mapping[str, Any]) -> Check:
    obj = geom_mask(scene, owner_mask(scene, subject, "subject"))
    other = geom_mask(scene, owner_mask(scene, str(p["other"]), "other"))
    gap = float(p["gap_tol"])
    if gap == 0.0:
        return lambda c: c.touches(obj, other)
    gaps = GeomGaps(scene.model, np.flatnonzero(obj), np.flatnonzero(other), gap)
    return lambda c: c.touches(obj, other) or bool(gaps.near(scene.data))


def _spilled(scene: Scene, subject: str, p: Mapping[str, Any]) -> Check:
    if subject not in scene.liquids:
        raise SpecError(f"spilled: subject {subject!r} is not a liquid (liquids: {', '.join(scene.liquids)})")
    container = str(p["container"])
    cavity = scene.object_model(container).cavity
    if cavity is None:
        raise SpecError(f"spilled: container {container!r} ({scene.objects[container].name}) has no cavity")
    ids, body, limit = scene.liquids[subject].body_ids, scene.object_body(container), float(p["max_fraction"])

    def check(c: Contacts) -> bool:
        d = scene.data
        local = (d.xpos[ids] - d.xpos[body]) @ d.xmat[body].reshape(3, 3)
        inside = cavity.contains(local, margin=SPILL_MARGIN, headroom=SPILL_HEADROOM)
        return bool(1.0 - inside.mean() > limit)

    return check


def _in_region(scene: Scene, subject: str, p: Mapping[str, Any]) -> Check:
    region, mode = str(p["region"]), str(p["mode"])
    site = mujoco.mj_name2id(scene.model, mujoco.mjtObj.mjOBJ_SITE, region)
    if site < 0:
        raise SpecError(f"in_region: the scene has no region {region!r} (the task's goal is named "
                        f"{scene.task.goal.name if scene.task.goal else 'nothing: it has no goal'})")
    radius, (body, lo, hi) = float(scene.model.site_size[site, 0]), _box(scene, subject)
    local = {"centre": ((lo + hi) / 2.0)[None, :], "contained": box_corners(lo, hi),
             "fraction": box_grid(lo, hi, IN_REGION_GRID)}[mode]
    need = float(p["min_fraction"]) if mode == "fraction" else 1.0

    def check(c: Contacts) -> bool:
        d = scene.data
        offset = d.xpos[body] + local @ d.xmat[body].reshape(3, 3).T - d.site_xpos[site]
        return bool(np.mean(np.einsum("ij,ij->i", offset, offset) <= radius * radius) >= need)

    return check


def _held(scene: Scene, subject: str, p: Mapping[str, Any]) -> Check:
    m, d, gap = scene.model, scene.data, float(p["gap_tol"])
    vmax, wmax = float(p["max_speed"]), float(p["max_angular_speed"])
    obj = geom_mask(scene, owner_mask(scene, subject, "subject"))
    fingers = [(scene.geom_owner >= 0) & (m.geom_bodyid == m.body(b).id) for b in robot.FINGER_BODIES]
    others = (scene.geom_owner >= 0) & ~obj & ~fingers[0] & ~fingers[1]
    finger_gaps = [GeomGaps(m, np.flatnonzero(f), np.flatnonzero(obj), gap) for f in fingers]
    on_fixed = [_near_top(scene, subject, owner, gap) for owner in (OWNER_TABLE, OWNER_FLOOR)]
    body, lo, hi = _box(scene, subject)
    hand, centre = m.body(robot.HAND_BODY).id, (lo + hi) / 2.0
    v_obj, v_hand = np.zeros(6), np.zeros(6)

    def relative_speeds() -> tuple[float, float]:
        """Linear (m/s, at the bounding-box centre) and angular (rad/s) speed of the object in the hand."""
        mujoco.mj_objectVelocity(m, d, mujoco.mjtObj.mjOBJ_XBODY, body, v_obj, 0)
        mujoco.mj_objectVelocity(m, d, mujoco.mjtObj.mjOBJ_XBODY, hand, v_hand, 0)
        point = d.xpos[body] + d.xmat[body].reshape(3, 3) @ centre
        v = (v_obj[3:] + np.cross(v_obj[:3], point - d.xpos[body])
             - v_hand[3:] - np.cross(v_hand[:3], point - d.xpos[hand]))
        return float(np.linalg.norm(v)), float(np.linalg.norm(v_obj[:3] - v_hand[:3]))

    def check(c: Contacts) -> bool:  # cheapest tests first: most states fail one of them
        if c.resting(obj, others):
            return False
        for f, g in zip(fingers, finger_gaps, strict=True):
            if not (c.touches(f, obj) or g.near(d)):
                return False
        if any(near() for near in on_fixed):
            return False
        v, w = relative_speeds()
        return v <= vmax and w <= wmax

    return check


def _dust_on(scene: Scene, subject: str) -> list[str]:
    """Dust instances lying on ``subject`` (``Scene.dust_hosts``), or ``subject`` itself if it is dust."""
    if subject in scene.dust.mocap_ids:
        return [subject]
    found = [name for name, host in scene.dust_hosts.items() if host == subject]
    if not found:
        raise SpecError(f"covered: no dust lies on {subject!r} (dust instances: "
                        f"{', '.join(scene.dust.mocap_ids) or 'none'})")
    return found


def _covered(scene: Scene, subject: str, p: Mapping[str, Any]) -> Check:
    dust, lo = _dust_on(scene, subject), float(p["min_fraction"])
    counts = np.array([len(scene.dust.mocap_ids[n]) for n in dust], dtype=float)

    def check(c: Contacts) -> bool:
        left = np.array([scene.dust.remaining_fraction(scene.data, n) for n in dust]) @ counts
        return bool(left / counts.sum() > lo)

    return check


def _clean(scene: Scene, subject: str, p: Mapping[str, Any]) -> Check:
    covered = _covered(scene, subject, {"min_fraction": float(p["max_fraction"])})
    return lambda c: not covered(c)


Interior = Callable[[np.ndarray, float, float], np.ndarray]


def _interior(scene: Scene, container: str) -> tuple[int, Interior]:
    """The body whose frame holds ``container``'s interior and a test ``inside(points, margin, headroom)``
    over points (n, 3) in that frame: a drawer's inner box, else the cavity."""
    model = scene.objects[container]
    geo, art = model.geometry, model.articulation
    if "drawer_inner" in geo and art is not None:
        link = next(lk for lk in model.links if lk.joint is not None and lk.joint.name == art.joint)
        hx, hy, depth = (float(v) for v in geo["drawer_inner"])
        floor = float(geo["drawer_floor_z"]) - float(link.pos[2])
        lo, hi = np.array([-hx, -hy, floor]), np.array([hx, hy, floor + depth])
        body = scene.model.body(f"{container}/{link.name}").id
        return body, lambda pts, m, h: np.all((pts >= lo - m) & (pts <= hi + np.array([m, m, h])), axis=1)
    cavity = model.cavity
    if cavity is None:
        raise SpecError(f"inside: container {container!r} ({model.name}) has no interior "
                        "(no drawer, no cavity)")
    return scene.object_body(container), lambda pts, m, h: cavity.contains(pts, margin=m, headroom=h)


def _geom_box(scene: Scene, name: str) -> tuple[np.ndarray, np.ndarray]:
    """The bounding box (lo, hi) of a rigid object's collision geoms in its root body's frame (exact, where
    ``ObjectModel.size`` is centred on the origin: a mug's handle sticks out on one side)."""
    m, d = scene.model, scene.data
    body = scene.object_body(name)
    rot = d.xmat[body].reshape(3, 3)
    signs = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)], dtype=float)
    pts = []
    for g in scene.object_geom_ids(name):
        centre, half = m.geom_aabb[g, :3], m.geom_aabb[g, 3:]
        world = d.geom_xpos[g] + (centre + signs * half) @ d.geom_xmat[g].reshape(3, 3).T
        pts.append((world - d.xpos[body]) @ rot)
    allpts = np.concatenate(pts)
    return allpts.min(axis=0), allpts.max(axis=0)


def _inside(scene: Scene, subject: str, p: Mapping[str, Any]) -> Check:
    container, margin, headroom = str(p["container"]), float(p["margin"]), float(p["headroom"])
    if container not in scene.objects:
        raise SpecError(f"inside: container {container!r} is not an object of the scene; objects: "
                        f"{', '.join(scene.object_names)}")
    frame, test = _interior(scene, container)
    body = scene.object_body(subject)
    lo, hi = _geom_box(scene, subject)
    points = box_corners(lo, hi) if p["mode"] == "contained" else ((lo + hi) / 2.0)[None, :]

    def check(c: Contacts) -> bool:
        d = scene.data
        world = d.xpos[body] + points @ d.xmat[body].reshape(3, 3).T
        local = (world - d.xpos[frame]) @ d.xmat[frame].reshape(3, 3)
        return bool(np.all(test(local, margin, headroom)))

    return check


def _near_start(scene: Scene, subject: str, p: Mapping[str, Any]) -> Check:
    body, limit = scene.object_body(subject), float(p["max_distance"])
    start = np.asarray(scene.task.object(subject).pos, dtype=np.float64)
    return lambda c: bool(np.linalg.norm(scene.data.xpos[body] - start) < limit)


FACTORIES: Mapping[str, Factory] = {
    "dropped": _dropped,
    "upright": _upright,
    "on": _on,
    "seated": _seated,
    "open": _open,
    "closed": _closed,
    "touching": _touching,
    "spilled": _spilled,
    "in_region": _in_region,
    "held": _held,
    "covered": _covered,
    "clean": _clean,
    "inside": _inside,
    "near_start": _near_start,
}
"""Evaluator name -> compiler of one subject's check (names and parameters: ``mgdata.spec.EVALUATORS``)."""


def compile_check(scene: Scene, evaluator: str, subject: str, params: Mapping[str, Any]) -> Check:
    """One subject's check. ``params`` must be complete (validated against ``mgdata.spec.EVALUATORS``).

    Raises:
        SpecError: a name in the parameters does not resolve in this scene, or the subject does not fit the
            evaluator (e.g. ``closed`` on an object without articulation).
    """
    return FACTORIES[evaluator](scene, subject, params)
