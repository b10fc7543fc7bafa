"""Expected visibility of layout reflectors: a hand-worked case, a brute-force loop, the device
views and the blocks."""

from __future__ import annotations

import math

import numpy as np
import pytest

from lgvtool.audit import visibility
from lgvtool.audit.visibility import DeviceView, expected_visibility
from lgvtool.config import Reflector
from lgvtool.errors import ConfigError


def _brute(hx: float, hy: float, hth: float, refl: list[Reflector], view: DeviceView
           ) -> list[bool]:
    """One pose, reflector by reflector, with plain math (the definition, written out)."""
    out = []
    for j, t in enumerate(refl):
        rj = math.hypot(t.x - hx, t.y - hy)
        bj = math.atan2(t.y - hy, t.x - hx)
        rel = (bj - hth + math.pi) % (2 * math.pi) - math.pi
        ok = (view.range_min_m <= rj <= view.range_max_m
              and abs(rel) <= math.radians(view.field_of_view_deg) / 2 + 1e-12)
        for k, o in enumerate(refl):
            if k == j:
                continue
            rk = math.hypot(o.x - hx, o.y - hy)
            bk = math.atan2(o.y - hy, o.x - hx)
            d = abs((bj - bk + math.pi) % (2 * math.pi) - math.pi)
            if rk < rj and d <= math.asin(min(1.0, o.radius / rk)):
                ok = False
        out.append(ok)
    return out


def test_hand_worked_case() -> None:
    # head at the origin looking along +x; reflector 1 at 5 m on the x axis (radius 0.05 m:
    # extent asin(0.01) = 0.01 rad); reflector 2 behind it at 10 m, 0.02 m off the axis
    # (bearing 0.002 rad, inside): hidden; reflector 3 at 10 m, 0.2 m off the axis (bearing
    # 0.02 rad, outside): seen; reflector 4 at 0.3 m (below range_min 0.5 m): not seen, but
    # it still hides reflector 5 straight behind it at 3 m, -y; reflector 6 at 80 m: beyond
    # range_max 70 m
    refl = [Reflector(id=1, x=5.0, y=0.0), Reflector(id=2, x=10.0, y=0.02),
            Reflector(id=3, x=10.0, y=0.2), Reflector(id=4, x=0.0, y=-0.3),
            Reflector(id=5, x=0.0, y=-3.0), Reflector(id=6, x=0.0, y=80.0)]
    got = expected_visibility([0.0], [0.0], [0.0], refl, DeviceView.for_family("nav350"))
    assert got.shape == (1, 6)
    assert got[0].tolist() == [True, False, True, False, False, False]
    # from the other side, (15, 0.02), reflector 2 is the nearer one (5 m, covering bearing
    # pi +- 0.01 rad); reflector 1 lies at bearing atan2(-0.02, -10) = -pi + 0.002 rad: hidden
    got = expected_visibility([15.0], [0.02], [1.0], refl[:2], DeviceView.for_family("nav350"))
    assert got[0].tolist() == [False, True]


def test_field_of_view() -> None:
    refl = [Reflector(id=1, x=5.0, y=0.0), Reflector(id=2, x=-5.0, y=0.0)]
    view = DeviceView.for_family("nav350", {"field_of_view_deg": 180.0})
    got = expected_visibility([0.0, 0.0], [0.0, 0.0], [0.0, math.pi], refl, view)
    assert got.tolist() == [[True, False], [False, True]]


def test_against_brute_force() -> None:
    rng = np.random.default_rng(4)
    refl = [Reflector(id=i, x=float(x), y=float(y), radius=float(a)) for i, (x, y, a) in
            enumerate(zip(rng.uniform(0, 25, 40), rng.uniform(0, 20, 40),
                          rng.uniform(0.03, 0.4, 40), strict=True))]
    hx, hy = rng.uniform(0, 25, 300), rng.uniform(0, 20, 300)
    hth = rng.uniform(-math.pi, math.pi, 300)
    view = DeviceView.for_family("nav200", {"field_of_view_deg": 270.0})
    got = expected_visibility(hx, hy, hth, refl, view)
    want = np.array([_brute(float(a), float(b), float(c), refl, view)
                     for a, b, c in zip(hx, hy, hth, strict=True)])
    assert got.shape == want.shape == (300, 40)
    assert (got == want).all()
    # the case is not trivial: some hidden, some out of range, most seen
    assert 0.3 < got.mean() < 0.98


def test_blocks_give_the_same(monkeypatch: pytest.MonkeyPatch) -> None:
    rng = np.random.default_rng(1)
    refl = [Reflector(id=i, x=float(x), y=float(y), radius=0.2) for i, (x, y) in
            enumerate(zip(rng.uniform(0, 25, 12), rng.uniform(0, 20, 12), strict=True))]
    hx, hy, hth = rng.uniform(0, 25, 500), rng.uniform(0, 20, 500), np.zeros(500)
    view = DeviceView.for_family("nav350")
    whole = expected_visibility(hx, hy, hth, refl, view)
    monkeypatch.setattr(visibility, "PAIR_BUDGET", 144 * 7)
    assert len(list(visibility.pose_blocks(500, 12, visibility.PAIR_BUDGET))) == 72
    assert (expected_visibility(hx, hy, hth, refl, view) == whole).all()


def test_families_and_overrides() -> None:
    nav200, nav350 = DeviceView.for_family("nav200"), DeviceView.for_family("nav350")
    assert (nav200.range_min_m, nav200.range_max_m) == pytest.approx((1.2, 28.5), abs=1e-9)
    assert (nav350.range_min_m, nav350.range_max_m) == pytest.approx((0.5, 70.0), abs=1e-9)
    assert DeviceView.for_family("nav350", {"range_max_m": 28}).range_max_m == \
        pytest.approx(28.0, abs=1e-12)
    with pytest.raises(ConfigError, match="nav300"):
        DeviceView.for_family("nav300")
    with pytest.raises(ConfigError, match="range_max_m"):
        DeviceView.for_family("nav350", {"range_max_m": -1.0})


def test_empty_and_bad_shapes() -> None:
    view = DeviceView.for_family("nav350")
    assert expected_visibility([], [], [], [Reflector(id=1, x=1, y=1)], view).shape == (0, 1)
    assert expected_visibility([0.0], [0.0], [0.0], [], view).shape == (1, 0)
    with pytest.raises(ValueError):
        expected_visibility([0.0, 1.0], [0.0], [0.0], [Reflector(id=1, x=1, y=1)], view)
