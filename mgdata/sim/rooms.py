"""Procedural rooms around the tabletop: the environment axis of the OOD variants (docs/scenarios.md).

A room is built only from MuJoCo primitives and builtin textures (no downloaded assets): it recolours the
floor, the sky, the table top and the plain scene's walls (``mgdata.sim.materials``) and adds skirting,
windows, furniture and a light around the table. Everything it adds is
visual only (``contype = conaffinity = 0``, no mass, no joints, static in the world body), so the robot, the
table and the objects move exactly as without it (``tests/test_scenarios.py`` checks the trajectory bit for
bit). The floor plane keeps its geometry and friction; only its texture changes.

Example::

    spec, _ = assemble_spec(task, sim)      # world.assemble_spec calls add_room when task.room is set
    add_room(spec, "office")
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import mujoco

from mgdata.errors import SceneError
from mgdata.sim.materials import ROOM_X, ROOM_Y, WALL_HEIGHT, wall_boxes

RGB = tuple[float, float, float]

ROOM_GROUP = 2
"""Geom group of room geoms (drawn by default, like the objects' visual geoms)."""


@dataclass(frozen=True)
class RoomStyle:
    """One room: colours (RGB 0…1) of its floor checker, walls, sky gradient, windows, furniture and light.

    ``table`` tints the table top's wood texture (a room brings its own table finish: a framed view is mostly
    table). ``floor_builtin`` is MuJoCo's builtin texture (``checker`` or ``gradient``; ``flat`` =
    ``floor_a`` only), ``floor_repeat`` how often it tiles over the 8 m floor. ``furniture`` names the pieces
    (:data:`FURNITURE`) placed along the walls.
    """

    name: str
    floor_a: RGB
    floor_b: RGB
    floor_builtin: str
    floor_repeat: float
    wall: RGB
    trim: RGB
    sky_top: RGB
    sky_bottom: RGB
    window: RGB
    furniture: tuple[str, ...]
    accent: RGB
    light: RGB
    table: RGB


ROOM_STYLES: tuple[RoomStyle, ...] = (
    RoomStyle(
        "office",
        (0.55, 0.57, 0.60),
        (0.50, 0.52, 0.55),
        "checker",
        24.0,
        (0.86, 0.86, 0.82),
        (0.35, 0.36, 0.40),
        (0.55, 0.70, 0.90),
        (0.85, 0.90, 0.95),
        (0.70, 0.85, 1.00),
        ("desk", "shelf", "cabinet", "plant"),
        (0.20, 0.30, 0.55),
        (0.95, 0.95, 1.00),
        table=(0.58, 0.6, 0.62),
    ),
    RoomStyle(
        "kitchen",
        (0.92, 0.92, 0.90),
        (0.20, 0.20, 0.22),
        "checker",
        16.0,
        (0.93, 0.86, 0.62),
        (0.55, 0.30, 0.18),
        (0.60, 0.75, 0.95),
        (0.95, 0.93, 0.85),
        (0.80, 0.92, 1.00),
        ("counter", "fridge", "shelf", "stool"),
        (0.75, 0.20, 0.15),
        (1.00, 0.95, 0.85),
        table=(0.92, 0.91, 0.88),
    ),
    RoomStyle(
        "living_room",
        (0.45, 0.28, 0.16),
        (0.38, 0.23, 0.13),
        "checker",
        6.0,
        (0.70, 0.62, 0.52),
        (0.95, 0.95, 0.92),
        (0.30, 0.40, 0.65),
        (0.75, 0.65, 0.55),
        (0.95, 0.85, 0.60),
        ("sofa", "plant", "lamp", "shelf"),
        (0.30, 0.45, 0.30),
        (1.00, 0.88, 0.70),
        table=(0.36, 0.22, 0.14),
    ),
    RoomStyle(
        "classroom",
        (0.62, 0.66, 0.52),
        (0.58, 0.62, 0.48),
        "checker",
        20.0,
        (0.96, 0.93, 0.78),
        (0.25, 0.45, 0.30),
        (0.45, 0.65, 0.95),
        (0.90, 0.95, 1.00),
        (0.75, 0.90, 1.00),
        ("board", "desk", "desk", "shelf"),
        (0.15, 0.30, 0.20),
        (1.00, 1.00, 0.95),
        table=(0.8, 0.7, 0.52),
    ),
    RoomStyle(
        "workshop",
        (0.40, 0.40, 0.40),
        (0.36, 0.36, 0.37),
        "gradient",
        1.0,
        (0.55, 0.60, 0.66),
        (0.90, 0.65, 0.10),
        (0.35, 0.38, 0.42),
        (0.60, 0.62, 0.65),
        (0.85, 0.85, 0.80),
        ("workbench", "cabinet", "barrel", "shelf"),
        (0.85, 0.45, 0.10),
        (0.90, 0.92, 1.00),
        table=(0.45, 0.52, 0.42),
    ),
    RoomStyle(
        "laboratory",
        (0.85, 0.88, 0.90),
        (0.78, 0.82, 0.85),
        "checker",
        30.0,
        (0.95, 0.97, 1.00),
        (0.20, 0.55, 0.65),
        (0.80, 0.88, 0.95),
        (0.97, 0.98, 1.00),
        (0.85, 0.95, 1.00),
        ("counter", "cabinet", "fridge", "stool"),
        (0.10, 0.60, 0.70),
        (0.92, 0.97, 1.00),
        table=(0.18, 0.19, 0.21),
    ),
    RoomStyle(
        "bedroom",
        (0.75, 0.60, 0.70),
        (0.70, 0.55, 0.65),
        "checker",
        3.0,
        (0.72, 0.78, 0.90),
        (0.95, 0.95, 0.95),
        (0.10, 0.12, 0.30),
        (0.35, 0.30, 0.55),
        (0.30, 0.35, 0.60),
        ("bed", "lamp", "cabinet", "plant"),
        (0.60, 0.30, 0.50),
        (0.85, 0.80, 1.00),
        table=(0.94, 0.92, 0.88),
    ),
    RoomStyle(
        "warehouse",
        (0.50, 0.47, 0.40),
        (0.46, 0.43, 0.36),
        "gradient",
        1.0,
        (0.42, 0.35, 0.30),
        (0.20, 0.35, 0.60),
        (0.25, 0.25, 0.28),
        (0.45, 0.45, 0.48),
        (0.70, 0.75, 0.80),
        ("crates", "shelf", "barrel", "crates"),
        (0.60, 0.45, 0.25),
        (1.00, 0.97, 0.90),
        table=(0.78, 0.64, 0.42),
    ),
    RoomStyle(
        "studio",
        (0.12, 0.12, 0.14),
        (0.16, 0.16, 0.18),
        "checker",
        12.0,
        (0.15, 0.15, 0.17),
        (0.85, 0.15, 0.35),
        (0.05, 0.05, 0.07),
        (0.12, 0.10, 0.15),
        (0.90, 0.30, 0.50),
        ("lamp", "sofa", "plant", "board"),
        (0.90, 0.75, 0.20),
        (0.95, 0.90, 1.00),
        table=(0.12, 0.12, 0.13),
    ),
    RoomStyle(
        "garden_room",
        (0.30, 0.50, 0.22),
        (0.26, 0.45, 0.18),
        "checker",
        10.0,
        (0.88, 0.92, 0.80),
        (0.40, 0.30, 0.20),
        (0.45, 0.75, 1.00),
        (0.90, 0.97, 1.00),
        (0.80, 1.00, 0.90),
        ("plant", "plant", "bench", "plant"),
        (0.85, 0.55, 0.20),
        (1.00, 1.00, 0.90),
        table=(0.5, 0.32, 0.18),
    ),
)
"""The room styles, in a fixed order (the environment builder picks one per task)."""

ROOM_NAMES: tuple[str, ...] = tuple(s.name for s in ROOM_STYLES)

# Each furniture piece: primitives in its own frame (x along the wall, y into the room, z up from the floor):
# (type, half sizes, centre, colour key: "trim" | "accent" | "wall" | "dark" | "light" | "leaf").
_Part = tuple[str, tuple[float, float, float], tuple[float, float, float], str]
FURNITURE: dict[str, tuple[_Part, ...]] = {
    "desk": (
        ("box", (0.6, 0.35, 0.03), (0, 0, 0.74), "trim"),
        ("box", (0.03, 0.3, 0.37), (-0.55, 0, 0.37), "dark"),
        ("box", (0.03, 0.3, 0.37), (0.55, 0, 0.37), "dark"),
    ),
    "shelf": (
        ("box", (0.5, 0.18, 0.9), (0, 0, 0.9), "trim"),
        ("box", (0.45, 0.02, 0.15), (0, 0.17, 1.3), "accent"),
        ("box", (0.45, 0.02, 0.15), (0, 0.17, 0.6), "light"),
    ),
    "cabinet": (
        ("box", (0.4, 0.25, 0.5), (0, 0, 0.5), "accent"),
        ("box", (0.38, 0.01, 0.02), (0, 0.26, 0.8), "dark"),
    ),
    "plant": (
        ("cylinder", (0.18, 0.2, 0), (0, 0, 0.2), "trim"),
        ("sphere", (0.42, 0, 0), (0, 0, 0.75), "leaf"),
    ),
    "counter": (
        ("box", (0.9, 0.3, 0.45), (0, 0, 0.45), "light"),
        ("box", (0.92, 0.32, 0.02), (0, 0, 0.92), "dark"),
    ),
    "fridge": (
        ("box", (0.35, 0.33, 0.9), (0, 0, 0.9), "light"),
        ("box", (0.02, 0.02, 0.25), (0.25, 0.34, 1.1), "dark"),
    ),
    "stool": (
        ("cylinder", (0.2, 0.03, 0), (0, 0, 0.65), "accent"),
        ("cylinder", (0.03, 0.32, 0), (0, 0, 0.32), "dark"),
    ),
    "sofa": (
        ("box", (0.9, 0.4, 0.22), (0, 0, 0.22), "accent"),
        ("box", (0.9, 0.12, 0.35), (0, -0.3, 0.55), "accent"),
        ("box", (0.1, 0.4, 0.3), (-0.85, 0, 0.3), "dark"),
        ("box", (0.1, 0.4, 0.3), (0.85, 0, 0.3), "dark"),
    ),
    "lamp": (
        ("cylinder", (0.15, 0.02, 0), (0, 0, 0.02), "dark"),
        ("cylinder", (0.02, 0.7, 0), (0, 0, 0.7), "dark"),
        ("cylinder", (0.2, 0.15, 0), (0, 0, 1.5), "light"),
    ),
    "board": (
        ("box", (1.0, 0.02, 0.6), (0, 0, 1.5), "dark"),
        ("box", (1.05, 0.03, 0.04), (0, 0.02, 0.88), "trim"),
    ),
    "workbench": (
        ("box", (0.9, 0.4, 0.04), (0, 0, 0.85), "trim"),
        ("box", (0.85, 0.35, 0.02), (0, 0, 0.2), "dark"),
        ("box", (0.05, 0.05, 0.4), (-0.8, 0, 0.4), "accent"),
        ("box", (0.05, 0.05, 0.4), (0.8, 0, 0.4), "accent"),
    ),
    "barrel": (
        ("cylinder", (0.3, 0.45, 0), (0, 0, 0.45), "accent"),
        ("cylinder", (0.31, 0.03, 0), (0, 0, 0.7), "dark"),
    ),
    "bed": (
        ("box", (1.0, 0.7, 0.25), (0, 0.2, 0.25), "light"),
        ("box", (1.0, 0.05, 0.5), (0, -0.5, 0.5), "trim"),
        ("box", (0.95, 0.5, 0.05), (0, 0.35, 0.52), "accent"),
    ),
    "crates": (
        ("box", (0.35, 0.35, 0.35), (-0.4, 0, 0.35), "accent"),
        ("box", (0.3, 0.3, 0.3), (0.35, 0, 0.3), "trim"),
        ("box", (0.28, 0.28, 0.28), (-0.4, 0, 0.98), "trim"),
    ),
    "bench": (
        ("box", (0.8, 0.22, 0.03), (0, 0, 0.45), "trim"),
        ("box", (0.05, 0.2, 0.21), (-0.7, 0, 0.21), "dark"),
        ("box", (0.05, 0.2, 0.21), (0.7, 0, 0.21), "dark"),
    ),
}

_BUILTINS = {
    "checker": mujoco.mjtBuiltin.mjBUILTIN_CHECKER,
    "gradient": mujoco.mjtBuiltin.mjBUILTIN_GRADIENT,
    "flat": mujoco.mjtBuiltin.mjBUILTIN_FLAT,
}
_TYPES = {
    "box": mujoco.mjtGeom.mjGEOM_BOX,
    "cylinder": mujoco.mjtGeom.mjGEOM_CYLINDER,
    "sphere": mujoco.mjtGeom.mjGEOM_SPHERE,
}


def room_style(name: str) -> RoomStyle:
    """The style called ``name``, or a SceneError listing the styles."""
    for style in ROOM_STYLES:
        if style.name == name:
            return style
    raise SceneError(f"unknown room style {name!r}; styles: {', '.join(ROOM_NAMES)}")


def add_room(spec: mujoco.MjSpec, name: str, floor_z: float) -> None:
    """Turn ``spec``'s plain surroundings (the ``floor_mat`` material, the ``sky`` texture and the
    ``wall_*`` geoms of ``mgdata.sim.materials``) into room ``name``: floor, sky, walls and table top
    recoloured, windows, skirting, furniture along the walls and a tinted light; all visual only."""
    style = room_style(name)
    spec.geom("table/top").rgba = [*style.table, 1.0]
    spec.add_texture(name="room_floor", type=mujoco.mjtTexture.mjTEXTURE_2D,
                     builtin=_BUILTINS[style.floor_builtin],
                     rgb1=list(style.floor_a), rgb2=list(style.floor_b), width=256, height=256)
    floor = spec.material("floor_mat")
    floor.textures[mujoco.mjtTextureRole.mjTEXROLE_RGB] = "room_floor"
    floor.texrepeat = [style.floor_repeat, style.floor_repeat]
    spec.geom("floor").rgba = [1.0, 1.0, 1.0, 1.0]
    sky = spec.texture("sky")
    sky.rgb1, sky.rgb2 = list(style.sky_top), list(style.sky_bottom)
    colours = {
        "trim": style.trim,
        "accent": style.accent,
        "wall": style.wall,
        "dark": _shade(style.trim, 0.45),
        "light": _shade(style.wall, 1.1),
        "leaf": (0.18, 0.45, 0.16),
    }
    body = spec.worldbody  # static geoms of the world body: no new body, so the state size is unchanged
    x0, (y0, y1) = ROOM_X[0], ROOM_Y
    walls = wall_boxes()
    for wall, ((cx, cy), (hx, hy)) in walls.items():
        spec.geom(f"wall_{wall}").rgba = [*style.wall, 1.0]  # the plain scene's walls (mgdata.sim.materials)
        _geom(
            body,
            f"room/skirting_{wall}",
            "box",
            (hx + 0.01, hy + 0.01, 0.06),
            (cx, cy, floor_z + 0.06),
            style.trim,
        )
    for i, (wall, along) in enumerate((("back", -1.2), ("back", 1.2), ("left", 0.4), ("right", 1.4))):
        (cx, cy), (hx, hy) = walls[wall]
        inward = 0.06
        if wall == "back":
            pos, size = (cx + inward, along, floor_z + 1.7), (0.01, 0.55, 0.6)
        else:
            sign = -1.0 if wall == "left" else 1.0
            pos, size = (along, cy + sign * inward, floor_z + 1.7), (0.55, 0.01, 0.6)
        _geom(body, f"room/window_{i}", "box", size, pos, style.window)
    # furniture: one piece per slot against a wall; yaw turns the piece's local +y towards the room
    slots = (
        (x0 + 0.5, -1.7, -math.pi / 2),
        (x0 + 0.5, 1.6, -math.pi / 2),
        (0.3, y1 - 0.5, math.pi),
        (1.6, y0 + 0.5, 0.0),
    )
    for k, (piece, (px, py, yaw)) in enumerate(zip(style.furniture, slots, strict=True)):
        c, s = math.cos(yaw), math.sin(yaw)
        quat = [math.cos(yaw / 2.0), 0.0, 0.0, math.sin(yaw / 2.0)]
        for j, (kind, size, (lx, ly, lz), key) in enumerate(FURNITURE[piece]):
            pos = (px + c * lx - s * ly, py + s * lx + c * ly, floor_z + lz)
            _geom(body, f"room/{piece}_{k}_{j}", kind, size, pos, colours[key], quat=quat)
    spec.worldbody.add_light(
        name="room_light",
        pos=[0.4, 0.0, floor_z + WALL_HEIGHT - 0.1],
        dir=[0.0, 0.0, -1.0],
        diffuse=list(_shade(style.light, 0.08)),
        specular=[0.0, 0.0, 0.0],
        castshadow=False,
        type=mujoco.mjtLightType.mjLIGHT_DIRECTIONAL,
    )


def _shade(rgb: RGB, factor: float) -> RGB:
    return (min(1.0, rgb[0] * factor), min(1.0, rgb[1] * factor), min(1.0, rgb[2] * factor))


def _geom(
    body: mujoco.MjsBody,
    name: str,
    kind: str,
    size: tuple[float, ...],
    pos: tuple[float, float, float],
    rgb: RGB,
    *,
    quat: list[float] | None = None,
) -> None:
    body.add_geom(
        name=name,
        type=_TYPES[kind],
        size=[float(v) for v in size],
        pos=[float(v) for v in pos],
        quat=quat or [1.0, 0.0, 0.0, 0.0],
        rgba=[*rgb, 1.0],
        contype=0,
        conaffinity=0,
        group=ROOM_GROUP,
        mass=0.0,
    )
