"""Link URLs, and serial/TCP links over a pseudo-terminal and loopback TCP."""

from __future__ import annotations

import os
import socket
import tty

import pytest

from lgvtool.devices.device_links import (
    MCU_SERIAL_DEFAULTS,
    LinkDown,
    LinkURLError,
    SerialLink,
    TcpLink,
    open_link,
    parse_link_url,
)


def test_serial_url_with_parameters_and_defaults() -> None:
    s = parse_link_url("serial:///dev/ttyS0?baud=38400&parity=o&stopbits=2")
    assert (s.scheme, s.target, s.baud, s.parity, s.bytesize, s.stopbits) == \
        ("serial", "/dev/ttyS0", 38400, "O", 8, 2.0)
    d = parse_link_url("serial:///dev/ttyS0")
    assert (d.baud, d.parity, d.bytesize, d.stopbits) == (19200, "E", 8, 1.0)
    assert d.describe() == "/dev/ttyS0 19200 8E1"
    m = parse_link_url("/dev/ttyUSB0", MCU_SERIAL_DEFAULTS)
    assert (m.scheme, m.target, m.baud, m.parity) == ("serial", "/dev/ttyUSB0", 115200, "N")
    assert parse_link_url("serial://COM3").target == "COM3"


def test_tcp_url() -> None:
    s = parse_link_url("tcp://127.0.0.1:4001?connect_timeout=0.5")
    assert (s.scheme, s.target, s.port, s.connect_timeout) == ("tcp", "127.0.0.1", 4001, 0.5)
    assert isinstance(open_link("tcp://127.0.0.1:4001"), TcpLink)
    assert isinstance(open_link("serial:///dev/null"), SerialLink)


@pytest.mark.parametrize("url", [
    "", "ttyS0", "udp://1.2.3.4:5", "tcp://host", "tcp://host:0", "tcp://host:99999",
    "tcp://host:12/path", "serial://", "serial:///dev/x?baud=fast", "serial:///dev/x?parity=Q",
    "serial:///dev/x?bytesize=9", "serial:///dev/x?stopbits=3", "serial:///dev/x?speed=9600",
    "tcp://h:1?connect_timeout=-1",
])
def test_bad_urls_are_input_errors(url: str) -> None:
    with pytest.raises(LinkURLError):
        parse_link_url(url)


def test_serial_link_over_a_pseudo_terminal() -> None:
    master, slave = os.openpty()
    tty.setraw(slave)
    name = os.ttyname(slave)
    os.close(slave)
    link = open_link(f"serial://{name}?baud=19200&parity=E")
    try:
        link.open()
        assert link.is_open
        os.write(master, bytes(range(256)))
        got = b""
        for _ in range(50):
            got += link.read(0.05)
            if len(got) >= 256:
                break
        assert got == bytes(range(256))
        link.write(b"\x02\x05PP\x07")
        assert os.read(master, 100) == b"\x02\x05PP\x07"
        assert link.read(0.01) == b""
        # closing and opening again works (some kernels refuse a parity setting on a
        # pseudo-terminal the second time: the link then opens it without parity)
        link.reconnect()
        assert link.is_open
        link.write(b"again")
        assert os.read(master, 100) == b"again"
        # the far end goes away: the next read fails with LinkDown and closes the link
        os.close(master)
        master = -1
        with pytest.raises(LinkDown):
            for _ in range(20):
                link.read(0.05)
        assert not link.is_open
        with pytest.raises(LinkDown):
            link.open()  # the pseudo-terminal is gone
    finally:
        link.close()
        if master >= 0:
            os.close(master)


def test_tcp_link_reads_writes_and_reports_the_peer_closing() -> None:
    server = socket.socket()
    server.bind(("127.0.0.1", 0))
    server.listen(1)
    port = server.getsockname()[1]
    link = open_link(f"tcp://127.0.0.1:{port}")
    try:
        link.open()
        peer, _ = server.accept()
        peer.sendall(b"\xa5\x5a\x19")
        assert link.read(1.0) == b"\xa5\x5a\x19"
        link.write(b"hello")
        assert peer.recv(10) == b"hello"
        assert link.read(0.01) == b""
        peer.close()
        with pytest.raises(LinkDown, match="closed by peer"):
            link.read(1.0)
        assert not link.is_open
    finally:
        link.close()
        server.close()
    with pytest.raises(LinkDown):
        open_link(f"tcp://127.0.0.1:{port}?connect_timeout=0.5").open()
