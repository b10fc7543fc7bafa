"""Noise-free synthetic drives for the estimator tests, built in code.

A forklift (tricycle kinematics) drives a circle at fixed steering; odometry, NAV poses and
reflector scans are computed exactly from the true motion.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from lgvtool.config import Area, Config, Reflector, Vehicle
from lgvtool.localize.observations import RawScan
from lgvtool.localize.replay_driver import LogData
from lgvtool.trajectory import Trajectory

T0_NS = 1_700_000_000_000_000_000

REFLECTORS = (
    Reflector(1, 0.5, 0.5), Reflector(2, 5.0, 0.2), Reflector(3, 9.5, 0.6),
    Reflector(4, 9.8, 5.5), Reflector(5, 9.4, 9.6), Reflector(6, 4.2, 9.8),
    Reflector(7, 0.3, 9.2), Reflector(8, 0.2, 4.0), Reflector(9, 7.1, 7.7),
)


def small_config(nav_x: float = 1.0, nav_y: float = 0.0) -> Config:
    """A 10 m x 10 m area with nine reflectors; the sensor at (nav_x, nav_y)."""
    return Config(vehicle=Vehicle(nav_x=nav_x, nav_y=nav_y),
                  area=Area(0.0, 10.0, 0.0, 10.0), reflectors=REFLECTORS)


@dataclass
class Circle:
    """Tricycle circle drive: O starts at (x0, y0, th0) and turns at a fixed steering angle."""

    vehicle: Vehicle
    x0: float = 5.0
    y0: float = 4.0
    th0: float = 0.3
    drive_speed: float = 0.36
    steering: float = math.radians(60.0)

    @property
    def v(self) -> float:
        """Speed of O, m/s."""
        return self.drive_speed * math.cos(self.steering)

    @property
    def omega(self) -> float:
        """Yaw rate, rad/s."""
        return self.drive_speed * math.sin(self.steering) / self.vehicle.h

    def pose(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """True pose of O at times t (s)."""
        th = self.th0 + self.omega * t
        r = self.v / self.omega
        return (self.x0 + r * (np.sin(th) - math.sin(self.th0)),
                self.y0 - r * (np.cos(th) - math.cos(self.th0)), th)


def circle_log(duration: float = 20.0, *, nav_x: float = 1.0, nav_y: float = 0.0,
               motion: str = "mcu", scans: str = "revolution", poses: bool = True,
               ids: bool = False, scan_rate: float = 8.0, nav_period: float = 0.45,
               mcu_period: float = 0.1, start_counts: int = 2**31 - 3000,
               drop_frames: tuple[int, ...] = ()) -> tuple[LogData, Circle, Config]:
    """Exact data of a circle drive.

    ``motion``: 'mcu' (frames with wrapping int32 counts starting near the limit and wrapping
    u16 sequence numbers) or 'twist'; ``scans``: 'revolution' (each reflector measured when
    the rotating head passes it), 'snapshot' or 'none'.
    """
    cfg = small_config(nav_x, nav_y)
    veh = cfg.vehicle
    c = Circle(veh)
    data = LogData(T0_NS, cfg.reflectors)
    tm = np.arange(0.0, duration + 1e-9, mcu_period)
    if motion == "mcu":
        k_l, k_r = veh.metres_per_count()
        s_l = (c.v - c.omega * veh.track / 2.0) * tm
        s_r = (c.v + c.omega * veh.track / 2.0) * tm
        cl = (start_counts + np.round(s_l / k_l).astype(np.int64) + 2**31) % 2**32 - 2**31
        cr = (start_counts + np.round(s_r / k_r).astype(np.int64) + 2**31) % 2**32 - 2**31
        seq = (np.arange(len(tm)) + 65530) % 65536
        ms = (np.round(tm * 1000).astype(np.int64) + 2**32 - 500) % 2**32
        keep = np.ones(len(tm), dtype=bool)
        keep[list(drop_frames)] = False
        data.mcu = {"t": tm[keep], "seq": seq[keep], "mcu_time_ms": ms[keep],
                    "enc_left": cl[keep], "enc_right": cr[keep],
                    "gyro_rate": np.full(keep.sum(), c.omega)}
    else:
        data.twist = {"t": tm, "v": np.full(len(tm), c.v), "omega": np.full(len(tm), c.omega)}
    if poses:
        tn = np.arange(0.05, duration, nav_period)
        x, y, th = c.pose(tn)
        ct, st = np.cos(th), np.sin(th)
        data.nav = {"t": tn, "x": x + nav_x * ct - nav_y * st, "y": y + nav_x * st + nav_y * ct,
                    "heading": np.remainder(th + math.pi, 2 * math.pi) - math.pi,
                    "valid": np.ones(len(tn), dtype=bool)}
    if scans != "none":
        period = 1.0 / scan_rate
        data.scans = [_scan(c, cfg, float(t_start), period if scans == "revolution" else 0.0, ids)
                      for t_start in np.arange(0.02, duration - period, period)]
    tt = np.arange(0.0, duration + 1e-9, 0.01)
    x, y, th = c.pose(tt)
    data.truth = Trajectory(tt, x, y, th, data.t0_ns)
    return data, c, cfg


def _scan(c: Circle, cfg: Config, t_start: float, period: float, ids: bool) -> RawScan:
    """Each reflector measured when the head (turning counter-clockwise once per period from
    bearing 0 at the start) points at it, found by fixed-point iteration."""
    veh = cfg.vehicle
    ranges, bearings, times, idl = [], [], [], []
    for r in cfg.reflectors:
        tau = 0.0
        for _ in range(50):
            x, y, th = (float(v[0]) for v in c.pose(np.array([t_start + tau])))
            sx = x + veh.nav_x * math.cos(th) - veh.nav_y * math.sin(th)
            sy = y + veh.nav_x * math.sin(th) + veh.nav_y * math.cos(th)
            b = math.atan2(r.y - sy, r.x - sx) - th
            b = b % (2 * math.pi)
            new_tau = period * b / (2 * math.pi)
            if abs(new_tau - tau) < 1e-13:
                break
            tau = new_tau
        ranges.append(math.hypot(r.x - sx, r.y - sy))
        bearings.append(math.remainder(b, 2 * math.pi))
        times.append(tau)
        idl.append(r.id if ids else -1)
    order = np.argsort(times)
    return RawScan(t_start, period, np.array(ranges)[order], np.array(bearings)[order],
                   np.array(times)[order], np.array(idl, dtype=np.int64)[order])


def position_errors(result_df, circle: Circle) -> np.ndarray:
    """Distance of each estimated position from the true one, m."""
    t = result_df["t"].to_numpy() - T0_NS * 1e-9
    x, y, _ = circle.pose(t)
    return np.hypot(result_df["x"].to_numpy() - x, result_df["y"].to_numpy() - y)


def _stamp(ns: int) -> dict[str, int]:
    return {"sec": ns // 1_000_000_000, "nsec": ns % 1_000_000_000}


def write_log(path, data: LogData, cfg: Config, *, mcu: bool = True, twist: bool = True,
              nav: bool = True, scans: bool = True, truth: bool = True) -> None:
    """Write synthetic data as an lgvtool log (MCAP) with the chosen topics."""
    from lgvtool.log import LogWriter, topics
    from lgvtool.log.messages import pose_in_frame

    def ns(t: float) -> int:
        return T0_NS + round(t * 1e9)

    rows: list[tuple[int, str, Mapping[str, object]]] = []
    if mcu and data.mcu is not None:
        m = data.mcu
        for i in range(len(m["t"])):
            n = ns(float(m["t"][i]))
            rate = float(m["gyro_rate"][i])
            raw = max(-32768, min(32767, round(math.degrees(rate) / 0.010986)))
            rows.append((n, topics.MCU_FRAME, {
                "timestamp": _stamp(n), "version": 1, "seq": int(m["seq"][i]),
                "mcu_time_ms": int(m["mcu_time_ms"][i]), "enc_left": int(m["enc_left"][i]),
                "enc_right": int(m["enc_right"][i]), "gyro_raw": raw, "gyro_scale": 0.010986,
                "gyro_rate": rate, "steering_angle": math.radians(60.0), "drive_speed": 0.36,
                "status": 0}))
    if twist and data.twist is not None:
        tw = data.twist
        for i in range(len(tw["t"])):
            n = ns(float(tw["t"][i]))
            rows.append((n, topics.ODOM, {"timestamp": _stamp(n), "v": float(tw["v"][i]),
                                          "omega": float(tw["omega"][i])}))
    if nav and data.nav is not None:
        nv = data.nav
        for i in range(len(nv["t"])):
            n = ns(float(nv["t"][i]))
            rows.append((n, topics.NAV_POSE, {
                "timestamp": _stamp(n), "x": float(nv["x"][i]), "y": float(nv["y"][i]),
                "heading": float(nv["heading"][i]), "quality": 100, "reflectors_used": 8,
                "valid": bool(nv["valid"][i])}))
    if scans:
        for s in data.scans:
            n = ns(s.t)
            rows.append((ns(s.t + s.period), topics.NAV_REFLECTORS, {
                "timestamp": _stamp(n), "scan_period": s.period, "observations": [
                    {"range": float(r), "bearing": float(b), "time_in_scan": float(tau),
                     "id": int(i)} for r, b, tau, i in zip(s.ranges, s.bearings, s.times,
                                                           s.ids, strict=True)]}))
    if truth and data.truth is not None:
        tr = data.truth
        for i in range(0, len(tr), 5):
            n = ns(float(tr.t[i]))
            rows.append((n, topics.TRUTH, pose_in_frame(n, float(tr.x[i]), float(tr.y[i]),
                                                        float(tr.heading[i]))))
    rows.sort(key=lambda r: r[0])
    with LogWriter(path, source="test") as w:
        w.write_config(cfg)
        w.write_map(cfg.reflectors, T0_NS)
        for n, topic, msg in rows:
            w.write(topic, msg, n)
