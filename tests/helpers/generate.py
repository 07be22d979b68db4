"""Helpers of the generation tests: the shipped jar recipe, made cheap (or failing on purpose) for a test."""

from __future__ import annotations

from pathlib import Path

from mgdata.paths import recipes_dir

ALL_CAMERAS = 'cameras = ["front", "left", "right", "shoulder", "wrist"]'


def jar_recipe(folder: Path, *, cameras: tuple[str, ...] = ("front",), image_size: int = 32,
               edits: tuple[tuple[str, str], ...] = ()) -> Path:
    """``folder/jar.toml``: the shipped jar recipe with fewer, smaller cameras (fast to render and encode),
    its spec path made absolute, and the literal ``(old, new)`` text ``edits`` applied."""
    text = (recipes_dir() / "jar.toml").read_text()
    text = text.replace('spec = "specs/jar.toml"', f'spec = "{recipes_dir() / "specs" / "jar.toml"}"')
    text = text.replace(ALL_CAMERAS, "cameras = [" + ", ".join(f'"{c}"' for c in cameras) + "]")
    text = text.replace("image_size = 256", f"image_size = {image_size}")
    for old, new in edits:
        text = text.replace(old, new)
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / "jar.toml"
    path.write_text(text)
    return path


def low_yield_recipe(tmp: Path) -> Path:
    """The jar recipe with two 64² cameras and about half of its attempts failing honestly: the goal sphere's
    radius is 4 cm and the carried jar's centre is aimed up to 5 cm off its centre along x and y, so on about
    half of the draws (π·4² / 10² ≈ 0.50) the jar is held outside the goal and the gate finds the goal not
    reached after the whole motion (the most expensive failure to have rendered)."""
    return jar_recipe(tmp, cameras=("front", "wrist"), image_size=64, edits=(
        ("goal_radius = 0.05", "goal_radius = 0.04"),
        ("goal_dx = [-0.012, 0.012]", "goal_dx = [-0.05, 0.05]"),
        ("goal_dy = [-0.012, 0.012]", "goal_dy = [-0.05, 0.05]")))
