"""Helpers of the generation tests: recipes written for a test."""

from __future__ import annotations

from pathlib import Path

from mgdata.paths import recipes_dir


def low_yield_recipe(tmp: Path) -> Path:
    """The jar recipe with two 64² cameras and about half of its attempts failing honestly: the goal sphere's
    radius is 4 cm and the carried jar's centre is aimed up to 5 cm off its centre along x and y, so on about
    half of the draws (π·4² / 10² ≈ 0.50) the jar is held outside the goal and the gate finds the goal not
    reached after the whole motion (the most expensive failure to have rendered)."""
    text = (recipes_dir() / "jar.toml").read_text()
    text = text.replace('spec = "specs/jar.toml"', f'spec = "{recipes_dir() / "specs" / "jar.toml"}"')
    cams = 'cameras = ["front", "left", "right", "shoulder", "wrist"]'
    text = text.replace(cams, 'cameras = ["front", "wrist"]')
    text = text.replace("image_size = 256", "image_size = 64")
    text = text.replace("goal_radius = 0.05", "goal_radius = 0.04")
    text = text.replace("goal_dx = [-0.012, 0.012]", "goal_dx = [-0.05, 0.05]")
    text = text.replace("goal_dy = [-0.012, 0.012]", "goal_dy = [-0.05, 0.05]")
    path = tmp / "jar.toml"
    path.write_text(text)
    return path
