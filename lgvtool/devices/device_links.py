"""Device links by URL: serial ports (pyserial) and TCP serial device servers.

URLs::

    serial:///dev/ttyS0?baud=19200&parity=E      # a serial port (parity N, E, O, M, S)
    serial:///dev/ttyUSB0?baud=115200&bytesize=8&stopbits=1
    /dev/ttyS0                                     # a bare path is a serial port too
    tcp://192.168.0.20:4001                        # a serial device server, raw TCP

Parameters the URL leaves out come from the device's defaults (the NAV200: 19200 baud, 8E1).

A :class:`Link` reads whatever bytes have arrived (``read(timeout)``, in the chunks they
arrived in), writes, closes and reopens. Every failure of an open link (a cable pulled, a USB
adapter gone, a peer that closed the connection) raises :class:`LinkDown`, so the caller can
log the gap and reconnect; a URL that cannot work at all raises :class:`LinkURLError`.
"""

from __future__ import annotations

import contextlib
import errno
import os
import select
import socket
import stat
from abc import ABC, abstractmethod
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING, Any, TypedDict
from urllib.parse import parse_qs, urlsplit

from lgvtool.errors import InputError, LgvError

if TYPE_CHECKING:
    import serial

__all__ = [
    "MCU_SERIAL_DEFAULTS",
    "NAV200_SERIAL_DEFAULTS",
    "Link",
    "LinkDown",
    "LinkFatal",
    "LinkSpec",
    "LinkURLError",
    "SerialLink",
    "TcpLink",
    "open_link",
    "parse_link_url",
]

_PARITIES = {"N": "N", "E": "E", "O": "O", "M": "M", "S": "S",
             "NONE": "N", "EVEN": "E", "ODD": "O", "MARK": "M", "SPACE": "S"}
_STOPBITS = {"1": 1.0, "1.5": 1.5, "2": 2.0}
_SERIAL_KEYS = {"baud", "parity", "bytesize", "stopbits"}
_TCP_KEYS = {"connect_timeout"}

#: Unix98 pseudo-terminal slaves have these major device numbers (Linux).
_PTY_MAJORS = range(136, 144)


class LinkURLError(InputError):
    """A link URL that cannot be used (unknown scheme, missing port, bad parameter)."""


class LinkDown(LgvError):
    """The link is not usable now (could not open, or failed while open); retry later."""


class LinkFatal(InputError):
    """The link can never work as given (not a serial device, permission denied, no such
    host): retrying is pointless, the recording stops (exit 2)."""


#: errors of opening a serial port that retrying cannot cure
_FATAL_ERRNOS = frozenset({errno.EACCES, errno.EPERM, errno.ENOTTY, errno.EISDIR, errno.ENXIO})


def _check_serial_target(path: str) -> None:
    """LinkFatal when ``path`` exists but can never be a serial port; a missing path (an
    unplugged USB adapter) is left to the retries."""
    try:
        st = os.stat(path)
    except FileNotFoundError:
        return
    except OSError as exc:
        if exc.errno in _FATAL_ERRNOS:
            raise LinkFatal(f"cannot open serial port {path}: {_reason(exc)}") from None
        return
    if not stat.S_ISCHR(st.st_mode):
        kind = "a directory" if stat.S_ISDIR(st.st_mode) else "not a character device"
        raise LinkFatal(f"serial port {path} is {kind}")
    try:
        fd = os.open(path, os.O_RDWR | os.O_NOCTTY | os.O_NONBLOCK)
    except OSError as exc:
        if exc.errno in _FATAL_ERRNOS:
            raise LinkFatal(f"cannot open serial port {path}: {_reason(exc)}") from None
        return
    try:
        if not os.isatty(fd):
            raise LinkFatal(f"serial port {path} is not a terminal device")
    finally:
        os.close(fd)


@dataclass(frozen=True)
class LinkSpec:
    """A parsed link URL.

    ``scheme`` is 'serial' or 'tcp'. For serial, ``target`` is the device path; for TCP, the
    host and ``port``. Serial settings: ``baud`` (bit/s), ``parity`` (one of N E O M S),
    ``bytesize`` (data bits), ``stopbits``. ``connect_timeout`` in s (TCP).
    """

    url: str
    scheme: str
    target: str
    port: int | None = None
    baud: int = 19200
    parity: str = "E"
    bytesize: int = 8
    stopbits: float = 1.0
    connect_timeout: float = 1.0

    def describe(self) -> str:
        """Short human-readable form, e.g. ``/dev/ttyS0 19200 8E1`` or ``tcp 10.0.0.2:4001``."""
        if self.scheme == "tcp":
            return f"tcp {self.target}:{self.port}"
        stop = f"{self.stopbits:g}"
        return f"{self.target} {self.baud} {self.bytesize}{self.parity}{stop}"


class SerialDefaults(TypedDict):
    """The serial settings a link URL may leave out: ``baud`` (bit/s), ``parity`` (one of
    N E O M S), ``bytesize`` (data bits), ``stopbits``."""

    baud: int
    parity: str
    bytesize: int
    stopbits: float


#: NAV200 serial defaults: 19200 baud, 8 data bits, even parity, 1 stop bit.
NAV200_SERIAL_DEFAULTS: SerialDefaults = {"baud": 19200, "parity": "E", "bytesize": 8, "stopbits": 1.0}
#: MCU serial defaults: 115200 baud, 8N1.
MCU_SERIAL_DEFAULTS: SerialDefaults = {"baud": 115200, "parity": "N", "bytesize": 8, "stopbits": 1.0}


def _one(query: dict[str, list[str]], key: str) -> str | None:
    values = query.get(key)
    return None if not values else values[-1]


def parse_link_url(url: str, defaults: SerialDefaults | None = None) -> LinkSpec:
    """Parse a link URL (``serial://PATH?...``, ``tcp://HOST:PORT`` or a bare device path).

    ``defaults`` gives the serial settings the URL does not (see ``NAV200_SERIAL_DEFAULTS``).
    Raises :class:`LinkURLError` for anything that cannot name a link.
    """
    text = url.strip()
    if not text:
        raise LinkURLError("empty link URL")
    base = (NAV200_SERIAL_DEFAULTS if defaults is None else defaults).copy()
    if "://" not in text:
        if text.startswith("/") or text.upper().startswith("COM"):
            text = "serial://" + text
        else:
            raise LinkURLError(f"link URL {url!r}: expected serial://PATH or tcp://HOST:PORT")
    parts = urlsplit(text)
    scheme = parts.scheme.lower()
    try:
        query = parse_qs(parts.query, keep_blank_values=True, strict_parsing=bool(parts.query))
    except ValueError:
        raise LinkURLError(f"link URL {url!r}: malformed parameters {parts.query!r}") from None
    if scheme == "serial":
        unknown = set(query) - _SERIAL_KEYS
        if unknown:
            raise LinkURLError(f"link URL {url!r}: unknown parameter(s) {', '.join(sorted(unknown))}"
                               f" (known: {', '.join(sorted(_SERIAL_KEYS))})")
        target = parts.netloc + parts.path
        if not target:
            raise LinkURLError(f"link URL {url!r}: no device path")
        spec = LinkSpec(url=url, scheme="serial", target=target, **base)
        return _serial_params(spec, query, url)
    if scheme == "tcp":
        unknown = set(query) - _TCP_KEYS
        if unknown:
            raise LinkURLError(f"link URL {url!r}: unknown parameter(s) {', '.join(sorted(unknown))}"
                               f" (known: {', '.join(sorted(_TCP_KEYS))})")
        try:
            port = parts.port
        except ValueError:
            raise LinkURLError(f"link URL {url!r}: the port must be a number 1-65535") from None
        if not parts.hostname or port is None or port == 0:
            raise LinkURLError(f"link URL {url!r}: expected tcp://HOST:PORT")
        if parts.path not in ("", "/"):
            raise LinkURLError(f"link URL {url!r}: a TCP link has no path")
        spec = LinkSpec(url=url, scheme="tcp", target=parts.hostname, port=port, **base)
        raw = _one(query, "connect_timeout")
        if raw is not None:
            try:
                value = float(raw)
            except ValueError:
                value = -1.0
            if not value > 0:
                raise LinkURLError(f"link URL {url!r}: connect_timeout must be a positive "
                                   f"number of seconds")
            spec = replace(spec, connect_timeout=value)
        return spec
    raise LinkURLError(f"link URL {url!r}: unknown scheme {parts.scheme!r} (serial, tcp)")


def _serial_params(spec: LinkSpec, query: dict[str, list[str]], url: str) -> LinkSpec:
    baud = _one(query, "baud")
    if baud is not None:
        if not baud.isdigit() or int(baud) <= 0:
            raise LinkURLError(f"link URL {url!r}: baud must be a positive integer, got {baud!r}")
        spec = replace(spec, baud=int(baud))
    parity = _one(query, "parity")
    if parity is not None:
        p = _PARITIES.get(parity.upper())
        if p is None:
            raise LinkURLError(f"link URL {url!r}: parity must be N, E, O, M or S, got {parity!r}")
        spec = replace(spec, parity=p)
    bytesize = _one(query, "bytesize")
    if bytesize is not None:
        if bytesize not in ("5", "6", "7", "8"):
            raise LinkURLError(f"link URL {url!r}: bytesize must be 5-8, got {bytesize!r}")
        spec = replace(spec, bytesize=int(bytesize))
    stopbits = _one(query, "stopbits")
    if stopbits is not None:
        if stopbits not in _STOPBITS:
            raise LinkURLError(f"link URL {url!r}: stopbits must be 1, 1.5 or 2, got {stopbits!r}")
        spec = replace(spec, stopbits=_STOPBITS[stopbits])
    return spec


class Link(ABC):
    """A byte link to one device. Not thread-safe: one thread reads and writes it."""

    def __init__(self, spec: LinkSpec) -> None:
        self.spec = spec
        #: a remark about how the link was opened (e.g. settings a pseudo-terminal ignores)
        self.note = ""

    @property
    @abstractmethod
    def is_open(self) -> bool:
        """True while the link is open."""

    @abstractmethod
    def open(self) -> None:
        """Open the link; :class:`LinkDown` when the device is not there (yet)."""

    @abstractmethod
    def close(self) -> None:
        """Close the link (no error if it is closed already)."""

    @abstractmethod
    def read(self, timeout: float) -> bytes:
        """Bytes that arrived within ``timeout`` s (b"" if none); :class:`LinkDown` on failure."""

    @abstractmethod
    def write(self, data: bytes) -> None:
        """Send ``data`` entirely; :class:`LinkDown` on failure."""

    def reconnect(self) -> None:
        """Close and open again."""
        self.close()
        self.open()

    def __enter__(self) -> Link:
        self.open()
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def _is_pty(path: str) -> bool:
    try:
        st = os.stat(path)
    except OSError:
        return False
    return stat.S_ISCHR(st.st_mode) and os.major(st.st_rdev) in _PTY_MAJORS


class SerialLink(Link):
    """A serial port through pyserial.

    A pseudo-terminal carries bytes, not bits: baud rate and parity mean nothing there, and
    some kernels refuse a parity setting on one. When the port is a pseudo-terminal and the
    requested settings are refused, the link opens it with no parity and says so in ``note``.
    """

    def __init__(self, spec: LinkSpec, *, write_timeout: float = 1.0) -> None:
        super().__init__(spec)
        self._ser: Any = None
        self._write_timeout = write_timeout

    @property
    def is_open(self) -> bool:
        return self._ser is not None

    def _serial(self, parity: str) -> serial.Serial:
        import serial

        stopbits = {1.0: serial.STOPBITS_ONE, 1.5: serial.STOPBITS_ONE_POINT_FIVE,
                    2.0: serial.STOPBITS_TWO}[self.spec.stopbits]
        return serial.Serial(
            self.spec.target, baudrate=self.spec.baud, bytesize=self.spec.bytesize,
            parity=parity, stopbits=stopbits, timeout=0, write_timeout=self._write_timeout,
            exclusive=True,
        )

    def open(self) -> None:
        if self._ser is not None:
            return
        _check_serial_target(self.spec.target)
        try:
            self._ser = self._serial(self.spec.parity)
            self.note = ""
            return
        except Exception as exc:  # pyserial raises several unrelated types
            first = exc
        if self.spec.parity != "N" and _is_pty(self.spec.target):
            try:
                self._ser = self._serial("N")
                self.note = "pseudo-terminal: parity setting not applied"
                return
            except Exception as exc:
                first = exc
        raise LinkDown(_reason(first)) from None

    def close(self) -> None:
        ser, self._ser = self._ser, None
        if ser is not None:
            with contextlib.suppress(Exception):
                ser.close()

    def read(self, timeout: float) -> bytes:
        ser = self._ser
        if ser is None:
            raise LinkDown("not open")
        try:
            ready, _, _ = select.select([ser.fileno()], [], [], max(0.0, timeout))
            if not ready:
                return b""
            return bytes(ser.read(max(1, ser.in_waiting)))
        except Exception as exc:  # SerialException, OSError, termios.error
            self.close()
            raise LinkDown(_reason(exc)) from None

    def write(self, data: bytes) -> None:
        ser = self._ser
        if ser is None:
            raise LinkDown("not open")
        try:
            ser.write(data)
        except Exception as exc:
            self.close()
            raise LinkDown(_reason(exc)) from None


class TcpLink(Link):
    """A raw TCP connection, e.g. to a serial device server."""

    def __init__(self, spec: LinkSpec) -> None:
        super().__init__(spec)
        self._sock: socket.socket | None = None

    @property
    def is_open(self) -> bool:
        return self._sock is not None

    def open(self) -> None:
        if self._sock is not None:
            return
        try:
            sock = socket.create_connection((self.spec.target, self.spec.port),
                                            timeout=self.spec.connect_timeout)
        except socket.gaierror as exc:
            if exc.errno == getattr(socket, "EAI_AGAIN", None):  # DNS not answering: retry
                raise LinkDown(str(exc.strerror or exc)) from None
            raise LinkFatal(f"cannot resolve host {self.spec.target!r}: "
                            f"{exc.strerror or exc}") from None
        except OSError as exc:
            raise LinkDown(_reason(exc)) from None
        sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        sock.setsockopt(socket.SOL_SOCKET, socket.SO_KEEPALIVE, 1)
        sock.setblocking(False)
        self._sock = sock

    def close(self) -> None:
        sock, self._sock = self._sock, None
        if sock is not None:
            with contextlib.suppress(OSError):
                sock.close()

    def read(self, timeout: float) -> bytes:
        sock = self._sock
        if sock is None:
            raise LinkDown("not open")
        try:
            ready, _, _ = select.select([sock], [], [], max(0.0, timeout))
            if not ready:
                return b""
            data = sock.recv(65536)
        except BlockingIOError:
            return b""
        except OSError as exc:
            self.close()
            raise LinkDown(_reason(exc)) from None
        if not data:
            self.close()
            raise LinkDown("connection closed by peer")
        return data

    def write(self, data: bytes) -> None:
        sock = self._sock
        if sock is None:
            raise LinkDown("not open")
        view = memoryview(data)
        try:
            while view:
                _, ready, _ = select.select([], [sock], [], 1.0)
                if not ready:
                    raise OSError(errno.ETIMEDOUT, "write timed out")
                sent = sock.send(view)
                view = view[sent:]
        except OSError as exc:
            self.close()
            raise LinkDown(_reason(exc)) from None


def _reason(exc: BaseException) -> str:
    """The OS's words for a failure (``No such file or directory``), else the exception's."""
    code = getattr(exc, "errno", None)
    if isinstance(code, int) and code > 0:
        return os.strerror(code)
    if isinstance(exc, OSError) and exc.strerror:
        return exc.strerror
    text = str(exc).strip()
    return text or type(exc).__name__


def open_link(url: str, defaults: SerialDefaults | None = None) -> Link:
    """A :class:`Link` (not yet opened) for ``url``; see :func:`parse_link_url`."""
    spec = parse_link_url(url, defaults)
    return TcpLink(spec) if spec.scheme == "tcp" else SerialLink(spec)
