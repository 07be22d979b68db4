"""An instruction packet as the emulated servos receive it (Dynamixel Protocol 2.0 or Feetech SCS/STS)."""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class Instruction:
    """One parsed instruction packet (``crc_ok`` False when its CRC or checksum did not match)."""

    id: int
    instruction: int
    params: bytes
    crc_ok: bool
