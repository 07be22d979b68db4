"""Fixtures of the dataset tests: a small synthetic dataset written with the real writer."""

from __future__ import annotations

import shutil
from collections.abc import Callable
from pathlib import Path

import pytest

from tests.helpers.record import GENERATED, small_episodes, write_dataset


@pytest.fixture(scope="session")
def small_dataset(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A 4-episode, 3-camera 64² dataset of kept episodes, as ``generate`` writes (read-only: copy it
    before changing anything)."""
    return write_dataset(tmp_path_factory.mktemp("small") / "ds", small_episodes(), **GENERATED)


@pytest.fixture
def dataset_copy(small_dataset: Path, tmp_path: Path) -> Callable[[], Path]:
    def make() -> Path:
        dst = tmp_path / f"copy{len(list(tmp_path.iterdir()))}"
        shutil.copytree(small_dataset, dst)
        return dst
    return make
