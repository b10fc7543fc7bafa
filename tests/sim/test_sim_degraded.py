"""The degraded scenario: every promised fault is in the log, and counted."""

from __future__ import annotations

from collections import Counter

import numpy as np
import pytest

from lgvtool.log import LogReader, topics
from lgvtool.timestamps import from_stamp

PROMISED = ("mcu_frame_dropped", "mcu_frame_corrupted", "nav_request_dropped",
            "nav_reply_dropped", "nav_reply_corrupted", "nav_no_position", "reflector_occluded",
            "false_reflector_used")


@pytest.fixture(scope="module")
def degraded(log_cache):
    reader = LogReader(log_cache("degraded"))
    diags = [m.data for m in reader.messages([topics.DIAGNOSTICS])]
    return reader, diags


def test_every_promised_fault_is_injected_and_counted(degraded) -> None:
    reader, diags = degraded
    injected = reader.metadata["simulator"]["faults_injected"]
    logged = Counter(d["kind"] for d in diags if d["source"] == "simulator")
    for kind in PROMISED:
        assert injected.get(kind, 0) > 0, kind
    assert dict(logged) == injected
    mirrored = [m.data for m in reader.messages([topics.DIAGNOSTICS_LOG])]
    assert len(mirrored) == len(diags)


def test_mcu_faults_show_in_the_decoded_channel(degraded) -> None:
    reader, diags = degraded
    meta = reader.metadata["simulator"]
    sent = meta["counts"]["mcu_frames_sent"]
    injected = meta["faults_injected"]
    frames = [m.data for m in reader.messages([topics.MCU_FRAME])]
    assert len(frames) == sent - injected["mcu_frame_dropped"] - injected["mcu_frame_corrupted"]
    decoder = Counter(d["kind"] for d in diags if d["source"] == "mcu")
    assert decoder["bad_checksum"] >= injected["mcu_frame_corrupted"]
    missing = sum(d["count"] for d in diags if d["source"] == "mcu" and d["kind"] == "seq_gap")
    seqs = [f["seq"] for f in frames]
    assert missing == (seqs[-1] - seqs[0] + 1) - len(seqs)


def test_nav_faults_show_in_the_decoded_channel(degraded) -> None:
    reader, diags = degraded
    meta = reader.metadata["simulator"]
    injected = meta["faults_injected"]
    polls = meta["counts"]["nav_polls"]
    assert sum(1 for _ in reader.messages([topics.NAV_TX])) == polls
    poses = [m.data for m in reader.messages([topics.NAV_POSE])]
    assert len(poses) == (polls - injected["nav_request_dropped"]
                          - injected["nav_reply_dropped"] - injected["nav_reply_corrupted"])
    invalid = sum(1 for p in poses if not p["valid"])
    assert invalid >= injected["nav_no_position"] - injected["nav_reply_dropped"] \
        - injected["nav_reply_corrupted"] - injected["nav_request_dropped"]
    assert invalid > 0
    nav = Counter(d["kind"] for d in diags if d["source"] == "nav200")
    assert nav["bad_checksum"] >= injected["nav_reply_corrupted"]
    assert nav["unanswered"] >= injected["nav_request_dropped"] + injected["nav_reply_dropped"] \
        - 1


def test_occluded_reflectors_are_not_seen_and_the_shiny_object_is(degraded, sim_cache) -> None:
    # which landmark the head saw is the simulator's own knowledge (the log carries the ids the
    # device gave, tests/sim/test_sim_site.py), so the stretches of the log are checked on it
    reader, diags = degraded
    sim = sim_cache("degraded")
    start = int(reader.metadata["simulator"]["start_epoch_s"]) * 1_000_000_000
    stretches = [((from_stamp(d["timestamp"]) - start) / 1e9, d["details"]) for d in diags
                 if d["kind"] == "reflector_occluded"]
    marks, sc = sim.landmarks, sim.scans
    layout_id = np.where(marks.is_false, -1, marks.ids)  # the shiny object has none: -1
    assert {det["reflector_id"] for _, det in stretches} <= set(layout_id.tolist())
    t = sc.start[:, None] + sc.time_in_scan
    for s, det in stretches:
        (j,) = np.nonzero(layout_id == det["reflector_id"])[0]
        inside = (t[:, j] >= s + 1e-6) & (t[:, j] < s + det["duration_s"] - 1e-6)
        assert not np.any(sc.seen[inside, j]), det
    false_seen = int(sc.seen[:, marks.is_false].sum())
    assert false_seen == reader.metadata["simulator"]["counts"]["false_reflector_detections"]
    assert false_seen > 0
    assert start > 0


def test_the_shiny_object_biases_the_poses_that_use_it(sim_cache) -> None:
    sim = sim_cache("degraded")
    s = sim.solutions
    mid = sim.scans.start + 0.5 * sim.scans.period
    hx, hy, _ = sim.truth.point_at(mid, sim.config.vehicle.nav_x, sim.config.vehicle.nav_y)
    err = np.hypot(s.x - hx, s.y - hy)
    used = s.false_used & s.valid
    assert used.any()
    assert np.median(err[used]) > np.median(err[~used & s.valid])
