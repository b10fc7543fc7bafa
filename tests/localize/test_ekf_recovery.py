"""``ekf`` finds the vehicle again on reflector scans: once scans of two or more reflectors
have found nothing for ``scan_recover_s``, the pose restarts at a scan's landmark fix (with the
device's ids or from the scan's geometry alone); never on a run that is not lost; the compiled
loop gives the numpy path's rows."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from localize_synth import T0_NS, Circle, circle_log

from lgvtool.localize.ekf import lost_scan
from lgvtool.localize.kernel_choice import KERNELS_ENV
from lgvtool.localize.replay_driver import replay_data

WRONG_BY_M = 1.0
"""How far off (m, sideways) the confident start is; its heading is 0.2 rad off too."""
CONFIDENT = {"ekf.init_sigma_xy_m": 0.02, "ekf.init_sigma_heading_rad": 0.01}
"""A start that trusts itself: its gate rejects every reflector 1 m away."""
LAST_EVENTS: dict[str, list[tuple[int, str, str]]] = {}
"""The events of the last replay :func:`_errors` ran."""


def test_the_lost_rule() -> None:
    lost = np.full(1, math.nan)
    assert not lost_scan(lost, 0.0, 1, False, 2.0)  # one reflector: no sign of being lost
    assert math.isnan(lost[0])
    assert not lost_scan(lost, 0.5, 3, False, 2.0)  # the first scan that finds nothing
    assert lost[0] == 0.5
    assert not lost_scan(lost, 2.4, 3, False, 2.0)  # 1.9 s later: not yet
    assert lost_scan(lost, 2.5, 2, False, 2.0)  # 2.0 s: due
    assert lost_scan(lost, 2.6, 3, False, 2.0)  # still due (no fix was found)
    assert not lost_scan(lost, 2.7, 1, True, 2.0)  # a reflector accepted: found again
    assert math.isnan(lost[0])
    never = np.full(1, math.nan)
    assert not any(lost_scan(never, t, 5, False, 0.0) for t in np.arange(0.0, 60.0, 0.125))


def test_a_nav_pose_taken_means_not_lost() -> None:
    """With NAV poses besides the scans, a pose the gate takes clears the scans' lost time: a
    filter that its poses keep is not restarted by scans that find nothing."""
    from lgvtool.config import Vehicle
    from lgvtool.localize.ekf import Ekf
    from lgvtool.localize.observations import PoseObservation

    ekf = Ekf(vehicle=Vehicle(nav_x=0.0, nav_y=0.0), initial_pose=(1.0, 2.0, 0.3))
    ekf.scan_lost[0] = 5.0
    assert ekf.update(PoseObservation(6.0, 1.01, 2.0, 0.3))
    assert math.isnan(ekf.scan_lost[0])
    ekf.scan_lost[0] = 5.0
    assert not ekf.update(PoseObservation(6.1, 9.0, 9.0, 0.3))  # refused: still lost
    assert ekf.scan_lost[0] == 5.0


def _errors(mode: str, monkeypatch: pytest.MonkeyPatch, ids: bool,
            settings: dict[str, Any]) -> tuple[np.ndarray, np.ndarray, Any]:
    """A 30 s circle with 8 scans a second, ``ekf`` started 1 m off and sure of it: time (s
    from the start) and position error (m) of each row, and the rows."""
    monkeypatch.setenv(KERNELS_ENV, mode)
    data, circle, cfg = circle_log(30.0, ids=ids, poses=False)
    x, y, th = (float(v[0]) for v in Circle(cfg.vehicle).pose(np.zeros(1)))
    res = replay_data(data, ["ekf"], config=cfg, seed=3, settings={**CONFIDENT, **settings},
                      initial_pose=(x - WRONG_BY_M * math.sin(th),
                                    y + WRONG_BY_M * math.cos(th), th + 0.2))
    LAST_EVENTS.clear()
    LAST_EVENTS.update(res.events)
    rows = res.estimates["ekf"]
    t = (rows.t_ns - T0_NS) * 1e-9
    tx, ty, _ = circle.pose(t)
    return t, np.hypot(rows.x - tx, rows.y - ty), rows


@pytest.mark.parametrize("ids", [True, False])
def test_a_lost_ekf_finds_the_vehicle_again(monkeypatch: pytest.MonkeyPatch,
                                            ids: bool) -> None:
    t, err, _ = _errors("numpy", monkeypatch, ids, {"ekf.use_ids": ids})
    ((when, kind, text),) = LAST_EVENTS["ekf"]
    assert kind == "restarted" and "landmark fix" in text
    assert 2.0 <= (when - T0_NS) * 1e-9 <= 3.0  # 2 s after its first scan found nothing
    assert err[t < 1.5].min() > 0.5  # lost: every reflector outside its gate
    # found within the recovery time and a scan or two, and kept from then on
    assert err[t > 3.0].max() < 0.01
    # without the recovery it stays lost for the whole drive
    t0, err0, _ = _errors("numpy", monkeypatch, ids,
                          {"ekf.use_ids": ids, "ekf.scan_recover_s": 0.0})
    assert err0[t0 > 20.0].min() > 0.5
    assert "ekf" not in LAST_EVENTS


def test_a_drive_that_is_not_lost_never_restarts(monkeypatch: pytest.MonkeyPatch) -> None:
    """With the true start the rows are the same with and without the recovery."""
    monkeypatch.setenv(KERNELS_ENV, "numpy")
    data, _, cfg = circle_log(30.0, ids=True, poses=False)
    runs = [replay_data(data, ["ekf"], config=cfg, seed=3, settings={
        "ekf.scan_recover_s": s}) for s in (2.0, 0.0)]
    rows = [r.estimates["ekf"] for r in runs]
    assert np.array_equal(rows[0].x, rows[1].x) and np.array_equal(rows[0].y, rows[1].y)
    assert runs[0].events == {}


def test_a_restart_is_an_event_of_the_replayed_log(tmp_path: Path) -> None:
    """``replay`` writes the restart on /diagnostics (source ``ekf``), says so in its
    summary, and a replay of its output does not repeat it."""
    from simlogs import simulate_log

    from lgvtool.app.replay_job import write_replay_log
    from lgvtool.localize.replay_driver import run_replay
    from lgvtool.log import LogReader, topics

    log = simulate_log(tmp_path / "drive.mcap", 20.0, 3, "warehouse", paper_scans=False,
                       sets=["sim.nav_device=nav350"])

    def replayed(src: Path, out: Path) -> list[dict[str, Any]]:
        reader = LogReader(src)
        truth = next(iter(reader.messages([topics.TRUTH]))).data["pose"]
        x, y = truth["position"]["x"], truth["position"]["y"]
        q = truth["orientation"]
        th = 2.0 * math.atan2(q["z"], q["w"])
        res = run_replay(reader, ["ekf"], settings=CONFIDENT,
                         initial_pose=(x - math.sin(th), y + math.cos(th), th + 0.2))
        write_replay_log(reader, str(out), res, None, src.name)
        return [m.data for m in LogReader(out).messages([topics.DIAGNOSTICS])
                if m.data.get("source") == "ekf"]

    first = replayed(log, tmp_path / "out.mcap")
    assert [d["kind"] for d in first] == ["restarted"]
    assert replayed(tmp_path / "out.mcap", tmp_path / "again.mcap") == first


@pytest.mark.parametrize("ids", [True, False])
def test_the_compiled_loop_recovers_as_the_numpy_path(monkeypatch: pytest.MonkeyPatch,
                                                      ids: bool) -> None:
    pytest.importorskip("numba")
    _, _, a = _errors("numpy", monkeypatch, ids, {"ekf.use_ids": ids})
    _, _, b = _errors("numba", monkeypatch, ids, {"ekf.use_ids": ids})
    assert np.array_equal(a.t_ns, b.t_ns)
    for col in ("x", "y", "heading"):
        assert np.allclose(getattr(a, col), getattr(b, col), rtol=0, atol=1e-9), col
    assert np.allclose(a.covariance, b.covariance, rtol=1e-9, atol=1e-15)
