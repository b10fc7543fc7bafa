"""The NAV350 telegrams lgvtool sends and receives: layouts, request builders, decoding.

A :class:`Telegram` is ``kind name value``; :meth:`Telegram.encode` frames it in either dialect
and :func:`decode_frame` turns a parsed :class:`~lgvtool.devices.nav350.nav350_cola.Frame` back into
one. Fixed layouts are listed in :data:`LAYOUTS` (one field code per argument: ``u8 u16 u32
i16 i32 flex``); the variable ones (the ``mNPOSGetData`` and ``mNMAPDoMapping`` replies,
landmark data, the layout upload and read-back) have their own walkers, which follow the
present-flags, never the request mask. A count larger than the bytes that follow it raises
:class:`~lgvtool.wire.wire_errors.BadLengthError` from :func:`decode_frame`.
Units are the wire's: mm, mdeg (1/1000 deg), ms ticks of the NAV350 clock.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any

from lgvtool.devices.nav350.nav350_cola import (
    BINARY,
    Frame,
    Reader,
    Writer,
    encode_frame,
    reader_for,
    writer_for,
)
from lgvtool.wire.wire_errors import BadLengthError, EncodeError, UnknownCommandError

__all__ = [
    "ERROR_CODES",
    "LAYOUTS",
    "MAX_LANDMARKS_PER_REQUEST",
    "MODES",
    "PASSWORD_CLIENT",
    "PASSWORD_SERVICE",
    "SOPAS_ERRORS",
    "AddedLandmarks",
    "Landmark",
    "LandmarkData",
    "LandmarkInfo",
    "LayerIds",
    "LayoutLandmark",
    "MappingResult",
    "PoseData",
    "PoseInfo",
    "ScanChannel",
    "StoredLandmark",
    "StoredLandmarks",
    "Telegram",
    "decode_frame",
    "do_mapping",
    "get_landmarks",
    "get_layer",
    "is_known",
    "map_config",
]

#: Operating modes of mNEVAChangeState.
MODES = {0: "power down", 1: "standby", 2: "mapping", 3: "landmark detection", 4: "navigation"}
MODE_STANDBY, MODE_MAPPING, MODE_LANDMARK, MODE_NAVIGATION = 1, 2, 3, 4
#: Access level 3 ("authorized client") password, and level 4 ("service").
PASSWORD_CLIENT, PASSWORD_SERVICE = 0xF4724744, 0x81BE23AA
#: errorCode of mNPOSGetData (and the other method replies).
ERROR_CODES = {0: "no error", 1: "wrong operating mode", 2: "asynchronous method terminated",
               3: "invalid data", 4: "no position available", 5: "timeout",
               6: "method already active", 7: "general error"}
#: Generic SOPAS sFA codes (that they apply to the NAV350 is inferred).
SOPAS_ERRORS = {1: "method access denied", 2: "unknown method index",
                3: "unknown variable index", 4: "local condition failed (value out of range)",
                5: "invalid data", 6: "unknown error", 7: "buffer overflow",
                8: "buffer underflow", 9: "unknown type", 10: "variable write access denied",
                11: "unknown command for name server", 12: "unknown CoLa command",
                13: "method server busy", 14: "flex array out of bounds",
                15: "unknown event index", 16: "CoLa-A value overflow",
                17: "CoLa-A invalid character", 18: "OSAI no message",
                19: "OSAI no answer message", 20: "internal error"}

_REQ = ("sMN", "sRN", "sWN", "sEN")
#: (kind, name) -> field codes of every fixed-layout telegram.
LAYOUTS: dict[tuple[str, str], tuple[str, ...]] = {
    # requests
    ("sMN", "SetAccessMode"): ("u8", "u32"),
    ("sMN", "mNEVAChangeState"): ("u8",),
    ("sMN", "mNPOSGetData"): ("u8", "u8"),
    ("sMN", "mNLMDGetData"): ("u8", "u8"),
    ("sMN", "mNPOSSetSpeed"): ("i16", "i16", "i32", "u32", "u8"),
    ("sMN", "mNPOSSetPose"): ("i32", "i32", "i32"),
    ("sMN", "mNLAYEraseLayout"): ("u8",),
    ("sMN", "mNLAYStoreLayout"): (),
    ("sMN", "mNLAYGetLayer"): ("u16",),
    ("sMN", "mNMAPDoMapping"): (),
    ("sMN", "mNAVGetTimestamp"): (),
    ("sMN", "mEEwriteall"): (),
    ("sWN", "NEVACurrLayer"): ("u16",),
    ("sWN", "NLMDLandmarkDataFormat"): ("u8", "u8", "u8"),
    ("sWN", "NAVScanDataFormat"): ("u8", "u8"),
    ("sWN", "NPOSPoseDataFormat"): ("u8", "u8"),
    ("sWN", "NLMDReflSize"): ("u16",),
    ("sWN", "NMAPMapCfg"): ("u8", "u8", "i32", "i32", "i32"),
    ("sWN", "EIHstCola"): ("u8",),
    ("sRN", "FirmwareVersion"): (),
    ("sRN", "SCdevicestate"): (),
    ("sRN", "ODoprh"): (),
    ("sRN", "ODpwrc"): (),
    ("sRN", "LocationName"): (),
    ("sRN", "LMDscandatacfg"): (),
    ("sRN", "DeviceIdent"): (),
    ("sRN", "SerialNumber"): (),
    # replies
    ("sAN", "SetAccessMode"): ("u8",),
    ("sAN", "mNEVAChangeState"): ("u8", "u8"),
    ("sAN", "mNPOSSetSpeed"): ("u8",),
    ("sAN", "mNPOSSetPose"): ("u8",),
    ("sAN", "mNLAYEraseLayout"): ("u8",),
    ("sAN", "mNLAYStoreLayout"): ("u8",),
    ("sAN", "mNAVGetTimestamp"): ("u8", "u32"),
    ("sAN", "mEEwriteall"): ("u8",),
    ("sRA", "FirmwareVersion"): ("flex",),
    ("sRA", "SCdevicestate"): ("u8",),
    ("sRA", "ODoprh"): ("u32",),
    ("sRA", "ODpwrc"): ("u32",),
    ("sRA", "LocationName"): ("flex",),
    ("sRA", "DeviceIdent"): ("flex", "flex"),
    ("sRA", "SerialNumber"): ("flex",),
    ("sRA", "LMDscandatacfg"): ("u16", "u8", "u8", "u8", "u16", "u8", "u8", "u8", "u8", "u16"),
    ("sFA", ""): ("u16",),
}
#: Variables whose write is acknowledged by an empty sWA.
WRITABLE = frozenset(n for (k, n) in LAYOUTS if k == "sWN")
#: Methods that may first answer with an empty sMA (mNMAPDoMapping and mNEVAChangeState do).
METHODS = frozenset(n for (k, n) in LAYOUTS if k == "sMN") | {
    "mNLAYAddLandmark", "mNLAYGetLandmark", "mNMAPDoMapping"}
#: Most global ids one mNLAYGetLandmark request asks for (the vendor driver uploads landmarks
#: in chunks of at most 50; the same bound for the read-back is lgvtool's choice).
MAX_LANDMARKS_PER_REQUEST = 50


# ---------------------------------------------------------------------------------- values
@dataclass(frozen=True, slots=True)
class PoseInfo:
    """The optional pose data: outputMode, the NAV350 ``timestamp_ms`` of the pose, meanDev,
    navMode, infoState (as reported; their units and codes are open) and the number of
    reflectors used."""

    output_mode: int
    timestamp_ms: int
    mean_dev: int
    nav_mode: int
    info_state: int
    used_reflectors: int


@dataclass(frozen=True, slots=True)
class LandmarkInfo:
    """A landmark's optional data: ids, type, subtype, quality, the NAV350 ``timestamp_ms`` at
    which it was measured, size (mm), hit count, mean echo, first and last scan index."""

    local_id: int
    global_id: int
    type: int
    subtype: int
    quality: int
    timestamp_ms: int
    size_mm: int
    hit_count: int
    mean_echo: int
    start_index: int
    end_index: int


@dataclass(frozen=True, slots=True)
class Landmark:
    """One detected reflector: cartesian (``x_mm, y_mm``), polar (``dist_mm``, ``phi_mdeg``)
    and optional data, each None when its present-flag is 0."""

    cartesian: tuple[int, int] | None = None
    polar: tuple[int, int] | None = None
    info: LandmarkInfo | None = None


@dataclass(frozen=True, slots=True)
class LandmarkData:
    """The landmark block: the filter setting and the reflectors."""

    filter: int
    landmarks: tuple[Landmark, ...]


@dataclass(frozen=True, slots=True)
class ScanChannel:
    """One scan or remission channel: ``content`` (DIST1, ANGL1, RSSI1), scale factor and
    offset, first angle (mdeg), angular step (mdeg), NAV350 ``timestamp_ms`` of its start and
    the values (DIST: mm, RSSI: counts)."""

    content: str
    scale_factor: float
    scale_offset: float
    start_angle_mdeg: int
    angle_res_mdeg: int
    timestamp_ms: int
    data: Sequence[int]
    """The values (an ``array`` when decoded: compare with ``list(...)``)."""


@dataclass(frozen=True, slots=True)
class PoseData:
    """A ``sAN mNPOSGetData`` reply (and, without a pose, ``sAN mNLMDGetData``): version,
    errorCode, the echoed wait and mask, then each block or None when its flag is 0.
    ``pose`` is ``(x_mm, y_mm, phi_mdeg)``, phi in 0..360000. ``info`` (the optional pose
    data) travels inside the pose block: its flag is on the wire only when the pose flag is
    1, so a reply with ``pose`` None and ``info`` set cannot be encoded."""

    version: int = 1
    error_code: int = 0
    wait: int = 1
    mask: int = 2
    pose: tuple[int, int, int] | None = None
    info: PoseInfo | None = None
    landmarks: LandmarkData | None = None
    scans: tuple[ScanChannel, ...] = ()
    remission: ScanChannel | None = None


@dataclass(frozen=True, slots=True)
class LayoutLandmark:
    """A landmark of a layout upload (mNLAYAddLandmark): x, y in mm, type, subtype, size mm,
    and the layers it belongs to."""

    x_mm: int
    y_mm: int
    type: int = 1
    subtype: int = 1
    size_mm: int = 80
    layers: tuple[int, ...] = (0,)


@dataclass(frozen=True, slots=True)
class AddedLandmarks:
    """The ``sAN mNLAYAddLandmark`` reply as read here: errorCode and the new global ids."""

    error_code: int
    ids: tuple[int, ...]


@dataclass(frozen=True, slots=True)
class MappingResult:
    """The ``sAN mNMAPDoMapping`` reply: errorCode, then the mapped reflectors (the landmark
    block, cartesian x, y in mm, polar distance mm and angle mdeg) or None when its
    present-flag is 0. No version field."""

    error_code: int
    landmarks: LandmarkData | None


@dataclass(frozen=True, slots=True)
class LayerIds:
    """The ``sAN mNLAYGetLayer`` reply (layout inferred): errorCode and the global ids of the
    landmarks of the layer asked for (dimensionless u16 ids)."""

    error_code: int
    ids: tuple[int, ...]


@dataclass(frozen=True, slots=True)
class StoredLandmark:
    """A landmark of the stored layout as ``sAN mNLAYGetLandmark`` returns it (layout
    inferred): its global id, x and y in mm, type, subtype, size in mm and its layers."""

    global_id: int
    x_mm: int
    y_mm: int
    type: int
    subtype: int
    size_mm: int
    layers: tuple[int, ...]


@dataclass(frozen=True, slots=True)
class StoredLandmarks:
    """The ``sAN mNLAYGetLandmark`` reply (layout inferred): errorCode and the landmarks
    asked for (positions in mm, see :class:`StoredLandmark`)."""

    error_code: int
    landmarks: tuple[StoredLandmark, ...]


# ---------------------------------------------------------------------------------- walkers
def _read_landmarks(r: Reader) -> LandmarkData:
    flt, n = r.group("BH")
    out = []
    for _ in range(n):
        cart = r.group("ii") if r.u16() else None
        polar = r.group("II") if r.u16() else None
        info = LandmarkInfo(*r.group("HHBHHIHHHHH")) if r.u16() else None
        out.append(Landmark(cart, polar, info))
    return LandmarkData(flt, tuple(out))


def _write_landmarks(w: Writer, block: LandmarkData) -> None:
    w.u8(block.filter).u16(len(block.landmarks))
    for lm in block.landmarks:
        if lm.cartesian is None:
            w.u16(0)
        else:
            w.u16(1).i32(lm.cartesian[0]).i32(lm.cartesian[1])
        if lm.polar is None:
            w.u16(0)
        else:
            w.u16(1).u32(lm.polar[0]).u32(lm.polar[1])
        i = lm.info
        if i is None:
            w.u16(0)
        else:
            (w.u16(1).u16(i.local_id).u16(i.global_id).u8(i.type).u16(i.subtype).u16(i.quality)
             .u32(i.timestamp_ms).u16(i.size_mm).u16(i.hit_count).u16(i.mean_echo)
             .u16(i.start_index).u16(i.end_index))


def _read_channel(r: Reader, rssi: bool) -> ScanChannel:
    content = r.text(5)
    sf, so, start, res, ts, n = r.group("ffiHIH")
    data = r.u16s(n) if rssi else r.u32s(n)
    return ScanChannel(content, sf, so, start, res, ts, data)


def _write_channel(w: Writer, ch: ScanChannel, rssi: bool) -> None:
    (w.text(ch.content).f32(ch.scale_factor).f32(ch.scale_offset).i32(ch.start_angle_mdeg)
     .u16(ch.angle_res_mdeg).u32(ch.timestamp_ms).u16(len(ch.data)))
    if rssi:
        w.u16s(ch.data)
    else:
        w.u32s(ch.data)


def _read_tail(r: Reader) -> tuple[LandmarkData | None, tuple[ScanChannel, ...],
                                   ScanChannel | None]:
    landmarks = _read_landmarks(r) if r.u16() else None
    scans = tuple(_read_channel(r, False) for _ in range(r.u16()))
    # the vendor driver always sends the remission flag; a reply that ends before it (as
    # parsers that expect absent blocks to be left out would send) has no remission block
    remission = _read_channel(r, True) if not r.done() and r.u16() else None
    return landmarks, scans, remission


def _write_tail(w: Writer, d: PoseData) -> None:
    if d.landmarks is None:
        w.u16(0)
    else:
        w.u16(1)
        _write_landmarks(w, d.landmarks)
    w.u16(len(d.scans))
    for ch in d.scans:
        _write_channel(w, ch, False)
    if d.remission is None:
        w.u16(0)
    else:
        w.u16(1)
        _write_channel(w, d.remission, True)


def _read_pose_data(r: Reader) -> PoseData:
    # the optional-pose flag is part of the pose block (the vendor parser reads it only when
    # the pose flag is set): without a pose, the landmark flag follows the pose flag
    version, err, wait, mask = r.group("HBBB")
    pose: tuple[int, int, int] | None = None
    info = None
    if r.u16():
        pose = r.group("iiI")
        info = PoseInfo(*r.group("BIiBIB")) if r.u16() else None
    landmarks, scans, remission = _read_tail(r)
    return PoseData(version, err, wait, mask, pose, info, landmarks, scans,
                    remission)


def _write_pose_data(w: Writer, d: PoseData) -> None:
    i = d.info
    if d.pose is None and i is not None:
        raise BadLengthError("mNPOSGetData: optional pose data without a pose cannot be "
                             "encoded (its present-flag is only sent after a pose)")
    w.u16(d.version).u8(d.error_code).u8(d.wait).u8(d.mask)
    if d.pose is None:
        w.u16(0)
    else:
        w.u16(1).i32(d.pose[0]).i32(d.pose[1]).u32(d.pose[2])
        if i is None:
            w.u16(0)
        else:
            (w.u16(1).u8(i.output_mode).u32(i.timestamp_ms).i32(i.mean_dev).u8(i.nav_mode)
             .u32(i.info_state).u8(i.used_reflectors))
    _write_tail(w, d)


def _read_landmark_only(r: Reader) -> PoseData:
    version, err, wait, mask = r.u16(), r.u8(), r.u8(), r.u8()
    landmarks, scans, remission = _read_tail(r)
    return PoseData(version, err, wait, mask, None, None, landmarks, scans, remission)


def _write_landmark_only(w: Writer, d: PoseData) -> None:
    w.u16(d.version).u8(d.error_code).u8(d.wait).u8(d.mask)
    _write_tail(w, d)


def _read_add(r: Reader) -> tuple[LayoutLandmark, ...]:
    out = []
    for _ in range(r.u16()):
        x, y, typ, sub, size, n = r.i32(), r.i32(), r.u8(), r.u8(), r.u16(), r.u16()
        out.append(LayoutLandmark(x, y, typ, sub, size, tuple(r.u16s(n))))
    return tuple(out)


def _write_add(w: Writer, marks: tuple[LayoutLandmark, ...]) -> None:
    w.u16(len(marks))
    for m in marks:
        w.i32(m.x_mm).i32(m.y_mm).u8(m.type).u8(m.subtype).u16(m.size_mm).u16(len(m.layers))
        w.u16s(m.layers)


def _read_added(r: Reader) -> AddedLandmarks:
    err = r.u8()
    return AddedLandmarks(err, tuple(r.u16s(r.u16())))


def _write_added(w: Writer, a: AddedLandmarks) -> None:
    w.u8(a.error_code).u16(len(a.ids)).u16s(a.ids)


def _read_mapping(r: Reader) -> MappingResult:
    err = r.u8()
    return MappingResult(err, _read_landmarks(r) if r.u16() else None)


def _write_mapping(w: Writer, m: MappingResult) -> None:
    w.u8(m.error_code)
    if m.landmarks is None:
        w.u16(0)
    else:
        w.u16(1)
        _write_landmarks(w, m.landmarks)


def _read_layer_ids(r: Reader) -> LayerIds:
    err = r.u8()
    return LayerIds(err, tuple(r.u16s(r.u16())))


def _write_layer_ids(w: Writer, v: LayerIds) -> None:
    w.u8(v.error_code).u16(len(v.ids)).u16s(v.ids)


def _read_id_list(r: Reader) -> tuple[int, ...]:
    return tuple(r.u16s(r.u16()))


def _write_id_list(w: Writer, ids: tuple[int, ...]) -> None:
    w.u16(len(ids)).u16s(ids)


def _read_stored(r: Reader) -> StoredLandmarks:
    err = r.u8()
    out = []
    for _ in range(r.u16()):
        gid, x, y, typ, sub, size, n = r.group("HiiBBHH")
        out.append(StoredLandmark(gid, x, y, typ, sub, size, tuple(r.u16s(n))))
    return StoredLandmarks(err, tuple(out))


def _write_stored(w: Writer, v: StoredLandmarks) -> None:
    w.u8(v.error_code).u16(len(v.landmarks))
    for m in v.landmarks:
        (w.u16(m.global_id).i32(m.x_mm).i32(m.y_mm).u8(m.type).u8(m.subtype).u16(m.size_mm)
         .u16(len(m.layers)).u16s(m.layers))


_CUSTOM: dict[tuple[str, str], tuple[Callable[[Reader], Any], Callable[[Writer, Any], None]]] = {
    ("sAN", "mNPOSGetData"): (_read_pose_data, _write_pose_data),
    ("sAN", "mNLMDGetData"): (_read_landmark_only, _write_landmark_only),
    ("sMN", "mNLAYAddLandmark"): (_read_add, _write_add),
    ("sAN", "mNLAYAddLandmark"): (_read_added, _write_added),
    ("sAN", "mNMAPDoMapping"): (_read_mapping, _write_mapping),
    ("sAN", "mNLAYGetLayer"): (_read_layer_ids, _write_layer_ids),
    ("sMN", "mNLAYGetLandmark"): (_read_id_list, _write_id_list),
    ("sAN", "mNLAYGetLandmark"): (_read_stored, _write_stored),
}


def is_known(kind: str, name: str) -> bool:
    """True for a telegram whose layout lgvtool knows (an empty ``sMA``/``sWA`` included)."""
    if kind in ("sMA", "sWA", "sEA"):
        return True
    key = (kind, name)
    return key in LAYOUTS or key in _CUSTOM


# ---------------------------------------------------------------------------------- telegram
@dataclass(frozen=True, slots=True)
class Telegram:
    """``kind name value``: ``value`` is the tuple of a fixed layout's fields, or the typed
    value of a variable one (:class:`PoseData`, ...); ``()`` for none. ``dialect`` is the one
    it was decoded from (encoding may choose either)."""

    kind: str
    name: str
    value: Any = ()
    dialect: str = BINARY
    size: int = field(default=0, compare=False)
    """Bytes of the frame it was decoded from (0 when built here)."""

    @property
    def is_request(self) -> bool:
        """True for host-to-device kinds (sMN, sRN, sWN, sEN)."""
        return self.kind in _REQ

    @property
    def is_error(self) -> bool:
        """True for an ``sFA`` error reply."""
        return self.kind == "sFA"

    @property
    def fields(self) -> tuple[Any, ...]:
        """The fixed-layout fields (``()`` for a typed value)."""
        return self.value if isinstance(self.value, tuple) else ()

    def encode(self, dialect: str | None = None) -> bytes:
        """The framed telegram in ``dialect`` (default: the one it came in)."""
        d = self.dialect if dialect is None else dialect
        w = writer_for(d)
        key = (self.kind, self.name)
        custom = _CUSTOM.get(key)
        if custom is not None:
            custom[1](w, self.value)
        elif self.kind in ("sMA", "sWA", "sEA") and key not in LAYOUTS:
            pass
        else:
            layout = LAYOUTS.get(key)
            if layout is None:
                raise UnknownCommandError(f"no layout for {self.kind} {self.name}")
            if len(layout) != len(self.fields):
                raise BadLengthError(f"{self.kind} {self.name} takes {len(layout)} values, "
                                     f"got {len(self.fields)}")
            for code, v in zip(layout, self.fields, strict=True):
                getattr(w, code)(v)
        return encode_frame(d, self.kind, self.name, w.data())

    def describe(self) -> str:
        """``sAN mNPOSGetData`` or ``sFA 2 (unknown method index)``."""
        if self.is_error and self.fields:
            code = int(self.fields[0])
            return f"sFA {code} ({SOPAS_ERRORS.get(code, 'unknown code')})"
        return f"{self.kind} {self.name}".rstrip()


def decode_frame(frame: Frame, size: int = 0) -> Telegram:
    """The telegram of a parsed frame: UnknownCommandError when its layout is unknown,
    BadLengthError when its arguments do not fit the layout."""
    key = (frame.kind, frame.name)
    r = reader_for(frame)
    custom = _CUSTOM.get(key)
    if custom is not None:
        value = custom[0](r)
    else:
        layout = LAYOUTS.get(key)
        if layout is None:
            if frame.kind in ("sMA", "sWA", "sEA"):
                layout = ()
            else:
                raise UnknownCommandError(f"unknown NAV350 telegram {frame.kind} {frame.name}")
        value = tuple(getattr(r, code)() for code in layout)
    r.end()
    return Telegram(frame.kind, frame.name, value, frame.dialect, size)


# ---------------------------------------------------------------------------------- builders
def request(kind: str, name: str, *values: object) -> Telegram:
    """A request telegram (binary by default)."""
    return Telegram(kind, name, tuple(values) if (kind, name) not in _CUSTOM else values[0])


def set_access_mode(level: int = 3, password: int = PASSWORD_CLIENT) -> Telegram:
    """``sMN SetAccessMode level password`` (3 F4724744: authorized client)."""
    return request("sMN", "SetAccessMode", level, password)


def change_state(mode: int) -> Telegram:
    """``sMN mNEVAChangeState mode`` (1 standby, 4 navigation, see :data:`MODES`)."""
    return request("sMN", "mNEVAChangeState", mode)


def current_layer(layer: int) -> Telegram:
    """``sWN NEVACurrLayer layer``."""
    return request("sWN", "NEVACurrLayer", layer)


def data_formats() -> tuple[Telegram, Telegram, Telegram]:
    """The three data-format writes of the vendor driver: landmark ``0 1 1``, scan ``1 1``,
    pose ``1 1``."""
    return (request("sWN", "NLMDLandmarkDataFormat", 0, 1, 1),
            request("sWN", "NAVScanDataFormat", 1, 1),
            request("sWN", "NPOSPoseDataFormat", 1, 1))


def get_pose_data(wait: int = 1, mask: int = 2) -> Telegram:
    """``sMN mNPOSGetData wait mask`` (1 2: wait for the next pose, pose + landmarks + scan)."""
    return request("sMN", "mNPOSGetData", wait, mask)


def speed_fields(vx: float, vy: float, omega: float, timestamp_ms: int,
                 coordbase: int = 0) -> tuple[int, int, int, int, int]:
    """mNPOSSetSpeed fields from vx, vy (m/s), omega (rad/s): mm/s, mm/s, mdeg/s truncated
    toward zero (as the vendor driver's casts do), the tick wrapped to 32 bits."""
    return (int(1000.0 * vx), int(1000.0 * vy), int(1000.0 * omega * 180.0 / math.pi),
            int(timestamp_ms) & 0xFFFFFFFF, int(coordbase))


def set_speed(vx: float, vy: float, omega: float, timestamp_ms: int,
              coordbase: int = 0) -> Telegram:
    """``sMN mNPOSSetSpeed`` from SI speeds (see :func:`speed_fields`); coordbase 0: the
    NAV350's own frame, 1: the global frame."""
    return request("sMN", "mNPOSSetSpeed", *speed_fields(vx, vy, omega, timestamp_ms, coordbase))


def add_landmarks(marks: tuple[LayoutLandmark, ...]) -> Telegram:
    """``sMN mNLAYAddLandmark`` with up to 50 landmarks."""
    return Telegram("sMN", "mNLAYAddLandmark", tuple(marks))


def map_config(mean: int, negative: int, x_mm: int, y_mm: int, phi_mdeg: int) -> Telegram:
    """``sWN NMAPMapCfg``: ``mean`` scans averaged (1..127, vendor default 50), ``negative``
    (0: map all reflectors, 1: only new ones), the vehicle pose the map is built from: x, y in
    mm (±10 000 000), phi in mdeg (±360 000)."""
    return request("sWN", "NMAPMapCfg", mean, negative, x_mm, y_mm, phi_mdeg)


def do_mapping() -> Telegram:
    """``sMN mNMAPDoMapping`` (needs mapping mode; answered by ``sMA``, then ``sAN`` with a
    :class:`MappingResult`, positions in mm)."""
    return request("sMN", "mNMAPDoMapping")


def get_layer(layer: int) -> Telegram:
    """``sMN mNLAYGetLayer layer`` (layer: u16 number): the global ids of that layer of the
    stored layout (reply :class:`LayerIds`; layout inferred)."""
    return request("sMN", "mNLAYGetLayer", layer)


def get_landmarks(ids: Sequence[int]) -> Telegram:
    """``sMN mNLAYGetLandmark count id…``: the stored landmarks with these global ids (reply
    :class:`StoredLandmarks`, positions in mm; layout inferred). At most
    :data:`MAX_LANDMARKS_PER_REQUEST` ids, else EncodeError (a ValueError)."""
    values = tuple(int(i) for i in ids)
    if len(values) > MAX_LANDMARKS_PER_REQUEST:
        raise EncodeError(f"mNLAYGetLandmark asks for at most {MAX_LANDMARKS_PER_REQUEST} "
                          f"landmarks, got {len(values)}")
    return Telegram("sMN", "mNLAYGetLandmark", values)


def reply(kind: str, name: str, *values: object) -> Telegram:
    """A reply telegram with fixed-layout ``values``."""
    return Telegram(kind, name, tuple(values))


def error_reply(code: int) -> Telegram:
    """``sFA code``."""
    return Telegram("sFA", "", (int(code),))
