"""Dynamixel Protocol 2.0 framing, device side: parse instruction packets, build status packets.

Packet: ``FF FF FD 00 | id | length (2, LE) | instruction | params | CRC-16 (2, LE)`` where ``length`` counts
instruction, params and CRC, the payload is byte-stuffed (``FF FF FD`` -> ``FF FF FD FD``) and the CRC is
CRC-16/BUYPASS (polynomial 0x8005) over everything before it. A status packet has instruction ``0x55``
followed by an error byte.
"""

from __future__ import annotations

from mgdata.teleop.emulator.packet import Instruction

HEADER = b"\xff\xff\xfd\x00"
BROADCAST = 0xFE
PING, READ, WRITE, SYNC_READ, SYNC_WRITE = 0x01, 0x02, 0x03, 0x82, 0x83
STATUS = 0x55
ERR_INSTRUCTION, ERR_CRC, ERR_ACCESS = 0x02, 0x03, 0x07


def _crc_table() -> list[int]:
    table = []
    for i in range(256):
        crc = i << 8
        for _ in range(8):
            crc = ((crc << 1) ^ 0x8005) if crc & 0x8000 else crc << 1
        table.append(crc & 0xFFFF)
    return table


_TABLE = _crc_table()


def crc16(data: bytes) -> int:
    crc = 0
    for byte in data:
        crc = ((crc << 8) ^ _TABLE[((crc >> 8) ^ byte) & 0xFF]) & 0xFFFF
    return crc


def stuff(payload: bytes) -> bytes:
    return payload.replace(b"\xff\xff\xfd", b"\xff\xff\xfd\xfd")


def unstuff(payload: bytes) -> bytes:
    return payload.replace(b"\xff\xff\xfd\xfd", b"\xff\xff\xfd")


def parse(buf: bytearray) -> Instruction | None:
    """Take one complete packet off the front of ``buf`` (dropping leading noise); ``None`` if incomplete."""
    start = buf.find(HEADER)
    if start < 0:
        del buf[: max(0, len(buf) - 3)]
        return None
    del buf[:start]
    if len(buf) < 7:
        return None
    length = int.from_bytes(buf[5:7], "little")
    total = 7 + length
    if len(buf) < total:
        return None
    packet = bytes(buf[:total])
    del buf[:total]
    crc_ok = crc16(packet[:-2]) == int.from_bytes(packet[-2:], "little")
    body = unstuff(packet[8:-2])
    return Instruction(packet[4], packet[7], body, crc_ok)


def status(servo_id: int, error: int, params: bytes) -> bytes:
    """A status packet from ``servo_id``."""
    payload = stuff(bytes([STATUS, error]) + params)
    head = HEADER + bytes([servo_id]) + (len(payload) + 2).to_bytes(2, "little")
    packet = head + payload
    return packet + crc16(packet).to_bytes(2, "little")
