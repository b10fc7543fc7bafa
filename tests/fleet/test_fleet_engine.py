"""The engine on a real local Dask cluster: every task once, errors kept apart, chunking."""

from __future__ import annotations

import os
import time

import pytest
from fleet_logs import ship_by_value

from lgvtool.errors import MissingDataError
from lgvtool.fleet.engine import Outcome, _Chunker, open_client, run_tasks

ship_by_value(__name__)


def square_or_fail(x: int) -> int:
    if x % 5 == 3:
        raise MissingDataError(f"task {x} has no motion data")
    if x % 5 == 4:
        raise RuntimeError(f"task {x} broke")
    return x * x


def whoami(x: int) -> int:
    time.sleep(0.05)
    return os.getpid()


@pytest.fixture(scope="module")
def client():
    with open_client(workers=2) as c:
        yield c


def test_every_task_once_with_its_error(client):
    outs: list[Outcome] = list(run_tasks(square_or_fail, range(40), client=client, progress=False))
    assert sorted(o.index for o in outs) == list(range(40))
    for o in outs:
        assert o.task == o.index
        if o.index % 5 == 3:
            assert not o.ok and o.input_error and o.error.startswith("MissingDataError: task")
        elif o.index % 5 == 4:
            assert not o.ok and not o.input_error and "RuntimeError" in o.error
            assert "Traceback" in o.detail
        else:
            assert o.ok and o.value == o.index ** 2 and o.error is None


def test_trivial_tasks_are_chunked_and_all_delivered(client):
    n = 3000
    t0 = time.perf_counter()
    outs = list(run_tasks(abs, range(-n, 0), client=client, progress=False))
    elapsed = time.perf_counter() - t0
    assert sorted(o.value for o in outs) == list(range(1, n + 1))
    assert elapsed < 30.0


def test_slow_tasks_spread_over_both_workers(client):
    pids = {o.value for o in run_tasks(whoami, range(16), client=client, progress=False)}
    assert len(pids) == 2


def test_chunk_size_follows_task_time():
    c = _Chunker(target_s=0.2, max_chunk=256)
    assert c.size(pending=1000, slots=2) == 1
    c.observe([0.001] * 4)
    sizes = [c.size(pending=10_000, slots=2) for _ in range(10)]
    assert sizes[:4] == [2, 4, 8, 16] and sizes[-1] == 200        # doubling up to 0.2 s
    assert c.size(pending=100, slots=2) == 25                      # a fair share near the end
    c.observe([1.0] * 25)                                          # tasks turned slow
    assert c.size(pending=10_000, slots=2) == 1


def test_progress_bar_on_stderr(client, capsys):
    list(run_tasks(abs, range(10), client=client, progress=True, label="demo"))
    err = capsys.readouterr().err
    assert "demo [" in err and "10/10" in err


def test_no_tasks_starts_no_cluster():
    assert list(run_tasks(abs, [], scheduler="tcp://127.0.0.1:9", progress=False)) == []


def test_local_cluster_leaves_port_8787_alone():
    """A local cluster's HTTP server takes a free loopback port: with 8787 held by another
    program (a dashboard of the user's own), no warning, and nothing listens on 8787 for it."""
    import socket
    import warnings

    holder = socket.socket()
    try:
        holder.bind(("127.0.0.1", 8787))
    except OSError:
        pytest.skip("port 8787 is in use here")
    holder.listen()
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("error")
            with open_client(workers=1) as c:
                http = c.cluster.scheduler.http_server
                assert http.address == "127.0.0.1" and http.port != 8787
    finally:
        holder.close()
