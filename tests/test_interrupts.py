"""Ctrl-C held over a block is delivered afterwards, to the handler that was in force before."""

from __future__ import annotations

import os
import signal

import pytest

from mgdata.interrupts import sigint_deferred


def test_interrupt_inside_block_is_delivered_after_it() -> None:
    done = []
    with pytest.raises(KeyboardInterrupt), sigint_deferred():
        os.kill(os.getpid(), signal.SIGINT)
        done.append("rest of the block")
    assert done == ["rest of the block"]


def test_nested_blocks_deliver_once_at_the_outermost() -> None:
    done = []
    with pytest.raises(KeyboardInterrupt), sigint_deferred():
        with sigint_deferred():
            os.kill(os.getpid(), signal.SIGINT)
            done.append("inner")
        done.append("outer")  # the inner block must not cut the outer one short
    assert done == ["inner", "outer"]


def test_forgotten_when_not_reraised() -> None:
    with sigint_deferred(reraise=False):
        os.kill(os.getpid(), signal.SIGINT)
    assert signal.getsignal(signal.SIGINT) is signal.default_int_handler

