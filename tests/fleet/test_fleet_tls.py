"""A tls:// Dask scheduler with certificates: lgvtool connects with --tls-* and evaluates on it;
without the certificates it is refused in one line."""

from __future__ import annotations

import json
import shutil
import subprocess
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

from lgvtool.cli import main

pytestmark = pytest.mark.skipif(shutil.which("openssl") is None, reason="needs openssl")


def _certificates(folder: Path) -> tuple[Path, Path, Path]:
    """A throw-away CA and one certificate for 127.0.0.1 (scheduler, worker and client)."""

    def run(*args: str) -> None:
        subprocess.run(["openssl", *args], cwd=folder, check=True, capture_output=True)

    run("req", "-x509", "-newkey", "rsa:2048", "-nodes", "-keyout", "ca.key", "-out", "ca.pem",
        "-days", "2", "-subj", "/CN=lgvtool test CA")
    run("req", "-newkey", "rsa:2048", "-nodes", "-keyout", "node.key", "-out", "node.csr",
        "-subj", "/CN=localhost")
    (folder / "ext.cnf").write_text("subjectAltName=DNS:localhost,IP:127.0.0.1\n")
    run("x509", "-req", "-in", "node.csr", "-CA", "ca.pem", "-CAkey", "ca.key",
        "-CAcreateserial", "-out", "node.pem", "-days", "2", "-extfile", "ext.cnf")
    return folder / "ca.pem", folder / "node.pem", folder / "node.key"


@pytest.fixture(scope="module")
def tls_cluster(tmp_path_factory: pytest.TempPathFactory) -> Iterator[tuple[Any, Path, Path, Path]]:
    from distributed import LocalCluster
    from distributed.security import Security

    ca, cert, key = _certificates(tmp_path_factory.mktemp("tls"))
    security = Security(tls_ca_file=str(ca), tls_scheduler_cert=str(cert),
                        tls_scheduler_key=str(key), tls_worker_cert=str(cert),
                        tls_worker_key=str(key), tls_client_cert=str(cert),
                        tls_client_key=str(key), require_encryption=True)
    with LocalCluster(n_workers=1, threads_per_worker=1, processes=False, protocol="tls://",
                      host="127.0.0.1", security=security, dashboard_address=None) as cluster:
        yield cluster, ca, cert, key


def test_open_client_speaks_tls_with_the_certificates(tls_cluster: Any) -> None:
    from lgvtool.errors import InputError
    from lgvtool.fleet.connect import SchedulerSpec
    from lgvtool.fleet.engine import open_client

    cluster, ca, cert, key = tls_cluster
    assert cluster.scheduler_address.startswith("tls://")
    spec = SchedulerSpec(cluster.scheduler_address, str(ca), str(cert), str(key))
    with open_client(spec, connect_timeout_s=10) as client:
        assert client.submit(pow, 2, 10).result() == 1024
    plain = cluster.scheduler_address.replace("tls://", "tcp://")
    with pytest.raises(InputError), open_client(plain, connect_timeout_s=5):
        pass


def test_evaluate_on_a_tls_scheduler(tls_cluster: Any, tmp_path: Path,
                                     capsys: pytest.CaptureFixture[str]) -> None:
    cluster, ca, cert, key = tls_cluster
    log = tmp_path / "run.mcap"
    main(["simulate", "-s", "paper-circle", "--duration", "12", "-o", str(log)])  # exits on error
    capsys.readouterr()
    main(["evaluate", str(log), "-e", "laser", "--json", "--scheduler", cluster.scheduler_address,
          "--tls-ca-file", str(ca), "--tls-cert", str(cert), "--tls-key", str(key)])
    out, err = capsys.readouterr()
    doc = json.loads(out)
    assert list(doc["estimators"]) == ["laser"] and doc["log"]
    assert "neither encrypted" not in err
    with pytest.raises(SystemExit) as failed:  # the scheduler refuses a client without TLS
        main(["evaluate", str(log), "-e", "laser", "--scheduler",
              cluster.scheduler_address.replace("tls://", "tcp://")])
    assert failed.value.code == 2
