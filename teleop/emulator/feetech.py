"""Feetech SCS/STS framing, device side: parse instruction packets, build status packets.

Packet: ``FF FF | id | length | instruction | params | checksum`` where ``length`` = params + 2 and the
checksum is ``~(id + length + instruction + params) & 0xFF``. A status packet carries an error byte in the
instruction's place. STS servos store multi-byte values little-endian.
"""

from __future__ import annotations

from mgdata.teleop.emulator.packet import Instruction

HEADER = b"\xff\xff"
BROADCAST = 0xFE
PING, READ, WRITE, SYNC_READ, SYNC_WRITE = 0x01, 0x02, 0x03, 0x82, 0x83


def checksum(body: bytes) -> int:
    return (~sum(body)) & 0xFF


def parse(buf: bytearray) -> Instruction | None:
    """Take one complete packet off the front of ``buf`` (dropping leading noise); ``None`` if incomplete."""
    start = buf.find(HEADER)
    if start < 0:
        del buf[: max(0, len(buf) - 1)]
        return None
    del buf[:start]
    while len(buf) >= 3 and buf[2] == 0xFF:  # a run of FF: the header is the last two
        del buf[0]
    if len(buf) < 4:
        return None
    total = 4 + buf[3]
    if len(buf) < total:
        return None
    packet = bytes(buf[:total])
    del buf[:total]
    ok = checksum(packet[2:-1]) == packet[-1]
    return Instruction(packet[2], packet[4], packet[5:-1], ok)


def status(servo_id: int, error: int, params: bytes) -> bytes:
    """A status packet from ``servo_id``."""
    body = bytes([servo_id, len(params) + 2, error]) + params
    return HEADER + body + bytes([checksum(body)])
