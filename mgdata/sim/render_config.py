"""RenderConfig: how coarsely MuJoCo's classic renderer tessellates what it draws (``recipes/sim.toml``
``[render]``).

On llvmpipe (CPU OpenGL) a camera frame costs ~90 ns per submitted triangle, culled or not, plus fill; the
Panda's decimated visual meshes are ~17k triangles, but MuJoCo's defaults add ~23k more per frame that no one
sees: every plane is a grid of quads at its ``size[2]`` spacing (the 8 m floor at 0.1 m: 12,800 triangles),
every sphere, cylinder and the skybox is 28 slices × 16 stacks (~900-1,800 triangles each) and every box face
4 × 4 quads. :class:`~mgdata.sim.renderer.CameraRig` applies these settings to its own copy of the model when
it builds its GL context, so physics, the scene's model and any other viewer are untouched. docs/render.md
has the measurements.
"""

from __future__ import annotations

from dataclasses import dataclass

from mgdata.errors import RecipeError


@dataclass(frozen=True)
class RenderConfig:
    """Tessellation of MuJoCo's built-in shapes for the camera rig (``recipes/sim.toml`` ``[render]``).

    Attributes:
        plane_grid: spacing (m) of the quads a plane is drawn with (its ``size[2]``; MuJoCo draws planes as a
            grid so that per-vertex lighting varies across them; our lights are directional, so a coarse grid
            looks the same).
        numslices, numstacks: segments around and along spheres, cylinders, capsules and the skybox
            (MuJoCo: 28 and 16).
        numquads: quads per box-face side (MuJoCo: 4).
        far_lod: the robot's far level of detail, as a fraction of the original visual mesh faces (the
            near level keeps ``robot.VISUAL_DECIMATION``); 0: no far level.
        far_lod_distance: fixed cameras at least this far (m) from the robot base draw the far level.
    """

    plane_grid: float = 4.0
    numslices: int = 16
    numstacks: int = 8
    numquads: int = 1
    far_lod: float = 0.05
    far_lod_distance: float = 1.0

    def __post_init__(self) -> None:
        if not self.plane_grid > 0:
            raise RecipeError(f"[render] plane_grid = {self.plane_grid!r}: expected a positive number (m)")
        for key, low in (("numslices", 3), ("numstacks", 2), ("numquads", 1)):
            if getattr(self, key) < low:
                raise RecipeError(f"[render] {key} = {getattr(self, key)!r}: expected an integer >= {low}")
        if not 0.0 <= self.far_lod < 1.0:
            raise RecipeError(f"[render] far_lod = {self.far_lod!r}: expected a fraction in [0, 1) (0: off)")
        if self.far_lod_distance < 0:
            raise RecipeError(f"[render] far_lod_distance = {self.far_lod_distance!r}: expected a number "
                              ">= 0 (m)")
