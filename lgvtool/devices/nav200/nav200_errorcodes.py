"""Meanings of the NAV200 error reply fields F1 (class), F2 (group) and F3 (detail).

F0 is the function letter of the rejected command. Tables as in the player driver's
``nav200.cc``.
"""

from __future__ import annotations

#: F1, error class.
ERROR_CLASSES: dict[int, str] = {
    1: "user software",
    2: "transputer",
    3: "TPU-sensor link",
    4: "spurious measurement",
    5: "spurious angle measurement",
    6: "reflector memory link",
    7: "RS-232 link",
}

#: F2, error group.
ERROR_GROUPS: dict[int, str] = {
    1: "I/O telegram traffic",
    2: "standby",
    3: "reference reflectors",
    4: "download",
    5: "upload",
    6: "mapping",
    7: "positioning",
    8: "test",
    9: "navigation general",
}

#: F3, error detail.
ERROR_DETAILS: dict[int, str] = {
    1: "unknown command",
    2: "not implemented",
    3: "wrong command",
    4: "reflector not available",
    5: "wrong reflector number",
    6: "wrong data block",
    7: "input not possible",
    8: "invalid layer",
    9: "no reflectors in layer",
    10: "all reflectors transferred",
    11: "communication error",
    12: "reference-reflector init error",
    13: "wrong radii in effective range",
    14: "Flash EPROM fault",
    15: "wrong reflector radius",
}


def _lookup(table: dict[int, str], value: int) -> str:
    return table.get(value, f"unknown ({value})")


def error_class_meaning(f1: int) -> str:
    """Readable meaning of F1; ``"unknown (n)"`` for a value outside the table."""
    return _lookup(ERROR_CLASSES, f1)


def error_group_meaning(f2: int) -> str:
    """Readable meaning of F2; ``"unknown (n)"`` for a value outside the table."""
    return _lookup(ERROR_GROUPS, f2)


def error_detail_meaning(f3: int) -> str:
    """Readable meaning of F3; ``"unknown (n)"`` for a value outside the table."""
    return _lookup(ERROR_DETAILS, f3)
