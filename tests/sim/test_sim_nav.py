"""The NAV200 model: truth at standstill, skew while turning, the wire, the reflector scans."""

from __future__ import annotations

import math

import numpy as np
import pytest

from lgvtool.devices.nav200.nav200_commands import decode_reply
from lgvtool.devices.nav200.nav200_framing import parse_telegram
from lgvtool.devices.nav200.nav200_requests import request_pose, request_positioning_mode
from lgvtool.log import LogReader, topics
from lgvtool.sim import nav_model
from lgvtool.sim.nav200_simlink import simulated_device
from lgvtool.timestamps import from_stamp

QUIET = {"sim.world": "ideal", "sim.noise": False, "site.survey_sigma_mm": 0.0,
         "nav.angle_step_deg": 0.0}
"""The kind world (a kinematic path, no reflector bias, a level floor) with every random error
off, the layout exact and bearings and ranges to the reflectors' centres."""


def _poses(path):
    reader = LogReader(path)
    meta = reader.metadata["simulator"]
    start = int(meta["start_epoch_s"]) * 1_000_000_000
    rows = [m.data for m in reader.messages([topics.NAV_POSE])]
    t = np.array([(from_stamp(d["timestamp"]) - start) / 1e9 for d in rows])
    return meta, rows, t


def _radial_error_at_o(sim, rows, t, keep):
    v = sim.config.vehicle
    ref = sim.plan.reference
    x = np.array([d["x"] for d in rows])[keep]
    y = np.array([d["y"] for d in rows])[keep]
    th = np.array([d["heading"] for d in rows])[keep]
    ox = x - v.nav_x * np.cos(th) + v.nav_y * np.sin(th)
    oy = y - v.nav_x * np.sin(th) - v.nav_y * np.cos(th)
    return np.hypot(ox - ref["centre_x"], oy - ref["centre_y"]) - ref["radius"]


def test_without_noise_the_nav_pose_is_the_truth_at_standstill(sim_cache, log_cache) -> None:
    sim = sim_cache("paper-circle", **QUIET)
    meta, rows, t = _poses(log_cache("paper-circle", **QUIET))
    still = (t > 1.0) & (t < meta["reference"]["moving_from_s"])
    assert still.sum() >= 5
    hx, hy, hth = sim.truth.point_at(t[still], sim.config.vehicle.nav_x,
                                     sim.config.vehicle.nav_y)
    x = np.array([d["x"] for d in rows])[still]
    y = np.array([d["y"] for d in rows])[still]
    th = np.array([d["heading"] for d in rows])[still]
    assert np.max(np.abs(x - hx)) <= 0.0005 + 1e-9  # whole mm on the wire
    assert np.max(np.abs(y - hy)) <= 0.0005 + 1e-9
    assert np.max(np.abs((th - hth + math.pi) % (2 * math.pi) - math.pi)) <= math.pi / 32768
    used = sim.settings.nav.max_reflectors
    assert all(d["valid"] and d["reflectors_used"] == used for d in np.array(rows)[still])


def _moving_error(sim_cache, log_cache, scenario, **overrides):
    sim = sim_cache(scenario, **overrides)
    meta, rows, t = _poses(log_cache(scenario, **overrides))
    ref = meta["reference"]
    keep = (t > ref["moving_from_s"] + 3) & (t < ref["moving_until_s"] - 3)
    return _radial_error_at_o(sim, rows, t, keep)


def test_without_noise_the_nav_pose_is_skewed_while_turning_and_more_so_faster(
        sim_cache, log_cache) -> None:
    slow = _moving_error(sim_cache, log_cache, "paper-circle", **QUIET)
    fast = _moving_error(sim_cache, log_cache, "fast", **QUIET)
    compensated = _moving_error(sim_cache, log_cache, "paper-circle",
                                **{**QUIET, "nav.skew": False})
    assert np.max(np.abs(compensated)) < 0.002  # only mm quantisation left
    assert abs(np.mean(slow)) > 0.02  # tens of mm, as a bias
    assert np.mean(slow) ** 2 > 2 * np.var(slow)  # the bias carries most of the mean square
    assert abs(np.mean(fast)) > 1.6 * abs(np.mean(slow))


def test_defaults_are_in_the_papers_regime(sim_cache, log_cache) -> None:
    err = _moving_error(sim_cache, log_cache, "paper-circle") * 1000.0
    rmse = float(np.sqrt(np.mean(err ** 2)))
    assert 20.0 < rmse < 120.0
    assert np.mean(err) ** 2 > np.var(err)  # mostly a bias


def test_each_reflector_is_measured_at_its_own_instant(sim_cache) -> None:
    sim = sim_cache("paper-circle", **QUIET)
    sc = sim.scans
    assert sc.period == pytest.approx(1 / 8.0)
    k = len(sc) // 2
    seen = sc.seen[k]
    times = sc.time_in_scan[k, seen]
    assert np.all((times >= 0) & (times < sc.period))
    assert len(np.unique(np.round(times, 6))) == seen.sum()
    # the head turns counter-clockwise from the scan start at 90 deg: time follows the bearing
    u = (sc.bearing[k, seen] - math.radians(90.0)) % (2 * math.pi)
    order = np.argsort(times)
    assert np.all(np.diff(u[order]) > 0)


def test_reflector_scans_are_logged_with_ids_and_times(log_cache) -> None:
    reader = LogReader(log_cache("paper-circle", **{"sim.paper_scans": True}))
    scans = [m for m in reader.messages([topics.NAV_REFLECTORS])]
    assert len(scans) > 8 * 190
    obs = scans[len(scans) // 2].data["observations"]
    assert {o["id"] for o in obs} <= set(range(1, 21))
    assert [o["time_in_scan"] for o in obs] == sorted(o["time_in_scan"] for o in obs)
    assert all(0.5 <= o["range"] <= 28.0 for o in obs)
    for m in scans[:50]:
        assert m.log_time_ns > from_stamp(m.data["timestamp"])  # logged after the revolution


def test_polls_every_450_ms_and_replies_after_the_request(log_cache) -> None:
    reader = LogReader(log_cache("paper-circle"))
    tx = [m for m in reader.messages([topics.NAV_TX])]
    gaps = np.diff([m.log_time_ns for m in tx]) / 1e9
    assert np.all(np.abs(gaps - 0.45) < 0.003)
    assert {m.data["data"] for m in tx} == {"AgVQUAc="}  # 02 05 50 50 07
    poses = [m for m in reader.messages([topics.NAV_POSE])]
    assert len(poses) == len(tx)
    lag = (np.array([m.log_time_ns for m in poses]) - np.array([m.log_time_ns for m in tx])) / 1e9
    # 5 + 17 bytes at 19200 baud 8E1, 5 ms reply delay, up to 3 ms host read
    assert np.all((lag > 0.017) & (lag < 0.025))


def test_device_answers_requests_as_an_emulator_would(sim_cache) -> None:
    sim = sim_cache("paper-circle")
    device = simulated_device(sim.solutions, sim.config.reflectors)
    assert device.latest(0.0) == -1
    reply = decode_reply(parse_telegram(device.answer(request_pose(), 0.0)))
    assert reply.payload.quality == 0xFF
    t = 50.0
    reply = decode_reply(parse_telegram(device.answer(request_pose(), t)))
    i = device.latest(t)
    assert sim.solutions.available[i] <= t < sim.solutions.available[i + 1]
    assert reply.payload.x == pytest.approx(sim.solutions.x[i], abs=5e-4)
    ack = decode_reply(parse_telegram(
        device.answer(request_positioning_mode(), t)))
    assert ack.code == "PA"


def _head_velocity(sim, times):
    """The head's true velocity at ``times``: vx, vy along the vehicle's axes (m/s), omega."""
    v, e = sim.config.vehicle, 1e-3
    ax, ay, ath = sim.truth.point_at(times + e, v.nav_x, v.nav_y)
    bx, by, bth = sim.truth.point_at(times - e, v.nav_x, v.nav_y)
    _, _, th = sim.truth.point_at(times, v.nav_x, v.nav_y)
    vxw, vyw, w = (ax - bx) / (2 * e), (ay - by) / (2 * e), (ath - bth) / (2 * e)
    c, s = np.cos(th), np.sin(th)
    return c * vxw + s * vyw, -s * vxw + c * vyw, w


def test_speed_input_compensation_removes_the_skew_and_a_wrong_speed_does_not(
        sim_cache) -> None:
    sim = sim_cache("paper-circle", duration=60.0, **QUIET)
    sc, v = sim.scans, sim.config.vehicle
    rows = np.arange(200, 260)  # turning at constant speed
    mid = sc.start[rows] + 0.5 * sc.period
    hx, hy, _ = sim.truth.point_at(mid, v.nav_x, v.nav_y)
    vx, vy, w = _head_velocity(sim, mid)
    assert np.all(w > 0.2) and np.all(np.hypot(vx, vy) > 0.2)

    def error(scale: float) -> np.ndarray:
        out = []
        for i, k in enumerate(rows):
            scans = nav_model.compensate(sc, np.array([k]), scale * vx[i], scale * vy[i],
                                         scale * w[i])
            sol = nav_model.solve(scans, sim.truth, v, sim.settings.nav, sim.landmarks)
            out.append(math.hypot(sol.x[0] - hx[i], sol.y[0] - hy[i]))
        return np.array(out)

    raw = np.hypot(sim.solutions.x[rows] - hx, sim.solutions.y[rows] - hy)
    assert np.all(error(0.0) == pytest.approx(raw, abs=1e-9))  # zero speed: the plain fit
    assert raw.mean() > 0.03
    assert error(1.0).max() < 0.001  # the true speed: the skew is gone
    assert error(0.5).mean() > 0.3 * raw.mean()  # half the speed: half the skew is left


def test_the_head_sees_a_cylinder_about_11_mm_behind_its_centre_on_its_pulse_grid() -> None:
    r = np.array([[2.0, 5.0, 10.0, 20.0]])
    alpha = np.array([[0.3, -1.2, 2.0, 0.01]])
    step = math.radians(0.1)
    phases = np.linspace(0.0, 1.0, 40, endpoint=False)
    behind = []
    for phase in phases:
        rng_, bearing, hits = nav_model.apparent_centre(r, alpha, 0.05, step, np.array([phase]))
        width = 2 * np.arcsin(0.05 / r)
        assert np.all(np.abs(hits - width / step) <= 1.0)  # the pulses within the width
        assert np.all(np.abs(bearing - alpha) <= step / 2 + 1e-12)  # the edges on the grid
        behind.append((rng_ - r)[0])
    depth = np.array(behind)
    assert np.all((depth > 0) & (depth < 0.05))
    # many pulses: the mean depth of the surface across the cylinder, R (1 - pi/4)
    assert depth[:, 0] == pytest.approx(0.05 * (1 - math.pi / 4), abs=1e-3)
    # a few pulses at long range: where they fall decides
    assert np.std(depth[:, 3]) > 3 * np.std(depth[:, 0])
    same = nav_model.apparent_centre(r, alpha, 0.05, 0.0, np.array([0.5]))
    assert np.array_equal(same[0], r) and np.array_equal(same[1], alpha)


def test_detection_falls_off_beyond_its_range() -> None:
    r = np.array([5.0, 12.0, 24.0])
    assert nav_model.range_falloff(r, 12.0) == pytest.approx([1.0, 1.0, 0.25], rel=1e-12)
    assert np.all(nav_model.range_falloff(r, 0.0) == 1.0)


@pytest.mark.parametrize("overrides", [{}, {"nav.skew": False, "nav.max_reflectors": 0}],
                         ids=["defaults", "no-skew-all-reflectors"])
def test_revolutions_computed_a_block_at_a_time_are_the_same(
        sim_cache, monkeypatch: pytest.MonkeyPatch, overrides: dict[str, object]) -> None:
    # degraded: occlusions and a shiny object, so detection, hiding and matching all vary
    sim = sim_cache("degraded", seed=3, duration=60.0, **overrides)
    s = sim.settings

    def run(block: int) -> tuple[nav_model.Scans, nav_model.Solutions]:
        monkeypatch.setattr(nav_model, "ROWS_PER_BLOCK", block)
        rng = np.random.default_rng(11)
        scans = nav_model.measure(sim.truth, sim.vehicle, s.nav, sim.site, sim.occlusions,
                                  s.nav_noise, rng)
        return nav_model.locate(scans, sim.truth, sim.vehicle, s.nav, sim.landmarks)

    whole = run(10**9)
    assert len(whole[0]) > 400
    for block in (7, 100):
        parts = run(block)
        for a, b in zip(parts, whole, strict=True):
            for name, value in vars(b).items():
                got = getattr(a, name)
                if isinstance(value, np.ndarray) and value.dtype.kind == "f":
                    # the same operations row by row: equal but for a processor's last bits
                    np.testing.assert_allclose(got, value, rtol=1e-12, atol=1e-12,
                                               err_msg=name)
                elif isinstance(value, np.ndarray):
                    assert np.array_equal(got, value), name
                else:
                    assert got == value, name
