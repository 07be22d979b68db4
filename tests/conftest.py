"""Suite-wide set-up: shared fixtures come from ``tests.helpers.fixtures`` (``pytest_plugins``); helpers are
imported from ``tests.helpers`` (never from a conftest)."""

from __future__ import annotations

import signal

import pytest

pytest_plugins = ["tests.helpers.fixtures"]


def pytest_configure(config: pytest.Config) -> None:
    """Deliver Ctrl-C as ``KeyboardInterrupt`` here and in every process the tests start: a suite launched in
    the background by a non-interactive shell (``pytest &``) inherits SIGINT ignored, which its children
    would inherit too, and the tests of what a Ctrl-C does would then see nothing."""
    signal.signal(signal.SIGINT, signal.default_int_handler)
