"""Fixtures every test folder may use, registered for the whole suite by ``pytest_plugins`` in
``tests/conftest.py`` (a folder's own fixtures stay in its ``conftest.py``)."""

from __future__ import annotations

from pathlib import Path

import pytest

from mgdata.spec import SafetySpec, family_spec
from tests.helpers.repo import REPO


@pytest.fixture(scope="session")
def jar_spec() -> SafetySpec:
    """The jar family's released spec."""
    return family_spec("jar")


@pytest.fixture(scope="session")
def repo_root() -> Path:
    """The checkout the suite runs from."""
    return REPO
