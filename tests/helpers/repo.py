"""Paths of the checkout the tests run from."""

from __future__ import annotations

from pathlib import Path

REPO = Path(__file__).resolve().parents[2]
"""The repository root (``pyproject.toml``, ``docs/``, ``scripts/``, ``recipes/`` …)."""
