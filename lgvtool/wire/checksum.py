"""Checksums of the two wire formats: the NAV200 XOR BCC and the MCU CRC-16/CCITT-FALSE."""

from __future__ import annotations

import binascii
from functools import reduce
from operator import xor


def xor_bcc(data: bytes | bytearray | memoryview) -> int:
    """XOR of every byte of ``data`` (0 for empty input); the NAV200 block check character.

    Over a whole NAV200 telegram, BCC included, the result is 0 when the telegram is intact.
    """
    return reduce(xor, bytes(data), 0)


def crc16_ccitt_false(data: bytes | bytearray | memoryview, crc: int = 0xFFFF) -> int:
    """CRC-16/CCITT-FALSE of ``data``: poly 0x1021, init 0xFFFF, no reflection, xorout 0.

    The check value of ``b"123456789"`` is 0x29B1. ``crc`` continues a running computation.
    Computed by :func:`binascii.crc_hqx`, the standard library's CRC of this polynomial
    without reflection, whose second argument is the initial value (about 30 times faster
    than a table in Python).
    """
    return binascii.crc_hqx(data, crc)
