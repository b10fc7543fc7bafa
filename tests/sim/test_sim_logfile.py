"""The simulated log's records: made one at a time in log-time order, as the whole run sorted
at once would give them."""

from __future__ import annotations

from collections.abc import Callable, Iterator
from itertools import takewhile
from typing import Any

import pytest

from lgvtool.sim import logfile
from lgvtool.sim.event_stream import nav_scans, truth_samples
from lgvtool.sim.simulation import Simulation


def _sorted_at_once(sim: Simulation) -> list[tuple[int, int, Any]]:
    """Every record of the run gathered first and sorted by (log time, kind, insertion)."""
    late = sim.settings.install.nav_time_offset_ms * 1e-3
    records: list[tuple[int, int, int, Any]] = []

    def add(t: float, kind: int, payload: Any) -> None:
        records.append((sim.host_ns(t), kind, len(records), payload))

    for sample in truth_samples(sim, sim.settings.sim.truth_rate_hz):
        add(sample.t, logfile._TRUTH, sample)
    for fault in sim.faults:
        add(fault.t, logfile._FAULT, fault)
    for chunk in sim.mcu_traffic.rx:
        add(chunk.t, logfile._MCU, chunk.data)
    if sim.settings.sim.nav_device == "nav350":
        from lgvtool.sim.nav350_simlink import nav350_traffic

        for t, direction, data in nav350_traffic(sim):
            add(t + late if direction == "rx" else t,
                logfile._NAV_RX if direction == "rx" else logfile._NAV_TX, data)
    else:
        for chunk in sim.nav_traffic.tx:
            add(chunk.t, logfile._NAV_TX, chunk.data)
        for chunk in sim.nav_traffic.rx:
            add(chunk.t + late, logfile._NAV_RX, chunk.data)
        for k, scan in enumerate(nav_scans(sim) if sim.settings.sim.paper_scans else ()):
            if sim.solutions.available[k] > sim.duration:
                break
            add(float(sim.solutions.available[k]) + late, logfile._SCAN, scan)
    records.sort(key=lambda r: (r[0], r[1], r[2]))
    return [(ns, kind, payload) for ns, kind, _, payload in records]


@pytest.mark.parametrize("overrides", [
    {"install.nav_time_offset_ms": -25.0},
    {"install.nav_time_offset_ms": -25.0, "sim.paper_scans": True},
    {"sim.nav_device": "nav350", "install.nav_time_offset_ms": 30.0},
], ids=["nav200", "nav200-paper-scans", "nav350"])
def test_records_come_in_the_order_of_the_whole_run_sorted(
        sim_cache: Callable[..., Simulation], overrides: dict[str, Any]) -> None:
    # degraded: lost, corrupt and late frames, occlusions, faults; the NAV's replies late or
    # early against the host clock, so that its sources interleave with the others'
    sim = sim_cache("degraded", seed=2, duration=120.0, **overrides)
    streamed = [(ns, kind, payload) for ns, kind, _, payload in logfile._records(sim)]
    expected = _sorted_at_once(sim)
    assert [r[:2] for r in streamed] == [r[:2] for r in expected]
    assert all(a[2] == b[2] for a, b in zip(streamed, expected, strict=True))
    assert {kind for _, kind, _ in streamed} >= {logfile._TRUTH, logfile._FAULT, logfile._MCU,
                                                 logfile._NAV_TX, logfile._NAV_RX}


def test_records_are_made_as_they_are_written(sim_cache: Callable[..., Simulation],
                                              monkeypatch: pytest.MonkeyPatch) -> None:
    sim = sim_cache("paper-circle", duration=120.0, **{"sim.paper_scans": True})
    made = {"scans": 0}

    def counted(s: Simulation) -> Iterator[Any]:
        for scan in nav_scans(s):
            made["scans"] += 1
            yield scan

    monkeypatch.setattr(logfile, "nav_scans", counted)
    first = list(takewhile(lambda r: r[0] < sim.host_ns(20.0), logfile._records(sim)))
    assert len(first) > 500
    assert 0 < made["scans"] < len(sim.scans) // 4


def test_scans_made_a_block_at_a_time_are_the_same(sim_cache: Callable[..., Simulation]) -> None:
    sim = sim_cache("degraded", seed=2, duration=120.0, **{"install.nav_time_offset_ms": -25.0})
    whole = list(nav_scans(sim, block=len(sim.scans)))
    assert len(whole) == len(sim.scans)
    assert list(nav_scans(sim, block=7)) == whole
    assert list(nav_scans(sim)) == whole


def test_a_source_out_of_time_order_is_sorted_stably(sim_cache: Callable[..., Simulation]
                                                     ) -> None:
    sim = sim_cache("paper-circle", duration=120.0)
    items = [(2.0, "a"), (1.0, "b"), (2.0, "c"), (1.0, "d")]
    assert [p for _, p in logfile._in_time_order(sim, items)] == ["b", "d", "a", "c"]
    assert [p for _, p in logfile._in_time_order(sim, sorted(items))] == ["b", "d", "a", "c"]
    with pytest.raises(RuntimeError, match="out of time order"):
        list(logfile._checked(iter([(2, "a"), (1, "b")])))
