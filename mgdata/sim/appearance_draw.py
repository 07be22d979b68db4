"""Appearance randomisation: per-episode draws of how a scene looks, applied only to what the cameras see.

A draw changes, on the camera rig's own copy of the model (never the model physics steps):

* the table top, floor and walls: their texture kind (:mod:`mgdata.sim.textures`), colour and sheen;
* every object instance's colour: a small hue / saturation / value shift of its own colours, so a ceramic
  mug stays a plausible mug (alpha kept);
* the two lights' directions and intensities and the headlight;
* the third-person cameras' poses: a few millimetres to centimetres and a degree or two (the wrist camera is
  mounted on the hand and stays);
* visual-only distractors: a few boxes, cylinders and spheres on free parts of the table, drawn into the
  rig's scene after MuJoCo's own geoms (they exist in no model, so nothing can touch them).

So the physics is bit-identical with and without it, by construction (tested). A draw is a pure function of
the settings, the scene and a seed sequence derived from the episode's recorded ``seed``, ``task_id`` and
``draw_index`` and the draw number ``k`` (generation renders ``k = 0``; ``mgdata render --appearance K``
renders ``k = 0 … K-1``), and is recorded in the episode's ``variation.appearance``.

Recipe table (optional; the shipped recipes have none, so appearance is fixed)::

    [appearance]
    enabled = true
    hue = 0.04                 # ± of the objects' hue (0…1 turn)
    saturation = [0.8, 1.2]    # × the objects' saturation
    value = [0.85, 1.1]        # × the objects' brightness
    key_light = [0.4, 0.8]     # diffuse intensities
    fill_light = [0.1, 0.35]
    ambient = [0.2, 0.4]
    light_azimuth_deg = 60.0   # ± about the vertical, of both lights' directions
    light_elevation_deg = [45.0, 80.0]
    camera_shift = 0.02        # m, ± per axis, third-person cameras
    camera_turn_deg = 1.5      # ± about each axis
    distractors = [0, 3]       # how many
    distractor_size = [0.02, 0.05]   # m, half extent
    distractor_clearance = 0.15      # m in the table plane from every object and the goal
    table_kinds = ["wood", "planks", "plaster", "ceramic"]
    floor_kinds = ["planks", "wood", "plaster", "fabric"]
    wall_kinds = ["plaster", "fabric", "cardboard"]
    table_colors = [[0.62, 0.47, 0.32], …]   # plausible base colours (RGB, 0…1): a draw picks one and
    floor_colors = [[0.55, 0.50, 0.45], …]   # scales each channel by 0.9…1.1 (defaults: AppearanceSettings)
    wall_colors = [[0.68, 0.74, 0.66], …]

Example::

    settings = parse_appearance({"enabled": True}, "jar.toml: [appearance]")
    draw = draw_appearance(settings, model, data, episode_seed(meta, k=0))
    rig.set_appearance(draw)
"""

from __future__ import annotations

import colorsys
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, fields
from typing import Any

import mujoco
import numpy as np

from mgdata.errors import RecipeError
from mgdata.sim.cameras import THIRD_PERSON
from mgdata.sim.textures import KINDS, texture

RGB = tuple[float, float, float]
APPEARANCE_STREAM = 0x41505052
"""Mixed into every draw's seed sequence, so appearance draws never coincide with physics draws."""
SURFACES = {"table": ("table/top", "table_mat"), "floor": ("floor", "floor_mat"),
            "walls": ("wall_", "wall_mat")}
"""Surface -> (geom name or prefix, material/texture name) in scenes built by ``mgdata.sim.materials``."""
TABLE_BOUNDS = ((-0.2, 1.0), (-0.7, 0.7))
"""m, world x and y: where distractors may stand (the table top, less a 5 cm margin)."""
ROBOT_KEEP_OUT = 0.3
"""m: no distractor closer than this to the robot base in the table plane."""


def _pair(value: Any, where: str, low: float, high: float) -> tuple[float, float]:
    if not (isinstance(value, list) and len(value) == 2 and all(
            isinstance(v, int | float) and not isinstance(v, bool) for v in value)):
        raise RecipeError(f"{where} = {value!r}: expected [low, high]")
    a, b = float(value[0]), float(value[1])
    if not low <= a <= b <= high:
        raise RecipeError(f"{where} = {value!r}: expected {low} <= low <= high <= {high}")
    return a, b


@dataclass(frozen=True)
class AppearanceSettings:
    """The ``[appearance]`` table (module docstring); ``enabled = False`` draws nothing."""

    enabled: bool = False
    hue: float = 0.04
    saturation: tuple[float, float] = (0.8, 1.2)
    value: tuple[float, float] = (0.85, 1.1)
    key_light: tuple[float, float] = (0.4, 0.8)
    fill_light: tuple[float, float] = (0.1, 0.35)
    ambient: tuple[float, float] = (0.2, 0.4)
    light_azimuth_deg: float = 60.0
    light_elevation_deg: tuple[float, float] = (45.0, 80.0)
    camera_shift: float = 0.02
    camera_turn_deg: float = 1.5
    distractors: tuple[float, float] = (0, 3)
    distractor_size: tuple[float, float] = (0.02, 0.05)
    distractor_clearance: float = 0.15
    table_kinds: tuple[str, ...] = ("wood", "planks", "plaster", "ceramic")
    floor_kinds: tuple[str, ...] = ("planks", "wood", "plaster", "fabric")
    wall_kinds: tuple[str, ...] = ("plaster", "fabric", "cardboard")
    table_colors: tuple[RGB, ...] = ((0.62, 0.47, 0.32), (0.76, 0.62, 0.45), (0.45, 0.32, 0.22),
                                     (0.85, 0.84, 0.80), (0.35, 0.36, 0.38), (0.70, 0.72, 0.74))
    floor_colors: tuple[RGB, ...] = ((0.55, 0.50, 0.45), (0.40, 0.30, 0.22), (0.62, 0.62, 0.60),
                                     (0.30, 0.32, 0.35), (0.72, 0.66, 0.55))
    wall_colors: tuple[RGB, ...] = ((0.68, 0.74, 0.66), (0.90, 0.88, 0.82), (0.75, 0.80, 0.88),
                                    (0.86, 0.76, 0.66), (0.60, 0.60, 0.62), (0.92, 0.92, 0.92))

    def to_info(self) -> dict[str, Any]:
        """JSON-ready settings (``info.json`` ``mgdata.appearance``)."""
        def plain(v: Any) -> Any:
            return [plain(x) for x in v] if isinstance(v, tuple) else v
        return {f.name: plain(getattr(self, f.name)) for f in fields(self)}


_RANGES = {"saturation": (0.0, 3.0), "value": (0.0, 3.0), "key_light": (0.0, 1.0), "fill_light": (0.0, 1.0),
           "ambient": (0.0, 1.0), "light_elevation_deg": (5.0, 90.0), "distractors": (0, 10),
           "distractor_size": (0.005, 0.15)}
_SCALARS = {"hue": (0.0, 0.5), "light_azimuth_deg": (0.0, 180.0), "camera_shift": (0.0, 0.1),
            "camera_turn_deg": (0.0, 10.0), "distractor_clearance": (0.0, 1.0)}


def _is_rgb(value: Any) -> bool:
    return isinstance(value, list) and len(value) == 3 and all(
        isinstance(x, int | float) and not isinstance(x, bool) and 0.0 <= x <= 1.0 for x in value)


def parse_appearance(table: Mapping[str, Any], where: str) -> AppearanceSettings:
    """Check an ``[appearance]`` table; every problem is one RecipeError naming the key."""
    known = {f.name for f in fields(AppearanceSettings)}
    if set(table) - known:
        raise RecipeError(f"{where} unknown key(s) {sorted(set(table) - known)}; expected {sorted(known)}")
    values: dict[str, Any] = {}
    for key, raw in table.items():
        at = f"{where} {key}"
        if key == "enabled":
            if not isinstance(raw, bool):
                raise RecipeError(f"{at} = {raw!r}: expected true or false")
            values[key] = raw
        elif key in _RANGES:
            values[key] = _pair(raw, at, *_RANGES[key])
            if key == "distractors" and not all(float(v).is_integer() for v in raw):
                raise RecipeError(f"{at} = {raw!r}: expected whole numbers [low, high]")
        elif key in _SCALARS:
            low, high = _SCALARS[key]
            if isinstance(raw, bool) or not isinstance(raw, int | float) or not low <= raw <= high:
                raise RecipeError(f"{at} = {raw!r}: expected a number in [{low}, {high}]")
            values[key] = float(raw)
        elif key.endswith("_colors"):
            if not (isinstance(raw, list) and raw and all(_is_rgb(c) for c in raw)):
                raise RecipeError(f"{at} = {raw!r}: expected a non-empty list of [r, g, b] in 0…1")
            values[key] = tuple(tuple(float(x) for x in c) for c in raw)
        else:  # texture kinds
            if not (isinstance(raw, list) and raw and all(k in KINDS for k in raw)):
                raise RecipeError(f"{at} = {raw!r}: expected a non-empty list of texture kinds from "
                                  f"{sorted(KINDS)}")
            values[key] = tuple(raw)
    return AppearanceSettings(**values)


@dataclass(frozen=True)
class Distractor:
    """A visual-only primitive: ``kind`` (box, cylinder, sphere), half ``size`` (m), centre ``pos`` (m,
    world), ``yaw`` (rad), ``rgba``."""

    kind: str
    size: float
    pos: tuple[float, float, float]
    yaw: float
    rgba: tuple[float, float, float, float]


@dataclass(frozen=True)
class AppearanceDraw:
    """One drawn appearance (see the module docstring); :meth:`record` is its JSON form."""

    k: int
    surfaces: Mapping[str, Mapping[str, Any]]
    tints: Mapping[str, tuple[float, float, float]]
    lights: Mapping[str, Any]
    cameras: Mapping[str, Mapping[str, tuple[float, ...]]]
    distractors: tuple[Distractor, ...] = field(default=())

    def record(self) -> dict[str, Any]:
        return {"k": self.k, "surfaces": {k: dict(v) for k, v in self.surfaces.items()},
                "tints": {k: list(v) for k, v in self.tints.items()}, "lights": dict(self.lights),
                "cameras": {k: {a: list(b) for a, b in v.items()} for k, v in self.cameras.items()},
                "distractors": [{"kind": d.kind, "size": d.size, "pos": list(d.pos), "yaw": d.yaw,
                                 "rgba": list(d.rgba)} for d in self.distractors]}

    def apply(self, model: mujoco.MjModel) -> list[int]:
        """Change ``model`` (a rig's copy) in place; returns the ids of the textures whose pixels changed."""
        changed = []
        for surface, drawn in self.surfaces.items():
            geom, material = SURFACES[surface]
            for g in range(model.ngeom):
                name = model.geom(g).name
                if name == geom or (geom.endswith("_") and name.startswith(geom)):
                    model.geom_rgba[g, :3] = drawn["rgb"]
            mat = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_MATERIAL, material)
            if mat >= 0:
                model.mat_specular[mat] = drawn["specular"]
            tex = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_TEXTURE, material)
            if tex >= 0 and model.tex_nchannel[tex] == 3 and model.tex_width[tex] == model.tex_height[tex]:
                size, adr = int(model.tex_width[tex]), int(model.tex_adr[tex])
                image = texture(drawn["kind"], size, int(drawn["seed"]))
                model.tex_data[adr: adr + image.size] = image.ravel()
                changed.append(tex)
        for g in range(model.ngeom):
            head = model.geom(g).name.split("/", 1)[0]
            if head in self.tints and "/" in model.geom(g).name:
                model.geom_rgba[g, :3] = shifted(model.geom_rgba[g, :3], self.tints[head])
        for name, light in (("key", self.lights["key"]), ("fill", self.lights["fill"])):
            lid = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_LIGHT, name)
            if lid >= 0:
                model.light_dir[lid] = light["dir"]
                model.light_diffuse[lid] = [light["diffuse"]] * 3
        model.vis.headlight.ambient[:] = [self.lights["ambient"]] * 3
        for name, pose in self.cameras.items():
            cam = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_CAMERA, name)
            if cam >= 0 and model.cam_bodyid[cam] == 0:
                model.cam_pos[cam] += pose["shift"]
                turn = np.zeros(4)
                mujoco.mju_euler2Quat(turn, np.radians(pose["turn_deg"]), "xyz")
                out = np.zeros(4)
                mujoco.mju_mulQuat(out, model.cam_quat[cam], turn)
                model.cam_quat[cam] = out
        return changed

    def add_distractors(self, scene: mujoco.MjvScene) -> None:
        """Append the distractors to an updated ``MjvScene`` (drawn like any geom, exist in no model)."""
        for d in self.distractors:
            if scene.ngeom >= scene.maxgeom:
                return
            kind = {"box": mujoco.mjtGeom.mjGEOM_BOX, "cylinder": mujoco.mjtGeom.mjGEOM_CYLINDER,
                    "sphere": mujoco.mjtGeom.mjGEOM_SPHERE}[d.kind]
            c, s = math.cos(d.yaw), math.sin(d.yaw)
            mat = np.array([c, -s, 0.0, s, c, 0.0, 0.0, 0.0, 1.0])
            mujoco.mjv_initGeom(scene.geoms[scene.ngeom], kind, np.array([d.size] * 3), np.array(d.pos), mat,
                                np.array(d.rgba, dtype=np.float32))
            scene.ngeom += 1


def shifted(rgb: Sequence[float], tint: Sequence[float]) -> np.ndarray:
    """``rgb`` with its hue turned by ``tint[0]``, its saturation and value scaled by ``tint[1:]``."""
    h, s, v = colorsys.rgb_to_hsv(*(float(x) for x in rgb))
    r, g, b = colorsys.hsv_to_rgb((h + tint[0]) % 1.0, min(1.0, s * tint[1]), min(1.0, v * tint[2]))
    return np.array([r, g, b])


def episode_seed(seed: int, task_id: int, draw_index: int, k: int, extra: int = 0) -> np.random.SeedSequence:
    """The seed sequence of appearance draw ``k`` of an episode (from its recorded seed, task and draw)."""
    return np.random.SeedSequence([APPEARANCE_STREAM, int(seed), int(task_id), int(draw_index), int(k),
                                   int(extra)])


def instances(model: mujoco.MjModel) -> list[str]:
    """Object instance names of a scene: top-level bodies whose geoms are named ``<body>/…``."""
    out = []
    for b in range(1, model.nbody):
        if model.body_parentid[b] != 0:
            continue
        name = model.body(b).name
        first, count = model.body_geomadr[b], model.body_geomnum[b]
        if count and model.geom(int(first)).name.startswith(f"{name}/"):
            out.append(name)
    return out


MOTION_CLEARANCE = 0.03
"""m between a distractor's bounding sphere and the bounding sphere of every moving colliding geom (the arm,
the hand and every object it moves), in every frame of the episode."""


def moving_spheres(model: mujoco.MjModel, data: mujoco.MjData) -> np.ndarray:
    """(n, 4) centres (m, world) and bounding radii of the colliding geoms that can move (their body is not
    welded to the world: the arm's links, the objects) in ``data`` (positions computed); an episode's frames
    together are what distractors keep clear of."""
    ids = np.flatnonzero(((model.geom_contype != 0) | (model.geom_conaffinity != 0))
                         & (model.body_weldid[model.geom_bodyid] != 0))
    return np.column_stack([data.geom_xpos[ids], model.geom_rbound[ids]])


def draw_appearance(settings: AppearanceSettings, model: mujoco.MjModel, data: mujoco.MjData,
                    seed: np.random.SeedSequence, k: int = 0,
                    sweep: np.ndarray | None = None) -> AppearanceDraw:
    """Draw an appearance for the scene ``model`` whose first frame is ``data`` (positions computed);
    ``sweep``: :func:`moving_spheres` over the episode's frames, which distractors keep clear of."""
    rng = np.random.default_rng(seed)
    st = settings
    surfaces = {}
    for surface, kinds, colors in (("table", st.table_kinds, st.table_colors),
                                   ("floor", st.floor_kinds, st.floor_colors),
                                   ("walls", st.wall_kinds, st.wall_colors)):
        base = colors[int(rng.integers(len(colors)))]
        rgb = np.clip(np.asarray(base) * rng.uniform(0.9, 1.1, 3), 0.0, 1.0)
        surfaces[surface] = {"kind": kinds[int(rng.integers(len(kinds)))], "rgb": [float(x) for x in rgb],
                             "specular": float(rng.uniform(0.0, 0.3)), "seed": int(rng.integers(2 ** 31))}
    tints = {name: (float(rng.uniform(-st.hue, st.hue)), float(rng.uniform(*st.saturation)),
                    float(rng.uniform(*st.value))) for name in instances(model)}
    lights: dict[str, Any] = {}
    for name, intensity in (("key", st.key_light), ("fill", st.fill_light)):
        azimuth = math.radians(float(rng.uniform(-180.0, 180.0) if name == "fill" else
                                     rng.uniform(-st.light_azimuth_deg, st.light_azimuth_deg)) + 70.0)
        elevation = math.radians(float(rng.uniform(*st.light_elevation_deg)))
        flat = math.cos(elevation)
        lights[name] = {"dir": [-flat * math.cos(azimuth), -flat * math.sin(azimuth), -math.sin(elevation)],
                        "diffuse": float(rng.uniform(*intensity))}
    lights["ambient"] = float(rng.uniform(*st.ambient))
    shift, turn = st.camera_shift, st.camera_turn_deg
    cameras = {name: {"shift": tuple(float(x) for x in rng.uniform(-shift, shift, 3)),
                      "turn_deg": tuple(float(x) for x in rng.uniform(-turn, turn, 3))}
               for name in THIRD_PERSON}
    sweep = np.zeros((0, 4)) if sweep is None else sweep
    return AppearanceDraw(k, surfaces, tints, lights, cameras, _distractors(st, model, data, rng, sweep))


def _distractors(st: AppearanceSettings, model: mujoco.MjModel, data: mujoco.MjData,
                 rng: np.random.Generator, sweep: np.ndarray) -> tuple[Distractor, ...]:
    """Up to the drawn count of primitives on the table, clear of the objects, the goal, the robot's base
    and everything that moves in the episode (``sweep``)."""
    keep_out = [data.xpos[model.body(n).id, :2] for n in instances(model)]
    goal = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, "goal")
    if goal >= 0:
        keep_out.append(data.xpos[goal, :2])
    base = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, "base")
    robot_xy = data.xpos[base, :2] if base >= 0 else np.zeros(2)
    count = int(rng.integers(int(st.distractors[0]), int(st.distractors[1]) + 1))
    out: list[Distractor] = []
    for _ in range(count):
        kind = ("box", "cylinder", "sphere")[int(rng.integers(3))]
        size = float(rng.uniform(*st.distractor_size))
        yaw = float(rng.uniform(-math.pi, math.pi))
        hue, sat, val = float(rng.random()), float(rng.uniform(0.3, 0.9)), float(rng.uniform(0.4, 0.95))
        rgb = colorsys.hsv_to_rgb(hue, sat, val)
        for _try in range(30):
            xy = np.array([rng.uniform(*TABLE_BOUNDS[0]), rng.uniform(*TABLE_BOUNDS[1])])
            clear = all(np.linalg.norm(xy - p) >= st.distractor_clearance + size for p in keep_out)
            centre = np.array([xy[0], xy[1], size])
            gap = np.linalg.norm(sweep[:, :3] - centre, axis=1) - sweep[:, 3] - math.sqrt(3.0) * size
            swept = len(sweep) and float(gap.min()) < MOTION_CLEARANCE
            if clear and not swept and np.linalg.norm(xy - robot_xy) >= ROBOT_KEEP_OUT:
                out.append(Distractor(kind, size, (float(xy[0]), float(xy[1]), size), yaw, (*rgb, 1.0)))
                keep_out.append(xy)
                break
    return tuple(out)
