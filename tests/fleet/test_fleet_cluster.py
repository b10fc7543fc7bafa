"""End to end: a real ``dask scheduler`` and ``dask worker`` as separate processes on loopback,
and ``lgvtool sweep --scheduler`` sending its tasks to them."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pandas as pd
import psutil
import pytest
from fleet_logs import make_log

START_TIMEOUT_S = 60.0
"""Longest wait for the scheduler to write its address, s."""


def _start(args: list[str], log: Path) -> subprocess.Popen[bytes]:
    with open(log, "wb") as out:
        return subprocess.Popen([sys.executable, "-m", "dask", *args], stdout=out,
                                stderr=subprocess.STDOUT, stdin=subprocess.DEVNULL,
                                start_new_session=True)


def _stop(proc: subprocess.Popen[bytes]) -> None:
    if proc.poll() is not None:
        return
    try:
        os.killpg(proc.pid, signal.SIGTERM)
        proc.wait(timeout=15)
    except subprocess.TimeoutExpired:
        os.killpg(proc.pid, signal.SIGKILL)
        proc.wait(timeout=15)
    except ProcessLookupError:
        pass


def _wait_for_address(path: Path, proc: subprocess.Popen[bytes], log: Path) -> str:
    deadline = time.monotonic() + START_TIMEOUT_S
    while time.monotonic() < deadline:
        if proc.poll() is not None:
            pytest.fail(f"dask scheduler exited: {log.read_text(errors='replace')[-2000:]}")
        try:
            return str(json.loads(path.read_text())["address"])
        except (OSError, ValueError, KeyError):
            time.sleep(0.1)
    pytest.fail(f"dask scheduler wrote no address within {START_TIMEOUT_S:g} s")


@pytest.mark.slow
def test_sweep_runs_on_a_separate_scheduler_and_worker(tmp_path, run_cli):
    logs = tmp_path / "logs"
    logs.mkdir()
    make_log(logs / "a.mcap", seed=3)
    make_log(logs / "b.mcap", seed=4)
    procs: list[subprocess.Popen[bytes]] = []
    try:
        info = tmp_path / "scheduler.json"
        scheduler = _start(["scheduler", "--host", "127.0.0.1", "--port", "0", "--no-dashboard",
                            "--scheduler-file", str(info), "--idle-timeout", "300"],
                           tmp_path / "scheduler.log")
        procs.append(scheduler)
        address = _wait_for_address(info, scheduler, tmp_path / "scheduler.log")
        assert address.startswith("tcp://127.0.0.1:")
        worker = _start(["worker", address, "--host", "127.0.0.1", "--nworkers", "1",
                         "--nthreads", "1", "--no-dashboard", "--death-timeout", "60",
                         "--local-directory", str(tmp_path / "worker")], tmp_path / "worker.log")
        procs.append(worker)

        out = tmp_path / "out"
        proc = run_cli("sweep", logs, "-e", "laser,pf", "--grid", "pf.particles=20,40",
                       "--scheduler", address, "-o", out, timeout=400)
        assert proc.returncode == 0, proc.stderr + (tmp_path / "worker.log").read_text()
        assert "4 task(s): 4 run now, 0 already done, 0 failed" in proc.stdout
        tidy = pd.read_parquet(out / "results.parquet")
        assert len(tidy) == 2 * 2 * 2 and (tidy["status"] == "ok").all()
        pids = set()
        for f in (out / "tasks").glob("*.json"):
            pids.add(int(json.loads(f.read_text())["worker"].rsplit(":", 1)[1]))
        assert len(pids) == 1
        ancestors = {p.pid for p in psutil.Process(pids.pop()).parents()}
        assert worker.pid in ancestors
    finally:
        for p in reversed(procs):
            _stop(p)
    assert all(p.poll() is not None for p in procs)
