"""Suite-wide set-up."""

from __future__ import annotations

import signal

import pytest


def pytest_configure(config: pytest.Config) -> None:
    """Deliver Ctrl-C as ``KeyboardInterrupt`` here and in every process the tests start: a suite launched in
    the background by a non-interactive shell (``pytest &``) inherits SIGINT ignored, which its children
    would inherit too, and the tests of what a Ctrl-C does would then see nothing."""
    signal.signal(signal.SIGINT, signal.default_int_handler)
