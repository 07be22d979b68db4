"""What a browser may send one of mgdata's viser servers (the annotator's, the teleop operator's 3D scene),
checked where it enters.

viser decodes every websocket frame a client sends and hands it to its handlers as it comes: a frame that is
not a viser message ends the connection with a traceback on the server's terminal, a wrong-typed GUI value
raises inside a handler, a NaN or an out-of-range slider value reaches the app, and any client may ask for a
public share link (a tunnel through viser's share server, around the 127.0.0.1 bind) or start a file upload
it buffers in memory. :func:`guard` puts a gate in front of one server's handlers instead: a message that
passes is handed on exactly as viser's own reader would; one that does not gets one text frame
``error: <what was wrong>`` (no traceback) and the connection is closed (1008 policy violation; 1009 for a
message over :data:`MAX_MESSAGE_BYTES`), and the server goes on serving every other client.

A message passes when it is all of:

* a binary frame of at most :data:`MAX_MESSAGE_BYTES`, decoding to a msgpack map with a ``type``;
* one of the :data:`ACCEPTED` messages viser's browser client sends (sharing and file uploads are refused);
* of the declared field types (``msgspec``, strict: an int may stand for a float, nothing else is coerced),
  every number finite, every ``wxyz`` a unit quaternion;
* for a GUI update: only its ``value``, for a control this server has, of the control's type, a slider's
  within its range, a dropdown's or button group's one of its options, text at most
  :data:`MAX_TEXT_CHARS`;
* for a GUI or scene event: after the client's first camera message (viser ignores a client's events until
  then, but would already have changed the control's value for everyone).

Scene events for a node that no longer exists pass (a click on the previous object can arrive after the
next one is shown); viser ignores them.

Example::

    server = viser.ViserServer(host="127.0.0.1", port=8080)
    guard(server)     # before any client connects
    ...
    unguard(server)   # when the server stops
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Awaitable, Callable
from typing import Any

import msgspec
import viser
from viser import _messages
from viser.infra import _infra
from websockets.asyncio.server import ServerConnection

MAX_MESSAGE_BYTES = 1024 * 1024
"""The largest message a client may send (bytes; viser's client sends at most a few kB at a time)."""
MAX_TEXT_CHARS = 1000
"""The longest text a text box takes."""
UNIT_TOLERANCE = 1e-3
"""How far from 1 the norm of a client's quaternion may be (float32 round-off is ~1e-7)."""
RANGE_TOLERANCE = 1e-6
"""How far outside a slider's range a value may be, as a fraction of the range (step rounding)."""

ACCEPTED = frozenset({
    "ViewerCameraMessage", "GuiUpdateMessage", "GuiButtonHoldMessage", "GuiFormSubmitMessage",
    "GuiFormDirtyMessage", "CommandTriggerMessage", "SceneNodeClickMessage", "SceneNodeDragMessage",
    "ScenePointerMessage", "TransformControlsUpdateMessage", "TransformControlsDragStartMessage",
    "TransformControlsDragEndMessage", "GetRenderResponseMessage", "LocalStorageGetItemResponseMessage",
})
"""The messages viser's browser client sends that mgdata's servers take (``client/src``: ``sendMessage``)."""
REFUSED = {
    "ShareUrlRequest": "sharing is off: this server serves only where --host says",
    "ShareUrlDisconnect": "sharing is off: this server serves only where --host says",
    "FileTransferStartUpload": "this server takes no file uploads",
    "FileTransferPart": "this server takes no file uploads",
}
"""Messages viser's client can send that mgdata's servers refuse, and why."""
_EVENTS = ACCEPTED - {"ViewerCameraMessage", "GetRenderResponseMessage", "LocalStorageGetItemResponseMessage"}

_Consumer = Callable[[ServerConnection, Callable[[Any], None], type], Awaitable[None]]
_VISER_CONSUMER: _Consumer = _infra._message_consumer  # type: ignore[attr-defined]
_GUARDED: dict[int, viser.ViserServer] = {}
"""Guarded servers by port (viser's reader gets the connection, whose local port names the server)."""


class Refused(ValueError):
    """A client's message that does not pass; ``code`` is the websocket close code."""

    def __init__(self, reason: str, code: int = 1008) -> None:
        super().__init__(reason)
        self.code = code


def guard(server: viser.ViserServer) -> None:
    """Check every message a client sends ``server`` from now on (see the module docstring)."""
    if getattr(_infra, "_message_consumer", None) not in (_VISER_CONSUMER, _consume):
        raise RuntimeError("viser's message reader changed: mgdata.viser_gate needs updating")
    _infra._message_consumer = _consume  # type: ignore[attr-defined]
    _GUARDED[server.get_port()] = server


def unguard(server: viser.ViserServer) -> None:
    _GUARDED.pop(server.get_port(), None)


async def _consume(websocket: ServerConnection, handle_message: Callable[[Any], None],
                   message_class: type) -> None:
    """viser's per-connection reader, with the gate in front for a guarded server's connections."""
    server = _GUARDED.get(websocket.local_address[1])
    if server is None:
        await _VISER_CONSUMER(websocket, handle_message, message_class)
        return
    seen_camera = False
    while True:  # after a refusal the next recv raises ConnectionClosed, which ends viser's handler
        raw = await websocket.recv()
        try:
            message = admit(raw, server, seen_camera)
        except Refused as err:
            line = "error: " + " ".join(str(err).split())
            await websocket.send(line)
            await websocket.close(err.code, _close_reason(line))
            continue
        seen_camera = seen_camera or isinstance(message, _messages.ViewerCameraMessage)
        handle_message(message)


def admit(raw: bytes | str, server: viser.ViserServer, seen_camera: bool) -> Any:
    """The message ``raw`` decodes to, if it passes (module docstring); :class:`Refused` if not."""
    if not isinstance(raw, bytes):
        raise Refused("a text frame: viser's messages are binary msgpack")
    if len(raw) > MAX_MESSAGE_BYTES:
        raise Refused(f"a message of {len(raw)} bytes: the limit is {MAX_MESSAGE_BYTES}", 1009)
    try:
        mapping = msgspec.msgpack.decode(raw)
    except (msgspec.DecodeError, ValueError) as err:  # ValueError: a string that is not UTF-8
        raise Refused(f"not msgpack ({err})") from None
    if not isinstance(mapping, dict):
        raise Refused(f"expected a msgpack map, got {type(mapping).__name__}")
    if not isinstance(mapping.get("type"), str):
        raise Refused("a msgpack map without a 'type' string")
    name = mapping.pop("type")
    if name in REFUSED:
        raise Refused(f"{name}: {REFUSED[name]}")
    if name not in ACCEPTED:
        raise Refused(f"{name[:80]!r} is not a message a browser sends")
    cls = getattr(_messages, name)
    try:
        message = msgspec.convert(mapping, cls)
    except msgspec.ValidationError as err:
        raise Refused(f"{name}: {err}") from None
    _check_numbers(message, name)
    if name in _EVENTS and not seen_camera:
        raise Refused(f"{name} before the client's first camera message")
    if isinstance(message, _messages.GuiUpdateMessage):
        _check_gui_update(message, server)
    return message


def _check_numbers(value: Any, where: str) -> None:
    if isinstance(value, float) and not math.isfinite(value):
        raise Refused(f"{where}: {value} is not a finite number")
    if isinstance(value, (tuple, list)):
        for i, item in enumerate(value):
            _check_numbers(item, f"{where}[{i}]")
    elif isinstance(value, dict):
        for key, item in value.items():
            _check_numbers(item, f"{where}.{key}")
    elif dataclasses.is_dataclass(value):
        for field in dataclasses.fields(value):
            item = getattr(value, field.name)
            _check_numbers(item, f"{where}.{field.name}")
            if field.name == "wxyz" and abs(math.sqrt(sum(q * q for q in item)) - 1.0) > UNIT_TOLERANCE:
                raise Refused(f"{where}.wxyz: {item} is not a unit quaternion")


def _check_gui_update(message: _messages.GuiUpdateMessage, server: viser.ViserServer) -> None:
    if set(message.updates) != {"value"}:
        raise Refused(f"a GUI update sets only 'value', got {sorted(message.updates)[:5]}")
    handle = server.gui._gui_input_handle_from_uuid.get(message.uuid)
    if handle is None or handle._impl.removed:
        raise Refused(f"no control {message.uuid[:40]!r}")
    value, current = message.updates["value"], handle._impl.value
    label = getattr(handle, "label", message.uuid[:40])
    if isinstance(current, bool):
        ok = isinstance(value, bool)
    elif isinstance(current, float):
        ok = isinstance(value, (int, float)) and not isinstance(value, bool)
    elif isinstance(current, str):
        ok = isinstance(value, str)
    else:
        raise Refused(f"control {label!r} takes no value from a browser")
    if not ok:
        raise Refused(f"control {label!r}: expected a {type(current).__name__}, got {type(value).__name__}")
    if isinstance(value, float) and not math.isfinite(value):
        raise Refused(f"control {label!r}: {value} is not a finite number")
    low, high = getattr(handle, "min", None), getattr(handle, "max", None)
    if low is not None and high is not None:
        slack = RANGE_TOLERANCE * (high - low)
        if not low - slack <= value <= high + slack:
            raise Refused(f"control {label!r}: {value} is outside {low} … {high}")
    options = getattr(handle, "options", None)
    if options is not None and value not in options:
        raise Refused(f"control {label!r}: {str(value)[:80]!r} is not one of its options")
    if isinstance(value, str) and len(value) > MAX_TEXT_CHARS:
        raise Refused(f"control {label!r}: {len(value)} characters, at most {MAX_TEXT_CHARS}")


def _close_reason(line: str) -> str:
    """``line`` cut to the 123 bytes a websocket close reason may hold."""
    data = line.encode()
    return line if len(data) <= 123 else data[:120].decode(errors="ignore") + "…"  # "…" is 3 bytes
