"""openpi's wire encoding: msgpack with numpy arrays as tagged maps (``openpi_client.msgpack_numpy``).

An ``ndarray`` travels as ``{b"__ndarray__": True, b"data": raw bytes, b"dtype": dtype.str, b"shape":
shape}`` and a numpy scalar as ``{b"__npgeneric__": True, b"data": item, b"dtype": dtype.str}``; object,
void and complex dtypes are refused. Anything openpi's client or server packs, :func:`unpackb` reads, and
the other way round.

Example::

    blob = packb({"observation/state": np.zeros(8, np.float32), "prompt": "close the jar"})
    unpackb(blob)["observation/state"].dtype   # float32
"""

from __future__ import annotations

from typing import Any

import msgpack
import numpy as np


def _pack_default(obj: Any) -> Any:
    if isinstance(obj, np.ndarray | np.generic) and obj.dtype.kind in ("V", "O", "c"):
        raise ValueError(f"unsupported dtype on the wire: {obj.dtype}")
    if isinstance(obj, np.ndarray):
        return {b"__ndarray__": True, b"data": np.ascontiguousarray(obj).tobytes(), b"dtype": obj.dtype.str,
                b"shape": obj.shape}
    if isinstance(obj, np.generic):
        return {b"__npgeneric__": True, b"data": obj.item(), b"dtype": obj.dtype.str}
    return obj


def _object_hook(obj: dict) -> Any:
    if b"__ndarray__" in obj:
        return np.ndarray(buffer=obj[b"data"], dtype=np.dtype(obj[b"dtype"]), shape=obj[b"shape"])
    if b"__npgeneric__" in obj:
        return np.dtype(obj[b"dtype"]).type(obj[b"data"])
    return obj


def packb(obj: Any) -> bytes:
    """Encode ``obj`` (dicts, lists, scalars, strings, numpy arrays) as openpi does."""
    return msgpack.packb(obj, default=_pack_default)


def unpackb(blob: bytes) -> Any:
    """Decode what :func:`packb` (or openpi's ``msgpack_numpy.Packer``) wrote; arrays are read-only views."""
    return msgpack.unpackb(blob, object_hook=_object_hook)
