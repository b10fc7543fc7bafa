"""Vehicle geometry, reflector map and run settings: TOML in, typed objects out.

Units inside lgvtool are SI (m, rad, s). The TOML file uses the same units except where a key
says otherwise (``*_deg``). Defaults come from the paper's experiment (see ``docs/config.md``).

Example::

    [vehicle]
    h = 1.20                 # m, target rotation centre O to drive wheel contact
    track = 0.60             # m, between the two encoder wheels
    wheel_radius_left = 0.075
    wheel_radius_right = 0.075
    encoder_ppr = 1000       # pulses per revolution
    gyro_range_dps = 360.0   # deg/s, full scale
    nav_x = 1.00             # m, NAV200 head position in the vehicle frame (forward)
    nav_y = 0.0              # m (left)
    nav_yaw = 0.0            # rad, mounting yaw of the head (lgvtool calibrate estimates it)

    [area]                   # the work area, m (particle filters initialise over it)
    x_min = 0.0
    x_max = 25.0
    y_min = 0.0
    y_max = 20.0

    [reference]
    steering_angle_deg = 60.0   # used when a log has no steering angle

    [[reflectors]]
    id = 1
    x = 0.05
    y = 1.79
    radius = 0.05

    [estimators.pf]          # passed to the estimator, checked there
    particles = 300
"""

from __future__ import annotations

import math
import tomllib
from collections.abc import Callable, Iterable, Mapping
from dataclasses import asdict, dataclass, field, replace
from pathlib import Path
from typing import Any

from lgvtool.declared import REQUIRED, check_table, setting
from lgvtool.errors import ConfigError
from lgvtool.json_types import SettingValue
from lgvtool.suggest import unknown_tail
from lgvtool.values import parse_setting, split_assignment


@dataclass(frozen=True)
class Vehicle:
    """Geometry of the forklift LGV (domain.md section 1). Lengths in m, angles in rad."""

    h: float = setting(
        1.20,
        "Distance from the target rotation centre O to the drive wheel contact point, m.",
        unit="m", minimum=0.0, min_open=True)
    track: float = setting(
        0.60,
        "Track ``l`` between the two encoder (auxiliary) wheels, m.",
        unit="m", minimum=0.0, min_open=True)
    wheel_radius_left: float = setting(
        0.075, "Left encoder wheel radius, m.", unit="m", minimum=0.0, min_open=True)
    wheel_radius_right: float = setting(
        0.075, "Right encoder wheel radius, m.", unit="m", minimum=0.0, min_open=True)
    encoder_ppr: int = setting(
        1000,
        "Encoder pulses per wheel revolution (LIB-49B: 1000).",
        unit="", minimum=0, min_open=True, maximum=10**7)
    gyro_range_dps: float = setting(
        360.0,
        "Gyro full scale, deg/s (my-Gyro-300 SPI: +-360).",
        unit="deg/s", minimum=0.0, min_open=True)
    nav_x: float = setting(
        1.00, "NAV200 head position in the vehicle frame, forward of O, m (d_x).", unit="m")
    nav_y: float = setting(
        0.0, "NAV200 head position in the vehicle frame, left of O, m (d_y).", unit="m")
    nav_height: float = setting(
        1.9, "NAV200 head height above the floor, m (not used in 2-D).", unit="m", minimum=0.0)
    nav_yaw: float = setting(
        0.0,
        "Mounting yaw of the NAV200 head: its x axis is turned this much counter-clockwise from "
        "the vehicle's, rad. The head measures bearings from, and reports the heading of, its "
        "axis.",
        unit="rad")
    nav_time_offset: float = setting(
        0.0,
        "NAV-to-host time offset: NAV poses and scans are stamped this much later than they "
        "happened on the motion data's clock, s (may be negative).",
        unit="s")
    nav_pose_age: float = setting(
        0.0,
        "Age of a NAV pose when the host receives it, beyond ``nav_time_offset`` (the device's own "
        "delay from the middle of the revolution to its reply), s; 0 to 2 s (a NAV answers within "
        "a few revolutions).",
        unit="s", minimum=0.0, maximum=2.0)
    gyro_scale: float = setting(
        1.0,
        "Gyro scale factor: the MCU reports ``gyro_scale * rate + gyro_bias``, dimensionless.",
        unit="", minimum=0.0, min_open=True)
    gyro_bias: float = setting(
        0.0, "Gyro bias, rad/s (see ``gyro_scale``).", unit="rad/s")
    odom_scale_v: float = setting(
        1.0,
        "Generic odometry (/odom/twist): the vehicle travels ``odom_scale_v * v``, dimensionless.",
        unit="", minimum=0.0, min_open=True)
    odom_scale_w: float = setting(
        1.0,
        "Generic odometry: the vehicle turns ``odom_scale_w * omega``, dimensionless.",
        unit="", minimum=0.0, min_open=True)
    odom_yaw_per_m: float = setting(
        0.0,
        "Generic odometry: the vehicle also turns this much per metre of reported travel "
        "(``odom_yaw_per_m * v`` on top of ``odom_scale_w * omega``), rad/m; positive to the left. "
        "A drift to one side while driving straight, as wheels of unequal size give.",
        unit="rad/m")

    def circle_radius(self, steering_angle: float) -> float:
        """Radius of the circle that O drives at a fixed steering angle, m: R = h / tan(delta)."""
        t = math.tan(steering_angle)
        if abs(t) < 1e-12:
            return math.inf
        return self.h / abs(t)

    def metres_per_count(self) -> tuple[float, float]:
        """Travel of the (left, right) encoder wheel per count, m."""
        k = 2.0 * math.pi / self.encoder_ppr
        return k * self.wheel_radius_left, k * self.wheel_radius_right


@dataclass(frozen=True)
class Reflector:
    """A reflector (or landmark) at a known position in the map frame."""

    id: int = setting(
        REQUIRED, "Id of the reflector, unique in its map.", unit="", maximum=2**31 - 1)
    x: float = setting(
        REQUIRED, "X of the centre, m.", unit="m")
    y: float = setting(
        REQUIRED, "Y of the centre, m.", unit="m")
    radius: float = setting(
        0.05, "Radius, m (the paper's cylinders are 10 cm in diameter).", unit="m", minimum=0.0)
    layer: int = setting(
        0, "NAV200 layer.", unit="", minimum=0, maximum=255)


@dataclass(frozen=True)
class Area:
    """An axis-aligned rectangle in the map frame, m."""

    x_min: float = setting(
        0.0, "West edge, m.", unit="m")
    x_max: float = setting(
        25.0, "East edge, m.", unit="m")
    y_min: float = setting(
        0.0, "South edge, m.", unit="m")
    y_max: float = setting(
        20.0, "North edge, m.", unit="m")

    @property
    def width(self) -> float:
        """Extent along x, m."""
        return self.x_max - self.x_min

    @property
    def height(self) -> float:
        """Extent along y, m."""
        return self.y_max - self.y_min


@dataclass(frozen=True)
class Reference:
    """What the evaluation compares against when the log does not say."""

    steering_angle_deg: float | None = setting(
        60.0,
        "Nominal steering angle of a circle drive, deg; None (``false`` in TOML): from the log "
        "only.",
        unit="deg")


@dataclass(frozen=True)
class Config:
    """The effective configuration of a run."""

    vehicle: Vehicle = field(default_factory=Vehicle)
    area: Area = field(default_factory=Area)
    reference: Reference = field(default_factory=Reference)
    reflectors: tuple[Reflector, ...] = ()
    estimators: Mapping[str, Mapping[str, Any]] = field(default_factory=dict)
    simulator: Mapping[str, Any] = field(default_factory=dict)

    def to_dict(self) -> dict[str, Any]:
        """A plain dict (TOML/JSON-ready) of every setting."""
        return {
            "vehicle": asdict(self.vehicle),
            "area": asdict(self.area),
            "reference": {k: False if v is None else v for k, v in asdict(self.reference).items()},
            "reflectors": [asdict(r) for r in self.reflectors],
            "estimators": {k: dict(v) for k, v in self.estimators.items()},
            "simulator": dict(self.simulator),
        }


_HALL_OFFSETS = (0.00, 0.31, -0.22, 0.12, -0.35, 0.27, -0.08, 0.19, -0.29, 0.05,
                 0.34, -0.15, 0.23, -0.31, 0.09, -0.24, 0.29, -0.04, 0.16, -0.19)
"""Irregular spacing of the default reflectors, in units of the mean spacing along the walls."""


def paper_hall_reflectors(area: Area | None = None, count: int = 20) -> tuple[Reflector, ...]:
    """The paper's hall: ``count`` 10 cm cylinders on the walls of a 25 m x 20 m room.

    Reflectors stand 5 cm off the walls (their centres), spread along the perimeter at a mean
    spacing of perimeter / count, each shifted by up to a third of that spacing
    (:data:`_HALL_OFFSETS`). Evenly spaced reflectors in a rectangle look the same from two poses
    half a turn apart, which no localiser can tell apart; installers avoid such layouts, and so
    does this default. Ids run 1..count counter-clockwise from the south-west corner.
    """
    a = area or Area()
    inset = 0.05
    x0, x1, y0, y1 = a.x_min + inset, a.x_max - inset, a.y_min + inset, a.y_max - inset
    w, h = x1 - x0, y1 - y0
    perimeter = 2 * (w + h)
    out = []
    for i in range(count):
        s = (i + 0.5 + _HALL_OFFSETS[i % len(_HALL_OFFSETS)]) * perimeter / count
        if s < w:
            x, y = x0 + s, y0
        elif s < w + h:
            x, y = x1, y0 + (s - w)
        elif s < 2 * w + h:
            x, y = x1 - (s - w - h), y1
        else:
            x, y = x0, y1 - (s - 2 * w - h)
        out.append(Reflector(id=i + 1, x=round(x, 4), y=round(y, 4), radius=0.05, layer=0))
    return tuple(out)


def default_config() -> Config:
    """Defaults from domain.md: the paper's vehicle, hall and reflector layout."""
    area = Area()
    return Config(area=area, reflectors=paper_hall_reflectors(area))


# --------------------------------------------------------------------------- loading


def _check_section(name: str, table: Any, cls: type) -> dict[str, Any]:
    return check_table(cls, name, table, what="key",
                       more="{n} keys in [" + name + "]; lgvtool config --parameters lists them")


def reflectors_from_tables(items: object) -> tuple[Reflector, ...]:
    """Reflectors from a list of tables (``[[reflectors]]``, or a logged map's entries): ``id``,
    ``x``, ``y`` (m) required, ``radius`` (m) and ``layer`` optional, each checked as every
    configuration number is (its type, finite, within 10^6); ids unique, radii not negative.

    :raises ConfigError: not a list of such tables.
    """
    if not isinstance(items, list):
        raise ConfigError("reflectors must be an array of tables ([[reflectors]])")
    refl = []
    for i, item in enumerate(items):
        where = f"reflectors[{i}]"
        d = _check_section(where, item, Reflector)
        for req in ("id", "x", "y"):
            if req not in d:
                raise ConfigError(f"missing value for {where}.{req}")
        refl.append(Reflector(**d))
    _check_map(refl)
    return tuple(refl)


def _validate(cfg: Config) -> Config:
    a = cfg.area
    if not (a.x_max > a.x_min and a.y_max > a.y_min):
        raise ConfigError("area: x_max must exceed x_min and y_max must exceed y_min")
    d = cfg.reference.steering_angle_deg
    if d is not None and not (0.0 < abs(d) < 90.0):
        raise ConfigError(f"reference.steering_angle_deg must be in (0, 90) in magnitude, got {d}")
    _check_map(cfg.reflectors)
    return cfg


def _check_map(reflectors: Iterable[Reflector]) -> None:
    """A map's ids unique and its radii not negative (ConfigError otherwise)."""
    seen: set[int] = set()
    for r in reflectors:
        if r.id in seen:
            raise ConfigError(f"reflector map has duplicate id {r.id}")
        seen.add(r.id)
        if r.radius < 0:
            raise ConfigError(f"reflector {r.id}: radius must not be negative, got {r.radius}")


def config_from_dict(data: Mapping[str, Any], base: Config | None = None) -> Config:
    """Build a validated :class:`Config` from parsed TOML, starting from ``base`` (defaults)."""
    cfg = base or default_config()
    known = {"vehicle", "area", "reference", "reflectors", "estimators", "simulator"}
    for key in data:
        if key not in known:
            raise ConfigError(f"unknown section '{key}'" + unknown_tail(key, sorted(known)))
    if "vehicle" in data:
        vehicle = _check_section("vehicle", data["vehicle"], Vehicle)
        cfg = replace(cfg, vehicle=replace(cfg.vehicle, **vehicle))
    if "area" in data:
        cfg = replace(cfg, area=replace(cfg.area, **_check_section("area", data["area"], Area)))
    if "reference" in data:
        reference = _check_section("reference", data["reference"], Reference)
        cfg = replace(cfg, reference=replace(cfg.reference, **reference))
    if "reflectors" in data:
        cfg = replace(cfg, reflectors=reflectors_from_tables(data["reflectors"]))
    for section in ("estimators", "simulator"):
        if section in data and not isinstance(data[section], dict):
            raise ConfigError(f"[{section}] must be a table")
    if "estimators" in data:
        cfg = replace(cfg, estimators=_section_check("estimators")(data["estimators"], cfg))
    if "simulator" in data:
        cfg = replace(cfg, simulator=_section_check("simulator")(data["simulator"], cfg))
    return _validate(cfg)


SectionCheck = Callable[[Mapping[str, Any], Config], dict[str, Any]]
"""Checks a table (``[estimators]``, ``[simulator]``) against the layer that owns its names, given
the configuration built so far; returns the table to keep. Raises :class:`ConfigError`."""

_SECTION_CHECKS: dict[str, SectionCheck] = {}
"""Section -> its check: ``[estimators]`` by the estimators, ``[simulator]`` by the simulator.
They live above this module (``lgvtool/config_checks.py``), which imports neither
``lgvtool.localize`` nor ``lgvtool.sim``; ``lgvtool/__init__.py`` registers them, so they are
there before any configuration is loaded (docs/architecture.md)."""


def register_section_check(section: str, check: SectionCheck) -> None:
    """Check ``[section]`` with ``check`` whenever a configuration holding it is built."""
    _SECTION_CHECKS[section] = check


def _section_check(section: str) -> SectionCheck:
    try:
        return _SECTION_CHECKS[section]
    except KeyError:  # never skip a check: lgvtool/__init__.py registers every one
        raise RuntimeError(f"no check registered for [{section}] (lgvtool/__init__.py "
                           "registers them)") from None


def load_config(path: str | Path | None) -> Config:
    """Load a TOML configuration over the defaults; ``None`` gives the defaults."""
    if path is None:
        return default_config()
    p = Path(path)
    if not p.is_file():
        raise ConfigError(f"configuration file not found: {p}")
    try:
        data = tomllib.loads(p.read_text(encoding="utf-8"))
    except tomllib.TOMLDecodeError as exc:
        raise ConfigError(f"{p}: malformed TOML: {exc}") from None
    except UnicodeDecodeError:
        raise ConfigError(f"{p}: not a text file") from None
    try:
        return config_from_dict(data)
    except ConfigError as exc:
        raise ConfigError(f"{p}: {exc}") from None


def parse_set_options(items: tuple[str, ...] | list[str]) -> dict[str, SettingValue]:
    """Parse ``--set key=value`` options; values are read by
    :func:`lgvtool.values.parse_setting` (TOML scalars, else a bare string), as ``--grid``'s."""
    out: dict[str, SettingValue] = {}
    for item in items:
        key, raw = split_assignment(item, "--set")
        out[key] = parse_setting(raw)
    return out


def to_toml(data: Mapping[str, Any]) -> str:
    """Write a config dict (as :meth:`Config.to_dict` gives) as TOML."""
    lines: list[str] = []

    def scalar(v: object) -> str:
        if isinstance(v, bool):
            return "true" if v else "false"
        if isinstance(v, int | float):
            return repr(v)
        if isinstance(v, str):
            return '"' + v.replace("\\", "\\\\").replace('"', '\\"') + '"'
        if isinstance(v, list | tuple):
            return "[" + ", ".join(scalar(x) for x in v) + "]"
        raise TypeError(f"cannot write {type(v).__name__} as TOML")

    def table(prefix: str, d: Mapping[str, object]) -> None:
        plain = {k: v for k, v in d.items() if not isinstance(v, dict) and v is not None}
        nested = {k: v for k, v in d.items() if isinstance(v, dict)}
        if plain or not nested:
            lines.append(f"[{prefix}]")
            lines.extend(f"{k} = {scalar(v)}" for k, v in plain.items())
            lines.append("")
        for k, v in nested.items():
            table(f"{prefix}.{k}", v)

    for key, value in data.items():
        if key == "reflectors":
            for r in value:
                lines.append("[[reflectors]]")
                lines.extend(f"{k} = {scalar(v)}" for k, v in r.items())
                lines.append("")
        elif isinstance(value, dict) and value:
            table(key, value)
    return "\n".join(lines)
