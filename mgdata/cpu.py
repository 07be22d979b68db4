"""The CPU features that change what mgdata writes: read once from ``/proc/cpuinfo``.

Two places depend on them: the H.264 encoder (x264's AVX-512 code path is not deterministic, so
:mod:`mgdata.record.video` keeps x264 to AVX2 on a machine that has AVX-512) and the fingerprint a Ray node
checks before it contributes attempts (:mod:`mgdata.generate.fingerprint`: MuJoCo's results can differ
between instruction sets).

Example::

    if "avx512f" in cpu_flags(): ...
"""

from __future__ import annotations

import functools
import platform
from pathlib import Path

CPUINFO = Path("/proc/cpuinfo")

RESULT_FLAGS = ("sse4_1", "sse4_2", "avx", "avx2", "fma", "avx512f", "avx512dq", "avx512bw", "avx512vl")
"""Instruction sets whose presence can change floating-point results (vectorised kernels, fused
multiply-add); two machines that differ in one of them may not reproduce each other's bytes."""


@functools.cache
def cpu_flags() -> frozenset[str]:
    """The ``flags`` of the first processor in ``/proc/cpuinfo`` (empty where there is none, e.g. macOS)."""
    try:
        text = CPUINFO.read_text()
    except OSError:
        return frozenset()
    for line in text.splitlines():
        key, _, value = line.partition(":")
        if key.strip() in ("flags", "Features"):
            return frozenset(value.split())
    return frozenset()


def has_avx512() -> bool:
    """True when the CPU has AVX-512 (foundation)."""
    return "avx512f" in cpu_flags()


def result_features() -> dict[str, object]:
    """The machine's identity as far as results go: architecture and :data:`RESULT_FLAGS` present."""
    flags = cpu_flags()
    return {"machine": platform.machine(), "flags": sorted(f for f in RESULT_FLAGS if f in flags)}
