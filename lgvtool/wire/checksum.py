"""Checksums of the two wire formats: the NAV200 XOR BCC and the MCU CRC-16/CCITT-FALSE."""

from __future__ import annotations

from functools import reduce
from operator import xor


def xor_bcc(data: bytes | bytearray | memoryview) -> int:
    """XOR of every byte of ``data`` (0 for empty input); the NAV200 block check character.

    Over a whole NAV200 telegram, BCC included, the result is 0 when the telegram is intact.
    """
    return reduce(xor, bytes(data), 0)


def _make_crc16_table() -> tuple[int, ...]:
    table = []
    for byte in range(256):
        crc = byte << 8
        for _ in range(8):
            crc = ((crc << 1) ^ 0x1021) if crc & 0x8000 else (crc << 1)
        table.append(crc & 0xFFFF)
    return tuple(table)


_CRC16_TABLE = _make_crc16_table()


def crc16_ccitt_false(data: bytes | bytearray | memoryview, crc: int = 0xFFFF) -> int:
    """CRC-16/CCITT-FALSE of ``data``: poly 0x1021, init 0xFFFF, no reflection, xorout 0.

    The check value of ``b"123456789"`` is 0x29B1. ``crc`` continues a running computation.
    """
    table = _CRC16_TABLE
    for byte in bytes(data):
        crc = ((crc << 8) & 0xFFFF) ^ table[((crc >> 8) ^ byte) & 0xFF]
    return crc
