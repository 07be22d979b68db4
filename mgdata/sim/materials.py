"""What surfaces look like: the room's materials, the objects' finishes and the lights (``recipes/sim.toml``
``[look]``, :class:`Look`).

* **Room.** Textures are grey and each geom's ``rgba`` colours them. The table top is wood, the floor
  laminate planks, the four walls plaster (:mod:`mgdata.sim.textures`,
  generated in code). The walls are visual only and stand where the environment rooms put theirs
  (``mgdata.sim.rooms``), which recolour them.
* **Objects.** Every visible geom of an object without a material of its own gets its category's finish
  (``ceramic``, ``glass``, ``metal``, ``plastic``, ``cardboard``, ``fabric``, ``food``, ``wood``): a grey
  texture (none for the smooth ones: glass, glaze, plastic) and a specular response, multiplied with the
  geom's own colour, so models keep their colours.
  Translucent geoms (alpha < 1) are glass whatever their category; an unlisted category is ``plastic``.
* **Lights.** A key light from the front left above, a weaker fill from the right, and a dim headlight, so
  that shapes read by their shading; optional shadows from the key light.

Only ``geom_matid``, materials, textures and lights change: physics is untouched (tested bit for bit).

Example::

    dress_room(spec, look, floor_z=-0.75)
    dress_objects(spec, {"jar": jar_model}, look)
"""

from __future__ import annotations

import zlib
from collections.abc import Mapping
from dataclasses import dataclass

import mujoco
import numpy as np

from mgdata.errors import RecipeError
from mgdata.sim.textures import texture

Vec3 = tuple[float, float, float]

ROOM_X = (-2.3, 3.1)
"""The walls' x positions (m, world): behind the robot and behind the front camera."""
ROOM_Y = (-2.6, 2.6)
WALL_HEIGHT = 3.0
"""m above the floor."""
WALLS = ("back", "front", "left", "right")
VISUAL_GROUP = 2

FINISHES: dict[str, tuple[str | None, float, float]] = {
    # finish: (texture kind or None, specular, shininess)
    "ceramic": (None, 0.45, 0.7),
    "glass": (None, 0.8, 0.9),
    "metal": ("metal", 0.7, 0.6),
    "plastic": (None, 0.3, 0.4),
    "cardboard": ("cardboard", 0.05, 0.1),
    "fabric": ("fabric", 0.02, 0.05),
    "food": ("food", 0.15, 0.3),
    "wood": ("wood", 0.12, 0.25),
}
"""Each finish: its grey texture kind (None: untextured), MuJoCo specular and shininess (0…1). Glaze and
plastic are smooth: a mesh without texture coordinates gets MuJoCo's projected ones, which smear a faint
speckle into streaks across a plate, so those finishes are sheen only."""


@dataclass(frozen=True)
class Look:
    """Materials and lights (``recipes/sim.toml`` ``[look]``).

    Attributes:
        textures: false draws every surface in its flat colour (the look before materials; for comparisons).
        texture_size: side (pixels) of each generated texture.
        table, floor, walls: base colours (RGB 0…1) of the table's wood, the floor's planks, the walls'
            plaster.
        floor_repeat: how often the floor texture tiles over the 8 m floor.
        key_light, fill_light: diffuse intensity of the two directional lights; key_dir, fill_dir: their
            directions (world).
        ambient, headlight: the headlight's ambient and diffuse intensity.
        shadows: the key light casts shadows (costly on CPU rendering: docs/render.md).
        wall_glow: the walls' emission (0…1): the lights point down, so upright walls would be dim.
        ceramic, glass, metal, plastic, cardboard, fabric, food, wood: the object categories with that finish.
    """

    textures: bool = True
    texture_size: int = 128
    table: Vec3 = (0.62, 0.47, 0.32)
    floor: Vec3 = (0.55, 0.50, 0.45)
    walls: Vec3 = (0.68, 0.74, 0.66)
    floor_repeat: float = 6.0
    key_light: float = 0.6
    key_dir: Vec3 = (0.3, 0.35, -1.0)
    fill_light: float = 0.25
    fill_dir: Vec3 = (-0.4, -0.6, -0.6)
    ambient: float = 0.3
    headlight: float = 0.2
    shadows: bool = False
    wall_glow: float = 0.35
    ceramic: tuple[str, ...] = ("mug", "teacup", "bowl", "plate")
    glass: tuple[str, ...] = ()
    metal: tuple[str, ...] = ("jar", "holder")
    plastic: tuple[str, ...] = ("cup", "bottle", "container", "lid", "tray")
    cardboard: tuple[str, ...] = ("box", "dust")
    fabric: tuple[str, ...] = ("sponge",)
    food: tuple[str, ...] = ("food",)
    wood: tuple[str, ...] = ("board", "cabinet")

    def __post_init__(self) -> None:
        if not 16 <= self.texture_size <= 1024:
            raise RecipeError(f"[look] texture_size = {self.texture_size!r}: expected pixels in 16…1024")
        if self.floor_repeat <= 0:
            raise RecipeError(f"[look] floor_repeat = {self.floor_repeat!r}: expected a positive number")
        for key in ("key_light", "fill_light", "ambient", "headlight", "wall_glow"):
            if not 0.0 <= getattr(self, key) <= 1.0:
                raise RecipeError(f"[look] {key} = {getattr(self, key)!r}: expected an intensity in [0, 1]")
        for key in ("key_dir", "fill_dir"):
            if getattr(self, key)[2] >= 0:
                raise RecipeError(f"[look] {key} = {list(getattr(self, key))}: a light must point down "
                                  "(z < 0)")
        seen: dict[str, str] = {}
        for finish in FINISHES:
            for category in getattr(self, finish):
                if category in seen:
                    raise RecipeError(f"[look] category {category!r} is listed under both {seen[category]} "
                                      f"and {finish}")
                seen[category] = finish

    def finish(self, category: str) -> str:
        """The finish of an object category (``plastic`` if none lists it)."""
        return next((f for f in FINISHES if category in getattr(self, f)), "plastic")


def _add_texture(spec: mujoco.MjSpec, name: str, image: np.ndarray) -> None:
    tex = spec.add_texture(name=name, type=mujoco.mjtTexture.mjTEXTURE_2D, width=image.shape[1],
                           height=image.shape[0], nchannel=3)
    tex.data = image.tobytes()


def _material(spec: mujoco.MjSpec, name: str, look: Look, kind: str | None, *, specular: float,
              shininess: float, repeat: tuple[float, float] = (1.0, 1.0), uniform: bool = False) -> None:
    """A material ``name`` with, if textures are on and ``kind`` is set, a grey texture ``name`` of that kind
    (the geoms' own ``rgba`` colours it)."""
    mat = spec.add_material(name=name, specular=specular, shininess=shininess, reflectance=0.0,
                            texrepeat=list(repeat), texuniform=uniform)
    if look.textures and kind is not None:
        seed = zlib.crc32(name.encode())
        _add_texture(spec, name, texture(kind, look.texture_size, seed))
        mat.textures[mujoco.mjtTextureRole.mjTEXROLE_RGB] = name


def wall_boxes() -> dict[str, tuple[tuple[float, float], tuple[float, float]]]:
    """Each wall's centre (x, y) and half extents (x, y) in the table plane (m, world)."""
    (x0, x1), (y0, y1) = ROOM_X, ROOM_Y
    return {
        "back": ((x0, 0.0), (0.05, (y1 - y0) / 2.0)),
        "front": ((x1, 0.0), (0.05, (y1 - y0) / 2.0)),
        "left": ((0.5 * (x0 + x1), y1), ((x1 - x0) / 2.0, 0.05)),
        "right": ((0.5 * (x0 + x1), y0), ((x1 - x0) / 2.0, 0.05)),
    }


def dress_room(spec: mujoco.MjSpec, look: Look, floor_z: float) -> None:
    """Materials for the table top (``table/top``), the floor (geom ``floor``), four plaster walls and the
    lights; call after the table and floor exist."""
    _material(spec, "table_mat", look, "wood", specular=0.15, shininess=0.3, repeat=(3.0, 3.0))
    _material(spec, "floor_mat", look, "planks", specular=0.1, shininess=0.2,
              repeat=(look.floor_repeat, look.floor_repeat))
    _material(spec, "wall_mat", look, "plaster", specular=0.0, shininess=0.0, repeat=(2.0, 2.0))
    spec.material("wall_mat").emission = look.wall_glow
    for geom in spec.geoms:
        if geom.name == "table/top":
            geom.material, geom.rgba = "table_mat", [*look.table, 1.0]
        elif geom.name.startswith("table/leg"):
            geom.material = "table_mat"
        elif geom.name == "floor":
            geom.material, geom.rgba = "floor_mat", [*look.floor, 1.0]
    h = WALL_HEIGHT / 2.0
    walls = wall_boxes()
    for wall, ((cx, cy), (hx, hy)) in walls.items():
        spec.worldbody.add_geom(name=f"wall_{wall}", type=mujoco.mjtGeom.mjGEOM_BOX, size=[hx, hy, h],
                                pos=[cx, cy, floor_z + h], material="wall_mat", rgba=[*look.walls, 1.0],
                                contype=0, conaffinity=0,
                                group=VISUAL_GROUP, mass=0.0)
    vis = spec.visual
    vis.headlight.ambient = [look.ambient] * 3
    vis.headlight.diffuse = [look.headlight] * 3
    vis.headlight.specular = [0.0, 0.0, 0.0]
    for name, intensity, direction, pos, shadow in (
            ("key", look.key_light, look.key_dir, (-0.6, -1.2, 2.8), look.shadows),
            ("fill", look.fill_light, look.fill_dir, (1.6, 1.8, 2.0), False)):
        spec.worldbody.add_light(name=name, pos=list(pos), dir=list(direction), diffuse=[intensity] * 3,
                                 specular=[0.15 * intensity] * 3, castshadow=shadow,
                                 type=mujoco.mjtLightType.mjLIGHT_DIRECTIONAL)


def dress_objects(spec: mujoco.MjSpec, categories: Mapping[str, str], look: Look) -> int:
    """Give every visible geom of each instance (``instance -> category``) without a material of its own
    its finish's material; returns how many geoms were dressed."""
    made: set[str] = set()
    n = 0
    for geom in spec.geoms:
        head = geom.name.split("/", 1)[0]
        seen = geom.group in (0, VISUAL_GROUP)
        if head not in categories or "/" not in geom.name or not seen or geom.material:
            continue
        finish = "glass" if geom.rgba[3] < 1.0 else look.finish(categories[head])
        name = f"finish_{finish}"
        if name not in made:
            kind, specular, shininess = FINISHES[finish]
            _material(spec, name, look, kind, specular=specular, shininess=shininess, repeat=(8.0, 8.0),
                      uniform=True)
            made.add(name)
        geom.material = name
        n += 1
    return n

