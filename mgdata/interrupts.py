"""Hold Ctrl-C while a block that must not be cut in half runs (a dataset commit, a state file update)."""

from __future__ import annotations

import contextlib
import signal
import threading
from collections.abc import Iterator


@contextlib.contextmanager
def sigint_deferred(reraise: bool = True) -> Iterator[None]:
    """Run the block with SIGINT held; afterwards deliver a SIGINT that came to the handler that was in force
    before (``reraise``: Python's own raises ``KeyboardInterrupt``, an enclosing ``sigint_deferred`` holds it
    in turn) or forget it. Outside the main thread (where signals cannot be handled) the block just runs."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    caught: list[int] = []
    previous = signal.signal(signal.SIGINT, lambda signum, frame: caught.append(signum))
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, previous)
    if caught and reraise:
        signal.raise_signal(signal.SIGINT)
