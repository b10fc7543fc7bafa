"""The collector held off while a job runs (lgvtool.gc_pause), and restored however the job
ends, with blocks nested or on several threads at once."""

from __future__ import annotations

import gc
import threading
from collections.abc import Iterator

import pytest

from lgvtool.gc_pause import collector_paused


@pytest.fixture
def collecting() -> Iterator[None]:
    was = gc.isenabled()
    gc.enable()
    yield
    if not was:
        gc.disable()


def test_paused_in_the_block_and_back_after_it_even_on_error(collecting: None) -> None:
    with collector_paused():
        assert not gc.isenabled()
        with collector_paused():
            assert not gc.isenabled()
        assert not gc.isenabled()  # the outer block still holds it
    assert gc.isenabled()
    with pytest.raises(RuntimeError), collector_paused():
        raise RuntimeError("boom")
    assert gc.isenabled()


def test_left_off_when_it_was_off(collecting: None) -> None:
    gc.disable()
    with collector_paused():
        pass
    assert not gc.isenabled()


def test_blocks_on_threads_overlapping_restore_it_once_the_last_leaves(collecting: None) -> None:
    """Thread A enters, B enters, A leaves (B still inside: still off), B leaves: on."""
    a_in, b_in, a_out = threading.Event(), threading.Event(), threading.Event()
    seen: dict[str, bool] = {}

    def first() -> None:
        with collector_paused():
            a_in.set()
            b_in.wait(10)
        a_out.set()

    def second() -> None:
        a_in.wait(10)
        with collector_paused():
            b_in.set()
            a_out.wait(10)
            seen["after A left"] = gc.isenabled()

    threads = [threading.Thread(target=first), threading.Thread(target=second)]
    for t in threads:
        t.start()
    for t in threads:
        t.join(20)
    assert seen == {"after A left": False}
    assert gc.isenabled()


def test_replay_evaluate_and_export_run_the_estimators_with_it_off(
        collecting: None, tmp_path, monkeypatch) -> None:
    """Every job that runs the estimators over a log (replay, evaluate of a raw log, export of
    a raw log's trajectories) does so with the collector off, and turns it back on after."""
    from simlogs import simulate_log

    from lgvtool.app.evaluate_job import evaluate_log
    from lgvtool.app.replay_job import ReplayOptions, replay_log
    from lgvtool.interop.trajectory_export import export_log
    from lgvtool.localize import replay_driver

    log = simulate_log(tmp_path / "raw.mcap", 20.0, seed=3)
    seen: list[bool] = []
    original = replay_driver.replay_data

    def spy(*args, **kwargs):
        seen.append(gc.isenabled())
        return original(*args, **kwargs)

    monkeypatch.setattr(replay_driver, "replay_data", spy)
    replay_log(ReplayOptions(str(log), str(tmp_path / "out.mcap"), estimators=("laser",),
                             show_progress=False))
    evaluate_log(log, estimators=["laser"])
    export_log(log, tmp_path / "tum", "tum", estimators=["laser"])
    assert seen == [False, False, False]
    assert gc.isenabled()
