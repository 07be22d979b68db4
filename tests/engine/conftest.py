"""Fixtures of the engine tests (builders: ``tests.helpers.scripted``)."""

from __future__ import annotations

import pytest

from mgdata.spec import SafetySpec, family_spec


@pytest.fixture(scope="session")
def jar_spec() -> SafetySpec:
    return family_spec("jar")
