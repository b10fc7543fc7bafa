"""Where fleet work runs: the check that the ``fleet`` extra is installed, and the address and
TLS security of a remote Dask scheduler.

A Dask scheduler and its workers can run code inside the client (Dask unpickles what workers
send back, and a worker's preload runs before any task): a scheduler must be trusted as much
as the machine lgvtool runs on. ``tls://`` with certificates authenticates it and encrypts the
traffic; a plain ``tcp://`` to another machine is neither, and lgvtool warns about it.
"""

from __future__ import annotations

import ipaddress
import sys
from dataclasses import dataclass
from typing import TYPE_CHECKING

from lgvtool.errors import InputError
from lgvtool.extras import available, require

if TYPE_CHECKING:
    from distributed.security import Security

FLEET_MODULES = ("dask", "distributed")
"""What the ``fleet`` extra installs for a cluster (pyarrow too, for sweep's Parquet files)."""


def fleet_available(modules: tuple[str, ...] = FLEET_MODULES) -> bool:
    """True when every module of ``modules`` can be imported (without importing it)."""
    return available(*modules)


def require_fleet(what: str, modules: tuple[str, ...] = FLEET_MODULES) -> None:
    """Raise one line naming the extra when ``what`` (e.g. ``sweep``) lacks its packages."""
    require(what, "fleet", *modules)


@dataclass(frozen=True)
class SchedulerSpec:
    """A remote Dask scheduler: its address and the PEM files of a ``tls://`` connection."""

    address: str
    ca_file: str | None = None
    cert: str | None = None
    key: str | None = None

    @property
    def tls(self) -> bool:
        """True for a ``tls://`` scheduler."""
        return self.address.startswith("tls://")

    def security(self) -> Security | None:
        """Dask's ``Security`` for this scheduler (None for tcp://)."""
        if not self.tls:
            return None
        from distributed.security import Security

        return Security(tls_ca_file=self.ca_file, tls_client_cert=self.cert,  # type: ignore[no-untyped-call,unused-ignore]
                        tls_client_key=self.key, require_encryption=True)

    def __str__(self) -> str:
        return self.address


def _is_loopback(host: str) -> bool:
    if host.lower() == "localhost":
        return True
    try:
        return ipaddress.ip_address(host.strip("[]")).is_loopback
    except ValueError:
        return False


def scheduler_spec(address: str | None, ca_file: str | None = None, cert: str | None = None,
                   key: str | None = None, *, warn: bool = True) -> SchedulerSpec | None:
    """Check ``--scheduler`` and its TLS options; None without a scheduler.

    A plain ``tcp://`` scheduler on another machine prints a warning on stderr.

    :raises InputError: a scheme other than tcp:// or tls://, no port, TLS options without a
        tls:// scheduler, tls:// without ``--tls-ca-file``, or the fleet extra missing.
    """
    tls_given = [n for n, v in (("--tls-ca-file", ca_file), ("--tls-cert", cert),
                                ("--tls-key", key)) if v]
    verb = "need" if len(tls_given) > 1 else "needs"
    if address is None:
        if tls_given:
            raise InputError(f"{', '.join(tls_given)} {verb} --scheduler tls://HOST:PORT")
        return None
    require_fleet("--scheduler")
    scheme, sep, rest = address.partition("://")
    host, _, port = rest.rpartition(":")
    if not sep or scheme not in ("tcp", "tls") or not host or not port.isdigit() \
            or not 0 < int(port) < 65536:
        raise InputError(f"--scheduler expects tls://HOST:PORT or tcp://HOST:PORT, got {address!r}")
    if scheme == "tcp" and tls_given:
        raise InputError(f"{', '.join(tls_given)} {verb} a tls:// scheduler, got {address!r}")
    if scheme == "tls" and ca_file is None:
        raise InputError("a tls:// scheduler needs --tls-ca-file (and --tls-cert when it asks "
                         "for client certificates)")
    if key is not None and cert is None:
        raise InputError("--tls-key needs --tls-cert")
    if scheme == "tcp" and not _is_loopback(host) and warn:
        print(f"lgvtool: warning: {address} is neither encrypted nor authenticated, and a "
              "scheduler and its workers can run code in this process; use tls:// "
              "(docs/fleet.md)", file=sys.stderr)
    return SchedulerSpec(address, ca_file, cert, key)
