"""The mapping of domain values to Foxglove messages: Foxglove's own schemas, geometry, and the
fast paths giving the builders' messages."""

from __future__ import annotations

import base64
import math
from typing import Any

import jsonschema
import numpy as np
import orjson
import pytest
from simlogs import cloud_points

from lgvtool.log import foxglove as fx
from lgvtool.log import topics
from lgvtool.log.messages import pose_in_frame, poses_in_frame, yaw_from_quaternion
from lgvtool.log.schemas import schema_json

T0 = 1_704_067_200_000_000_000
M = fx.Mounting(1.0, 0.2, 0.05)


def _valid(schema: str, msg: dict) -> None:
    jsonschema.Draft202012Validator(schema_json(schema)).validate(msg)


def _approx(a: object, b: object) -> None:
    """Equal JSON documents, numbers to 1e-12 (the fast paths' sin/cos may differ in the last
    bit from the math module's)."""
    if isinstance(a, dict):
        assert isinstance(b, dict) and list(a) == list(b)
        for k in a:
            _approx(a[k], b[k])
    elif isinstance(a, list):
        assert isinstance(b, list) and len(a) == len(b)
        for x, y in zip(a, b, strict=True):
            _approx(x, y)
    elif isinstance(a, float):
        assert b == pytest.approx(a, rel=1e-12, abs=1e-12)
    else:
        assert a == b


def test_builders_validate_against_foxglove_schemas() -> None:
    _valid("foxglove.FrameTransforms", fx.frame_transforms(T0, "pf", 1.0, 2.0, 0.3, M))
    _valid("foxglove.SceneUpdate", fx.covariance_ellipse(T0, "pf", 1.0, 2.0,
                                                         [0.01, 0.002, 0, 0.002, 0.004, 0, 0, 0,
                                                          0.001]))
    _valid("foxglove.PointCloud", fx.scan_cloud(T0, [5.0, -7.0], [0.3, 1.0], [4, -1]))
    _valid("foxglove.PointCloud", fx.scan_cloud(T0, [], [], []))
    _valid("foxglove.SceneUpdate", fx.reference_circle(T0, 10.0, 9.0, 0.69))
    scan = fx.encoded(topics.NAV_SCAN, fx.scan_cloud(T0, [3.0], [0.1], [2]))
    for e in (*fx.nav_pose_messages(T0, 1.0, 2.0, 0.5, M), scan,
              *fx.estimate_messages("ekf", T0, 1.0, 2.0, 0.5, [1e-4, 0, 0, 0, 1e-4, 0, 0, 0,
                                                               1e-3], M)):
        assert e.schema == topics.schema_for_topic(e.topic)
        _valid(e.schema, orjson.loads(e.data))


def test_a_message_missing_a_required_field_fails() -> None:
    msg: dict[str, Any] = dict(fx.frame_transforms(T0, "pf", 1.0, 2.0, 0.3, M))
    del msg["transforms"][0]["child_frame_id"]
    assert not jsonschema.Draft202012Validator(
        schema_json("foxglove.FrameTransforms")).is_valid(msg)


def test_head_frame_sits_at_the_mounting_of_o() -> None:
    """O recovered from a head pose, moved by the mounting, gives the head back."""
    for x, y, h in ((3.0, 4.0, 0.0), (-1.0, 2.5, 2.9), (10.0, 9.0, -1.7)):
        ox, oy, oh = fx.o_from_head(x, y, h, M)
        c, s = math.cos(oh), math.sin(oh)
        assert ox + c * M.x - s * M.y == pytest.approx(x, abs=1e-12)
        assert oy + s * M.x + c * M.y == pytest.approx(y, abs=1e-12)
        assert math.remainder(oh + M.yaw - h, 2 * math.pi) == pytest.approx(0.0, abs=1e-12)
    frames: dict[str, Any] = dict(fx.frame_transforms(T0, "nav", 1.0, 2.0, 0.5, M))
    tf = frames["transforms"]
    assert [(t["parent_frame_id"], t["child_frame_id"]) for t in tf] == [
        ("map", "nav/O"), ("nav/O", "nav/head")]
    assert tf[1]["translation"] == {"x": 1.0, "y": 0.2, "z": 0.0}
    assert yaw_from_quaternion(tf[1]["rotation"]) == pytest.approx(0.05, rel=1e-12)


def test_covariance_ellipse_axes() -> None:
    # 0.3 m along 30 deg, 0.1 m across
    th = math.radians(30)
    r = np.array([[math.cos(th), -math.sin(th)], [math.sin(th), math.cos(th)]])
    c = r @ np.diag([0.09, 0.01]) @ r.T
    a, b, angle = fx.ellipse_axes(c[0, 0], c[0, 1], c[1, 1])
    assert (a, b, angle) == pytest.approx((0.3, 0.1, th), rel=1e-9)
    msg: dict[str, Any] = dict(fx.covariance_ellipse(
        T0, "pf", 1.0, 2.0, [c[0, 0], c[0, 1], 0, c[1, 0], c[1, 1], 0, 0, 0, 1e-3]))
    (sphere,) = msg["entities"][0]["spheres"]
    assert sphere["size"]["x"] == pytest.approx(2 * fx.SIGMAS * 0.3, rel=1e-9)
    assert sphere["size"]["y"] == pytest.approx(2 * fx.SIGMAS * 0.1, rel=1e-9)
    assert yaw_from_quaternion(sphere["pose"]["orientation"]) == pytest.approx(th, rel=1e-9)
    assert msg["entities"][0]["frame_id"] == "map"


def test_scan_cloud_holds_each_observation_as_a_point_in_the_head_frame() -> None:
    msg: dict[str, Any] = dict(fx.scan_cloud(T0 + 10_000_000, [0.0, 2.0], [5.0, 0.0], [3, -1]))
    assert msg["frame_id"] == "nav/head"
    assert msg["timestamp"] == {"sec": T0 // 10**9, "nsec": 10_000_000}
    assert msg["pose"]["position"] == {"x": 0.0, "y": 0.0, "z": 0.0}
    pts = cloud_points(msg)
    assert len(pts) == 2 and len(base64.b64decode(msg["data"])) == 2 * msg["point_stride"]
    assert (pts["x"].tolist(), pts["y"].tolist(), pts["z"].tolist()) == (
        [0.0, 2.0], [5.0, 0.0], [0.0, 0.0])
    assert pts["id"].tolist() == [3, -1]
    nav = [round(255 * v) for v in fx.PALETTE["nav"]] + [255]
    grey = [round(255 * v) for v in fx.PALETTE["deadreckoning"]] + [255]
    rgba = [[int(p[c]) for c in ("red", "green", "blue", "alpha")] for p in pts]
    assert rgba == [nav, grey]  # a known reflector in the source's colour, an unknown grey
    assert fx.scan_cloud(T0, [1.0], [1.0], [0], "truth")["frame_id"] == "truth/head"



def test_reference_circle_points_lie_on_it() -> None:
    circle: dict[str, Any] = dict(fx.reference_circle(T0, 10.0, 9.0, 0.7, n=36))
    (e,) = circle["entities"]
    pts = e["lines"][0]["points"]
    assert len(pts) == 36 and e["lines"][0]["type"] == 1  # a closed loop
    for p in pts:
        assert math.hypot(p["x"] - 10.0, p["y"] - 9.0) == pytest.approx(0.7, rel=1e-12)


def test_fast_paths_equal_the_builders() -> None:
    rng = np.random.default_rng(1)
    n = 40
    t = T0 + np.cumsum(rng.integers(1, 10**8, n))
    x, y = rng.normal(10, 3, n), rng.normal(9, 3, n)
    h = rng.uniform(-math.pi, math.pi, n)
    cov = np.zeros((n, 3, 3))
    a = rng.normal(0, 0.1, (n, 2, 2))
    cov[:, :2, :2] = a @ a.transpose(0, 2, 1)
    cov[:, 2, 2] = 1e-3
    for i, text in enumerate(fx.pose_in_frame_many(t, x, y, h)):
        _approx(pose_in_frame(int(t[i]), x[i], y[i], h[i]), orjson.loads(text))
    t_tf, tfs = fx.frame_transforms_many("ekf", t, x, y, h, M)
    assert t_tf == t.tolist()
    for i, text in enumerate(tfs):
        _approx(fx.frame_transforms(int(t[i]), "ekf", float(x[i]), float(y[i]), float(h[i]), M),
                orjson.loads(text))
    t_cov, ells = fx.covariance_ellipse_many("ekf", t, x, y, cov)
    assert t_cov == t.tolist()
    for i, text in enumerate(ells):
        _approx(fx.covariance_ellipse(int(t[i]), "ekf", float(x[i]), float(y[i]),
                                      cov[i].ravel().tolist()), orjson.loads(text))
    parts, ess = rng.integers(0, 500, n), rng.uniform(0, 500, n)
    states = fx.pose_estimate_many("ekf", t, x, y, h, cov, parts, ess)
    for i, text in enumerate(states):
        _approx(fx.pose_estimate(int(t[i]), "ekf", float(x[i]), float(y[i]), float(h[i]),
                                 cov[i].ravel().tolist(), int(parts[i]), float(ess[i])),
                orjson.loads(text))
    live = fx.estimate_messages("ekf", int(t[0]), float(x[0]), float(y[0]), float(h[0]),
                                cov[0].ravel().tolist(), M, particles=int(parts[0]),
                                ess=float(ess[0]))
    assert [e.topic for e in live] == [topics.estimate_pose("ekf"), topics.estimate_state("ekf"),
                                       topics.estimate_tf("ekf"),
                                       topics.estimate_covariance("ekf")]
    for e, fast in zip(live, (fx.pose_in_frame_many(t, x, y, h)[0], states[0], tfs[0],
                              ells[0]), strict=True):
        _approx(orjson.loads(fast), orjson.loads(e.data))
    clouds = [(int(t[0]), x[:5], y[:5], h[:5]), (int(t[1]), x[:0], y[:0], h[:0])]
    for c, text in zip(clouds, fx.poses_in_frame_many(clouds), strict=True):
        _approx(poses_in_frame(c[0], list(zip(c[1], c[2], c[3], strict=True))),
                orjson.loads(text))


def test_scan_fast_path_equals_the_builder() -> None:
    rng = np.random.default_rng(2)
    counts = rng.integers(0, 7, 6)
    offsets = np.concatenate([[0], np.cumsum(counts)])
    n = int(offsets[-1])
    x, y, ids = rng.uniform(-20, 20, n), rng.uniform(-20, 20, n), rng.integers(-1, 30, n)
    starts = T0 + 125_000_000 * np.arange(6)
    texts = fx.scan_clouds_many(starts, offsets, x, y, ids, "pf")
    assert len(texts) == 6
    for k, text in enumerate(texts):
        a, b = offsets[k], offsets[k + 1]
        assert orjson.loads(text) == fx.scan_cloud(int(starts[k]), x[a:b], y[a:b], ids[a:b], "pf")
    assert fx.scan_clouds_many([], [0], [], [], []) == []



def test_fast_paths_leave_out_rows_that_are_not_finite() -> None:
    t = np.array([T0, T0 + 1, T0 + 2])
    x = np.array([1.0, math.nan, 2.0])
    cov = np.tile(np.eye(3).ravel() * 1e-3, (3, 1))
    cov[2, 0] = math.inf
    assert fx.frame_transforms_many("a", t, x, x * 0, x * 0, M)[0] == [T0, T0 + 2]
    assert fx.covariance_ellipse_many("a", t, x, x * 0, cov)[0] == [T0]
