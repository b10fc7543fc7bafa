"""The one coercer: types, finiteness and ranges, as every option, --set and config file sees."""

from __future__ import annotations

import math

import pytest

from lgvtool.errors import ConfigError
from lgvtool.values import MAX_COUNT, coerce, max_workers, parse_scalar


@pytest.mark.parametrize(("value", "kind", "expected"), [
    (3, int, 3), (1e3, int, 1000), (2, float, 2.0), ("yes", bool, True), (0, bool, False),
    ("laser", str, "laser"), (0.5, float, 0.5),
])
def test_good_values_pass(value: object, kind: type, expected: object) -> None:
    out = coerce("x", value, kind)
    assert out == expected and type(out) is type(expected)


@pytest.mark.parametrize(("value", "kind", "words"), [
    (math.nan, float, "must be a number"), (math.inf, float, "finite"),
    (-math.inf, float, "finite"), (1.5, int, "integer"), (True, int, "integer"),
    ("3", float, "number"), (2, bool, "true or false"), (MAX_COUNT + 1, int, "at most"),
    (1e30, int, "too large"), (3, str, "string"),
])
def test_bad_values_are_refused_by_name(value: object, kind: type, words: str) -> None:
    with pytest.raises(ConfigError, match=r"^pf\.particles") as err:
        coerce("pf.particles", value, kind)
    assert words in str(err.value)


def test_bounds_open_and_closed() -> None:
    assert coerce("d", 0.0, float, minimum=0.0) == 0.0
    with pytest.raises(ConfigError, match="above 0"):
        coerce("d", 0.0, float, minimum=0.0, min_open=True)
    with pytest.raises(ConfigError, match="at most 5"):
        coerce("d", 5.5, float, maximum=5.0)
    with pytest.raises(ConfigError, match="one of a, b"):
        coerce("c", "z", str, choices=("a", "b"))
    # a bound that %g would round is shown in full: "at most 1, got 1" would contradict itself
    with pytest.raises(ConfigError, match=r"at most 0\.999999999, got 1$"):
        coerce("p", 1.0, float, maximum=0.999999999)


def test_infinity_and_nan_only_where_they_mean_something() -> None:
    assert coerce("max_range_m", math.inf, float, allow_inf=True) == math.inf
    with pytest.raises(ConfigError):
        coerce("max_range_m", -math.inf, float, allow_inf=True)
    with pytest.raises(ConfigError, match="at most 10"):
        coerce("r", math.inf, float, allow_inf=True, maximum=10.0)
    assert math.isnan(coerce("false_x", math.nan, float, allow_nan=True))


def test_command_line_words() -> None:
    assert parse_scalar("1e3", int) == 1000 and parse_scalar(" 7 ", int) == 7
    nan = parse_scalar("nan", float)
    assert isinstance(nan, float) and math.isnan(nan)
    assert parse_scalar("false", bool) is False
    with pytest.raises(ValueError):
        parse_scalar("abc", float)


def test_worker_limit_follows_the_memory() -> None:
    assert 1 <= max_workers() <= 256


def test_grid_values_are_read_as_set_values() -> None:
    from lgvtool.config import parse_set_options
    from lgvtool.errors import ConfigError
    from lgvtool.fleet.tasks import parse_grid
    from lgvtool.values import parse_setting, split_assignment

    words = ["300", "1e3", "0.25", "true", "'quoted'", "bare", " spaced "]
    grid = parse_grid(["k=" + ",".join(words)])
    assert grid["k"] == [parse_set_options([f"k={w}"])["k"] for w in words]
    assert grid["k"] == [300, 1000.0, 0.25, True, "quoted", "bare", "spaced"]
    assert [type(v) for v in grid["k"]] == [int, float, float, bool, str, str, str]
    assert parse_setting(" 7 ") == 7 and split_assignment(" a.b =x=y") == ("a.b", "x=y")
    for bad, option in (("novalue", "--set"), ("=3", "--set")):
        with pytest.raises(ConfigError, match=f"{option} expects key=value, got '{bad}'"):
            parse_set_options([bad])
    with pytest.raises(ConfigError, match=r"--grid expects key=v1,v2,\.\.\., got '=1,2'"):
        parse_grid(["=1,2"])
