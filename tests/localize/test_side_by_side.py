"""The estimators run side by side on threads: the same results as one after the other, a
failure stops the others and is the one raised, numba made ready before the threads start, and
one thread by default on the numpy path."""

from __future__ import annotations

import json
import threading
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest
from simlogs import simulate_log

from lgvtool.errors import InputError
from lgvtool.localize.replay_driver import (
    ReplayResult,
    load_log,
    replay_data,
    run_side_by_side,
)
from lgvtool.log import LogReader

ALL = ["laser", "deadreckoning", "ekf", "pf-paper", "pf"]


@pytest.fixture(scope="module")
def sim_log(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return simulate_log(tmp_path_factory.mktemp("side") / "circle.mcap", 30.0, seed=4)


def _replay(log: Path, threads: int) -> tuple[ReplayResult, int]:
    """The replay of ``log`` on ``threads`` threads, and the observations it reported."""
    reader = LogReader(log)
    cfg = reader.config()
    data = load_log(reader, cfg.reflectors or None)
    counted: list[int] = []
    res = replay_data(data, ALL, config=cfg, seed=3, threads=threads,
                      progress=counted.append, settings={"pf.particles": 300})
    return res, sum(counted)


def test_threads_give_the_same_results_as_one(sim_log: Path) -> None:
    one, one_count = _replay(sim_log, 1)
    many, many_count = _replay(sim_log, 4)
    assert list(many.estimates) == ALL == list(one.estimates)
    for name in ALL:
        a, b = one.estimates[name], many.estimates[name]
        # both runs on this CPU, the same arithmetic in the same order on every thread:
        # identical on any machine (no stored figures compared across CPUs)
        for field in ("t_ns", "x", "y", "heading", "covariance", "particles", "ess"):
            assert np.array_equal(getattr(a, field), getattr(b, field), equal_nan=True), \
                (name, field)
    for name in ("pf-paper", "pf"):
        ca, cb = one.clouds[name], many.clouds[name]
        assert len(ca) == len(cb) > 0
        assert all(p[0] == q[0] and np.array_equal(p[1], q[1]) for p, q in zip(ca, cb, strict=True))
    assert one.settings == many.settings
    # every observation counted once, whichever thread ran it
    assert one_count == many_count > 0


def test_jobs_run_at_once_costliest_first() -> None:
    started: list[str] = []
    both = threading.Barrier(2, timeout=10)

    def run(job: str, report: Callable[[int], None] | None) -> str:
        started.append(job)
        if job in ("big", "small"):
            both.wait()  # returns only when the two run at the same time
        return job.upper()

    out = run_side_by_side(["small", "big", "tiny"], run, [1.0, 5.0, 0.5], threads=2)
    assert out == ["SMALL", "BIG", "TINY"]  # in job order
    assert started[0] == "big"


def test_a_failure_stops_the_others_and_is_raised() -> None:
    stopped: list[str] = []

    def run(job: str, report: Callable[[int], None] | None) -> str:
        if job == "bad":
            time.sleep(0.05)
            raise InputError("bad estimator")
        try:
            for _ in range(1000):  # a long run that reports as the estimators do
                assert report is not None
                report(1)
                time.sleep(0.01)
        except BaseException:
            stopped.append(job)
            raise
        return job

    t0 = time.monotonic()
    with pytest.raises(InputError, match="bad estimator"):
        run_side_by_side(["long", "bad"], run, [2.0, 1.0], threads=2)
    assert stopped == ["long"]
    assert time.monotonic() - t0 < 5.0  # not the 10 s the long run would take


def test_one_thread_runs_in_the_caller() -> None:
    seen: list[threading.Thread] = []

    def run(job: int, report: Callable[[int], None] | None) -> int:
        seen.append(threading.current_thread())
        return job * 2

    assert run_side_by_side([1, 2, 3], run, [1.0, 2.0, 3.0], threads=1) == [2, 4, 6]
    assert set(seen) == {threading.current_thread()}


def test_evaluate_on_threads_prints_the_same_document(sim_log: Path, run_cli) -> None:
    docs = []
    for threads in ("1", "3"):
        res = run_cli("evaluate", sim_log, "--json", "--seed", "2", "--threads", threads)
        assert res.returncode == 0, res.stderr
        docs.append(json.loads(res.stdout))
    assert list(docs[0]["estimators"]) == ALL
    assert docs[0] == docs[1]


def test_prepare_runs_once_before_the_threads_only() -> None:
    events: list[str] = []

    def run(job: str, report: Callable[[int], None] | None) -> str:
        events.append(job)
        return job

    run_side_by_side(["a", "b"], run, [1.0, 2.0], threads=1,
                     prepare=lambda: events.append("prepare"))
    assert events == ["a", "b"]  # in the caller: nothing to prepare
    events.clear()
    run_side_by_side(["a", "b"], run, [1.0, 2.0], threads=2,
                     prepare=lambda: events.append("prepare"))
    assert events[0] == "prepare" and sorted(events[1:]) == ["a", "b"]


_READY = """
import sys
from lgvtool.localize.kernel_choice import ready
print(ready(sys.argv[1]))
# numba's typing registries, which its first compiled call imports, are loaded
print(sys.argv[2] in sys.modules and "numba" in sys.modules, "numba.np.arraymath" in sys.modules)
"""


@pytest.mark.parametrize(("family", "module"), [("particles", "lgvtool.localize.pf_kernels"),
                                                ("gaussian", "lgvtool.localize.ekf_kernels")])
def test_kernels_made_ready_in_the_caller(family: str, module: str) -> None:
    import os
    import subprocess
    import sys

    from lgvtool.localize.kernel_choice import KERNELS_ENV

    def fresh(mode: str) -> str:
        env = {**os.environ, KERNELS_ENV: mode}
        return subprocess.run([sys.executable, "-c", _READY, family, module], env=env, check=True,
                              capture_output=True, text=True).stdout.strip()

    assert fresh("numpy").split() == ["False", "False", "False"]  # the numpy path: numba never imported
    pytest.importorskip("numba")
    assert fresh("numba").split() == ["True", "True", "True"]  # the kernels imported and numba's machinery up


@pytest.mark.parametrize(("mode", "expected"), [("numpy", 1), ("numba", None)])
def test_side_by_side_by_default_only_with_compiled_kernels(
        sim_log: Path, monkeypatch: pytest.MonkeyPatch, mode: str, expected: int | None) -> None:
    """The numpy path's short array operations hold the interpreter: two threads of them are
    slower than one (docs/performance.md), so its default is one thread."""
    import lgvtool.localize.replay_driver as driver
    from lgvtool.localize.kernel_choice import KERNELS_ENV

    if mode == "numba":
        pytest.importorskip("numba")
    monkeypatch.setenv(KERNELS_ENV, mode)
    asked: list[int | None] = []
    real = driver.run_side_by_side

    def spy(jobs, run, costs, threads=None, progress=None, prepare=None):
        asked.append(threads)
        return real(jobs, run, costs, threads, progress, prepare)

    monkeypatch.setattr(driver, "run_side_by_side", spy)
    reader = LogReader(sim_log)
    cfg = reader.config()
    data = load_log(reader, cfg.reflectors or None)
    replay_data(data, ["laser", "ekf"], config=cfg)
    replay_data(data, ["laser", "ekf"], config=cfg, threads=2)  # asked for: as asked
    assert asked == [expected, 2]
