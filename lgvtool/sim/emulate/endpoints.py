"""The device ends of the emulated links: pseudo-terminals and TCP listeners.

A :class:`PtyEndpoint` is a pseudo-terminal whose slave a recorder opens as a serial port. It is
reached through a symbolic link that stays put (``DIR/nav200`` -> ``/dev/pts/N``), so that a
dropped link can come back as a new pseudo-terminal under the same name, as a USB serial
adapter does under its udev name. A :class:`TcpEndpoint` listens on a port and serves one client
at a time (a newer client replaces the older), as a serial device server does.

Both are non-blocking: the server loop polls :meth:`Endpoint.service`, reads what has arrived
and writes only while a client is there.
"""

from __future__ import annotations

import contextlib
import errno
import os
import select
import socket
import time
import tty
from abc import ABC, abstractmethod
from pathlib import Path

__all__ = ["Endpoint", "PtyEndpoint", "TcpEndpoint"]

#: After a client opens a pseudo-terminal, wait this long before streaming to it: the opener
#: (pyserial) flushes its input once the port is configured, and bytes sent before would be
#: lost without trace, s.
PTY_SETTLE = 0.25


class Endpoint(ABC):
    """One emulated device port."""

    def __init__(self, name: str, settle: float = 0.0) -> None:
        self.name = name
        #: wait this long after a client connects before writing to it, s
        self.settle = settle
        #: True while dropped (the port is gone)
        self.dropped = False
        #: monotonic time at which the present client connected, or None
        self.connected_at: float | None = None
        self.connections = 0

    @property
    @abstractmethod
    def url(self) -> str:
        """The URL a recorder opens (``serial://...`` or ``tcp://...``)."""

    @abstractmethod
    def describe(self) -> str:
        """Where the port is now, for people."""

    @abstractmethod
    def fileno(self) -> int | None:
        """File descriptor to wait on for incoming bytes while connected, else None."""

    @abstractmethod
    def service(self, now: float) -> None:
        """Accept or notice a client (or its leaving); call every loop."""

    @abstractmethod
    def read(self) -> bytes:
        """Bytes that arrived (b"" if none); never blocks."""

    @abstractmethod
    def _send(self, data: bytes) -> bool:
        """Write to the client; False if it is gone."""

    @abstractmethod
    def drop(self) -> None:
        """Take the port away (cable pulled): the client sees the link fail."""

    @abstractmethod
    def restore(self) -> None:
        """Bring the port back after :meth:`drop`."""

    @abstractmethod
    def close(self) -> None:
        """Release everything."""

    def ready(self, now: float) -> bool:
        """True when a client is connected and settled, so that bytes written reach it."""
        return self.connected_at is not None and now - self.connected_at >= self.settle

    def write(self, data: bytes, now: float) -> bool:
        """Write ``data`` if a client is ready; True if it was written."""
        if not self.ready(now):
            return False
        ok = self._send(data)
        if not ok:
            self.connected_at = None
        return ok


class PtyEndpoint(Endpoint):
    """A pseudo-terminal reached through the symbolic link ``link_dir/name``.

    ``settle``: see :data:`PTY_SETTLE` (0 for a device that only answers requests).
    """

    def __init__(self, name: str, link_dir: Path, settle: float = PTY_SETTLE) -> None:
        super().__init__(name, settle)
        self.link = Path(link_dir) / name
        self._master: int | None = None
        self.pts = ""
        self._open()

    def _open(self) -> None:
        master, slave = os.openpty()
        tty.setraw(slave)
        self.pts = os.ttyname(slave)
        os.close(slave)
        os.set_blocking(master, False)
        self._master = master
        tmp = self.link.with_name(self.link.name + ".new")
        with contextlib.suppress(FileNotFoundError):
            tmp.unlink()
        tmp.symlink_to(self.pts)
        tmp.replace(self.link)
        self.connected_at = None

    @property
    def url(self) -> str:
        return f"serial://{self.link}"

    def describe(self) -> str:
        return f"{self.url} (pseudo-terminal {self.pts})"

    def fileno(self) -> int | None:
        return self._master if self.connected_at is not None else None

    def service(self, now: float) -> None:
        if self._master is None:
            return
        p = select.poll()
        p.register(self._master, select.POLLIN)
        hung_up = any(ev & select.POLLHUP for _, ev in p.poll(0))
        if hung_up:
            self.connected_at = None
        elif self.connected_at is None:
            self.connected_at = now
            self.connections += 1

    def read(self) -> bytes:
        if self._master is None or self.connected_at is None:
            return b""
        try:
            return os.read(self._master, 65536)
        except BlockingIOError:
            return b""
        except OSError as exc:
            if exc.errno == errno.EIO:  # the client closed the port
                self.connected_at = None
                return b""
            raise

    def _send(self, data: bytes) -> bool:
        if self._master is None:
            return False
        view = memoryview(data)
        deadline = time.monotonic() + 1.0
        while view:
            try:
                n = os.write(self._master, view)
            except BlockingIOError:
                if time.monotonic() > deadline:
                    return False
                select.select([], [self._master], [], 0.05)
                continue
            except OSError:
                return False
            view = view[n:]
        return True

    def drop(self) -> None:
        # the name goes first, so that a client reopening at once finds nothing
        with contextlib.suppress(FileNotFoundError):
            self.link.unlink()
        if self._master is not None:
            os.close(self._master)
            self._master = None
        self.connected_at = None
        self.dropped = True

    def restore(self) -> None:
        if self._master is None:
            self._open()
        self.dropped = False

    def close(self) -> None:
        self.drop()


class TcpEndpoint(Endpoint):
    """A TCP listener on ``host:port`` (port 0: any free port) serving one client at a time."""

    def __init__(self, name: str, host: str = "127.0.0.1", port: int = 0) -> None:
        super().__init__(name)
        self.host = host
        self.port = port
        self._listener: socket.socket | None = None
        self._client: socket.socket | None = None
        self._listen()

    def _listen(self) -> None:
        sock = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
        sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        try:
            sock.bind((self.host, self.port))
        except OSError:
            sock.close()
            raise
        sock.listen(1)
        sock.setblocking(False)
        self.port = sock.getsockname()[1]
        self._listener = sock

    @property
    def url(self) -> str:
        return f"tcp://{self.host}:{self.port}"

    def describe(self) -> str:
        return f"{self.url} (TCP, one client at a time)"

    def fileno(self) -> int | None:
        return None if self._client is None else self._client.fileno()

    def service(self, now: float) -> None:
        if self._listener is None:
            return
        try:
            client, _ = self._listener.accept()
        except (BlockingIOError, InterruptedError):
            return
        except OSError:
            return
        client.setblocking(False)
        client.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        self._close_client()
        self._client = client
        self.connected_at = now
        self.connections += 1

    def _close_client(self) -> None:
        client, self._client = self._client, None
        if client is not None:
            with contextlib.suppress(OSError):
                client.close()
        self.connected_at = None

    def read(self) -> bytes:
        if self._client is None:
            return b""
        try:
            data = self._client.recv(65536)
        except (BlockingIOError, InterruptedError):
            return b""
        except OSError:
            self._close_client()
            return b""
        if not data:
            self._close_client()
        return data

    def _send(self, data: bytes) -> bool:
        if self._client is None:
            return False
        try:
            self._client.sendall(data)
        except BlockingIOError:
            return False
        except OSError:
            self._close_client()
            return False
        return True

    def drop(self) -> None:
        # the listener goes first, so that a client reconnecting at once is refused
        if self._listener is not None:
            with contextlib.suppress(OSError):
                self._listener.close()
            self._listener = None
        self._close_client()
        self.dropped = True

    def restore(self) -> None:
        if self._listener is None:
            self._listen()
        self.dropped = False

    def close(self) -> None:
        self.drop()
