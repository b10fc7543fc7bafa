"""Every setting of the simulator, grouped by what it models, with ``--set`` overrides.

Keys are ``section.name``: ``sim.*`` (run), ``mcu.*`` (encoders, gyro, MCU link),
``nav.*`` (NAV200 head, solver, serial link), ``faults.*`` (injected faults) and ``scenario.*``
(parameters of the chosen scenario, see :mod:`lgvtool.sim.scenarios`). ``vehicle.*`` keys
belong to :class:`lgvtool.config.Vehicle` and are applied to the configuration instead.

Values are SI (m, s, rad) unless the key says otherwise (``*_deg``, ``*_dps``, ``*_ppm``,
``*_mm``). All defaults are documented in ``docs/simulator.md``.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import asdict, dataclass, field, fields, replace
from typing import Any

from lgvtool.errors import ConfigError
from lgvtool.suggest import unknown_tail
from lgvtool.values import MAX_COUNT, MAX_RATE_HZ, coerce


@dataclass(frozen=True)
class RunSettings:
    """How the simulation is run and time-stamped."""

    rate_hz: float = 200.0
    """Integration rate of the ground truth, Hz (at least 200)."""
    truth_rate_hz: float = 20.0
    """Rate of the logged ground truth /truth/pose, Hz."""
    start_epoch_s: int = 1_704_067_200
    """Host time of simulation time 0, whole s since the Unix epoch (2024-01-01T00:00:00Z)."""
    noise: bool = True
    """Master switch: false turns off every random error (NAV, MCU, timing jitter)."""
    nav_device: str = "nav200"
    """The laser device of the log: 'nav200' (serial, polled PP) or 'nav350' (SOPAS over
    Ethernet, pose and landmarks of every revolution; lgvtool.sim.nav350_simlink)."""


@dataclass(frozen=True)
class McuSettings:
    """Encoders, gyro, drive unit and the MCU serial link."""

    period_s: float = 0.100
    """Frame period of the MCU by its own clock, s."""
    baud: int = 115_200
    """Serial speed of the MCU link (8N1, 10 bits per byte), baud."""
    clock_drift_ppm: float = 25.0
    """MCU crystal error: its clock runs fast by this much, parts per million."""
    clock_offset_ms: int = 123_456
    """MCU clock reading at simulation time 0, ms."""
    send_jitter_s: float = 0.0005
    """Standard deviation of the MCU's send instant around its schedule, s."""
    host_latency_s: float = 0.001
    """Delay from the last byte on the wire to the host's read returning it (before jitter), s."""
    host_jitter_s: float = 0.002
    """Extra read delay, uniform in [0, host_jitter_s], s."""
    split_probability: float = 0.3
    """Probability that a frame reaches the host in two reads instead of one."""
    noise: bool = True
    """False turns off slip, gyro white noise and bias walk, steering and speed noise and the
    timing jitter (calibration errors and the constant gyro bias stay)."""
    wheel_radius_error_left: float = 0.002
    """True left wheel radius is nominal x (1 + this): a calibration error, dimensionless."""
    wheel_radius_error_right: float = -0.0015
    """True right wheel radius is nominal x (1 + this), dimensionless."""
    slip_sigma: float = 0.0015
    """Wheel slip: random walk of the counted travel, m per sqrt(m) travelled."""
    gyro_bias_dps: float = 0.05
    """Constant gyro bias, deg/s."""
    gyro_bias_walk_dps: float = 0.002
    """Gyro bias random walk, deg/s per sqrt(s)."""
    gyro_noise_dps: float = 0.05
    """White noise on each frame's gyro rate (mean over the frame period), deg/s: a rate noise
    density of 0.015 deg/s/sqrt(Hz), typical of a +-300 deg/s MEMS gyro, averaged over 0.1 s."""
    gyro_scale_error: float = 0.003
    """Gyro scale factor error, dimensionless."""
    steering_noise_deg: float = 0.05
    """Noise of the reported steering angle, deg."""
    speed_noise: float = 0.003
    """Noise of the reported drive wheel speed, m/s."""
    gyro_scale_udeg_s: int = 10_986
    """Gyro quantisation step, micro-deg/s per count (360/32768 deg/s: +-360 deg/s in int16)."""


@dataclass(frozen=True)
class NavSettings:
    """The NAV200: rotating head, reflector measurements, pose solver and serial link."""

    rotation_hz: float = 8.0
    """Head revolutions per second relative to the vehicle, Hz."""
    clockwise: bool = False
    """Direction of the head's rotation; false: counter-clockwise seen from above."""
    scan_start_deg: float = 90.0
    """Head angle in the vehicle frame at which a revolution (scan) starts and the device closes
    its data set, deg (undocumented for the NAV200; see docs/simulator.md)."""
    skew: bool = True
    """Each reflector is measured at its own instant of the revolution; false: all at once
    (mid-revolution), i.e. an ideal motion-compensated device."""
    range_min: float = 0.5
    """Closest measurable reflector (centre), m."""
    range_max: float = 28.0
    """Farthest measurable reflector (centre), m."""
    noise: bool = True
    """False turns off range and bearing noise, missed detections and the poll and read jitter."""
    sigma_range_mm: float = 12.0
    """Range noise, standard deviation, mm."""
    sigma_bearing_deg: float = 0.05
    """Bearing noise, standard deviation, deg."""
    detection_probability: float = 0.9
    """Probability that a visible reflector is detected in a revolution (within
    detection_range_m; calibrated to the spread of the paper's Table 1)."""
    sigma_range_per_m_mm: float = 1.0
    """Growth of the range noise with range: its standard deviation is sigma_range_mm plus this
    times the range in m, mm per m (the echo weakens with range)."""
    detection_range_m: float = 12.0
    """Beyond this range the detection probability falls as (detection_range_m / range)^2
    (echo energy of a reflector narrower than the beam), m; 0: no fall-off."""
    reflector_radius_mm: float = 50.0
    """Radius of the reflector cylinders, mm (the paper's 10 cm diameter): the head measures
    the surface it hits and adds this radius, so the apparent centre depends on which pulses hit."""
    angle_step_deg: float = 0.1
    """Angular step between the head's laser pulses, deg: the edges of each reflector's return
    fall on this grid (its phase random per revolution); 0: continuous bearings and ranges to
    the centre."""
    solver_sigma_range_mm: float = 12.0
    """Range standard deviation the device assumes when weighting its fit, mm."""
    solver_sigma_bearing_deg: float = 0.04
    """Bearing standard deviation the device assumes when weighting its fit, deg (calibrated to
    the bias of the paper's Table 1)."""
    solver_iterations: int = 6
    """Gauss-Newton iterations per revolution."""
    gate: float = 0.4
    """An observation is matched to the nearest stored reflector within this distance, m."""
    min_reflectors: int = 3
    """Fewest matched reflectors for a valid position."""
    max_reflectors: int = 6
    """The device fits only this many nearest matched reflectors (NAV200 PC command); 0: all
    (calibrated to the spread of the paper's Table 1)."""
    quality_rms_mm: float = 250.0
    """Quality falls from 100 to 0 as the fit's RMS range residual grows to this, mm."""
    latency_s: float = 0.040
    """Time from the end of a revolution until its pose can be reported, s."""
    reply_delay_s: float = 0.005
    """Time from the end of a request to the first reply byte, s."""
    poll_period_s: float = 0.450
    """Host poll period of the PP request, s."""
    poll_start_s: float = 0.5
    """Time of the first poll, s."""
    poll_jitter_s: float = 0.002
    """Host scheduling jitter of each poll, uniform in [0, poll_jitter_s], s."""
    baud: int = 19_200
    """Serial speed (8E1, 11 bits per byte), baud."""
    host_latency_s: float = 0.001
    """Delay from the last byte on the wire to the host's read returning it (before jitter), s."""
    host_jitter_s: float = 0.002
    """Extra read delay, uniform in [0, host_jitter_s], s."""
    split_probability: float = 0.3
    """Probability that a reply reaches the host in two reads instead of one."""
    map_sigma_mm: float = 10.0
    """Survey error of the device's stored reflector map (per reflector, per axis), mm: the map
    every consumer of the log gets; the reflectors really stand this far off it."""


@dataclass(frozen=True)
class FaultSettings:
    """Faults injected on purpose (all off by default; the ``degraded`` scenario sets them)."""

    mcu_drop_rate: float = 0.0
    """Fraction of MCU frames lost on the link."""
    mcu_corrupt_rate: float = 0.0
    """Fraction of MCU frames with one bit flipped after the header (CRC fails)."""
    nav_request_drop_rate: float = 0.0
    """Fraction of PP requests that never reach the device (no reply)."""
    nav_reply_drop_rate: float = 0.0
    """Fraction of PP replies lost on the link."""
    nav_corrupt_rate: float = 0.0
    """Fraction of PP replies with one bit flipped in the data (BCC fails)."""
    nav_invalid_rate: float = 0.0
    """Fraction of PP replies in which the device reports no valid position (quality 0xFF)."""
    occlusion_fraction: float = 0.0
    """Fraction of the time each reflector is hidden (pallets, people), dimensionless."""
    occlusion_mean_s: float = 6.0
    """Mean length of one occlusion stretch, s."""
    false_reflector: bool = False
    """Place a shiny object that the head takes for a reflector."""
    false_x: float = math.nan
    """Position of the shiny object, m; NaN: beside the reflector ``false_near_id``."""
    false_y: float = math.nan
    """Position of the shiny object, m; NaN: beside the reflector ``false_near_id``."""
    false_near_id: int = 3
    """Reflector beside which the shiny object stands (when false_x/false_y are NaN)."""
    false_offset: float = 0.3
    """Distance of the shiny object from that reflector, along the wall, m."""
    false_detection_probability: float = 0.6
    """Probability that the head sees the shiny object in a revolution."""


ONLY_WHEN_SET: dict[tuple[str, str], Any] = {("sim", "nav_device"): "nav200"}
"""Settings recorded only when they differ from this default, so that the logs of runs made
before they existed are written again byte for byte."""


@dataclass(frozen=True)
class InstallSettings:
    """Installation errors the host does not know: the true vehicle differs from the configured
    (nominal) one by these amounts; the log's stored configuration keeps the nominal values.

    The true wheel radii and the gyro's scale factor and bias are the ``mcu.wheel_radius_error_*``,
    ``mcu.gyro_scale_error`` and ``mcu.gyro_bias_dps`` settings (see :data:`INSTALLATION`).
    """

    nav_dx_mm: float = 0.0
    """True NAV head position minus the configured ``vehicle.nav_x`` (forward), mm."""
    nav_dy_mm: float = 0.0
    """True NAV head position minus the configured ``vehicle.nav_y`` (left), mm."""
    nav_yaw_deg: float = 0.0
    """True mounting yaw of the head minus the configured ``vehicle.nav_yaw`` (counter-clockwise),
    deg: the head measures its bearings from, and reports the heading of, its own x axis."""
    track_error_mm: float = 0.0
    """True track between the encoder wheels minus the configured ``vehicle.track``, mm."""
    nav_time_offset_ms: float = 0.0
    """Constant NAV-to-host time offset: every NAV200 reply reaches the host, and every scan is
    stamped on the host's clock, this much later than it happened, ms (may be negative)."""


INSTALLATION: dict[str, str] = {
    "install.nav_dx_mm": "true NAV head x minus the configured vehicle.nav_x (forward), mm",
    "install.nav_dy_mm": "true NAV head y minus the configured vehicle.nav_y (left), mm",
    "install.nav_yaw_deg": "true mounting yaw of the head minus the configured vehicle.nav_yaw, "
                           "deg (counter-clockwise)",
    "install.track_error_mm": "true encoder-wheel track minus the configured vehicle.track, mm",
    "install.nav_time_offset_ms": "NAV replies and scans reach the host this much later than "
                                  "they happened, ms",
    "mcu.wheel_radius_error_left": "true left wheel radius = configured x (1 + this)",
    "mcu.wheel_radius_error_right": "true right wheel radius = configured x (1 + this)",
    "mcu.gyro_scale_error": "the gyro reports (1 + this) x the true yaw rate (+ bias)",
    "mcu.gyro_bias_dps": "constant gyro bias, deg/s",
}
"""Every setting that makes the true vehicle differ from its configuration, with its meaning
(``simulate --list`` shows them; the log's stored configuration keeps the nominal values)."""


def setting_value(settings: SimSettings, key: str) -> Any:
    """The value of a ``section.name`` setting."""
    section, _, name = key.partition(".")
    return getattr(getattr(settings, section), name)


SECTIONS: dict[str, type] = {
    "sim": RunSettings,
    "mcu": McuSettings,
    "nav": NavSettings,
    "faults": FaultSettings,
    "install": InstallSettings,
}
"""Section name -> settings class (``scenario`` and ``vehicle`` are handled apart)."""


@dataclass(frozen=True)
class SimSettings:
    """All simulator settings of one run."""

    sim: RunSettings = field(default_factory=RunSettings)
    mcu: McuSettings = field(default_factory=McuSettings)
    nav: NavSettings = field(default_factory=NavSettings)
    faults: FaultSettings = field(default_factory=FaultSettings)
    install: InstallSettings = field(default_factory=InstallSettings)
    scenario: Mapping[str, Any] = field(default_factory=dict)
    """Parameters of the scenario (validated by the scenario)."""

    def to_dict(self, installation: bool = True) -> dict[str, Any]:
        """Every setting as a nested JSON-able dict (NaN written as None); the settings of
        :data:`ONLY_WHEN_SET` only when they differ from their default. The ``install``
        section only when ``installation`` and some installation error is set (a log's stored
        configuration leaves it out: the host does not know it)."""
        out: dict[str, Any] = {}
        for name in SECTIONS:
            if name == "install" and not (installation and self.install != InstallSettings()):
                continue
            out[name] = {k: _jsonable(v) for k, v in asdict(getattr(self, name)).items()
                         if (name, k) not in ONLY_WHEN_SET or v != ONLY_WHEN_SET[(name, k)]}
        out["scenario"] = {k: _jsonable(v) for k, v in self.scenario.items()}
        return out

    @property
    def mcu_noise(self) -> bool:
        """True when MCU noise is on (both the master switch and mcu.noise)."""
        return self.sim.noise and self.mcu.noise

    @property
    def nav_noise(self) -> bool:
        """True when NAV noise is on (both the master switch and nav.noise)."""
        return self.sim.noise and self.nav.noise


def _jsonable(v: Any) -> Any:
    if isinstance(v, float) and not math.isfinite(v):
        return None
    return v


#: upper ends of settings beyond the generic maxima of :mod:`lgvtool.values`
_MAXIMA: dict[str, float] = {
    "sim.rate_hz": MAX_RATE_HZ, "sim.truth_rate_hz": MAX_RATE_HZ, "nav.rotation_hz": 100.0,
    "sim.start_epoch_s": 7_258_118_400,  # 2200-01-01
    "mcu.clock_offset_ms": 2**32 - 1, "mcu.baud": 4_000_000, "nav.baud": 4_000_000,
    "mcu.gyro_scale_udeg_s": 0xFFFF, "nav.solver_iterations": 1000,
    "nav.min_reflectors": 64, "nav.max_reflectors": 64, "faults.false_near_id": MAX_COUNT,
}
#: largest magnitude of any other number: lengths, times and noise levels of a hall-sized run
_MAGNITUDE = 1e6


def _coerce(key: str, value: Any, kind: type, default: Any = None) -> Any:
    unset = isinstance(default, float) and math.isnan(default)  # NaN means "not set"
    if unset and (value is None or (isinstance(value, str) and value.lower() == "nan")):
        return math.nan
    if kind is str:
        return str(value)
    if kind in (int, float):
        top = _MAXIMA.get(key, _MAGNITUDE)
        return coerce(key, value, kind, minimum=-_MAGNITUDE, maximum=top, allow_nan=unset)
    return coerce(key, value, kind)


def _field_types(cls: type) -> dict[str, type]:
    names = {"bool": bool, "int": int, "float": float, "str": str}
    return {f.name: names[str(f.type)] for f in fields(cls)}


def apply_overrides(settings: SimSettings, overrides: Mapping[str, Any]) -> SimSettings:
    """Apply ``{"section.key": value}`` overrides (``scenario.*`` unchecked here).

    Raises ConfigError for an unknown section or key or a value of the wrong type.
    """
    grouped: dict[str, dict[str, Any]] = {}
    scenario = dict(settings.scenario)
    for full_key, value in overrides.items():
        section, _, key = full_key.partition(".")
        if not key:
            raise ConfigError(f"setting '{full_key}' must be section.key "
                              f"(sections: {', '.join([*SECTIONS, 'scenario', 'vehicle'])})")
        if section == "scenario":
            scenario[key] = value
            continue
        cls = SECTIONS.get(section)
        if cls is None:
            raise ConfigError(f"unknown setting section '{section}' in '{full_key}'"
                              + unknown_tail(section, [*SECTIONS, "scenario", "vehicle"],
                                             label="sections"))
        types = _field_types(cls)
        if key not in types:
            raise ConfigError(f"unknown setting '{full_key}'" + unknown_tail(
                key, types, prefix=f"{section}.", label=f"known in {section}",
                more=f"{len(types)} settings in {section}; docs/simulator.md#settings lists them"))
        default = getattr(cls(), key)
        grouped.setdefault(section, {})[key] = _coerce(full_key, value, types[key], default)
    out = replace(settings, scenario=scenario)
    for section, values in grouped.items():
        out = replace(out, **{section: replace(getattr(out, section), **values)})
    return validate(out)


def flatten(table: Mapping[str, Any], prefix: str = "") -> dict[str, Any]:
    """Flatten a nested table (e.g. a TOML ``[simulator]`` section) to ``section.key`` keys."""
    out: dict[str, Any] = {}
    for k, v in table.items():
        key = f"{prefix}{k}"
        if isinstance(v, Mapping):
            out.update(flatten(v, key + "."))
        else:
            out[key] = v
    return out


def validate(s: SimSettings) -> SimSettings:
    """Check ranges; raise ConfigError naming the first bad setting."""
    checks: list[tuple[bool, str]] = [
        (s.sim.rate_hz >= 200.0, "sim.rate_hz must be at least 200"),
        (s.sim.truth_rate_hz > 0 and s.sim.truth_rate_hz <= s.sim.rate_hz,
         "sim.truth_rate_hz must be positive and at most sim.rate_hz"),
        (s.sim.start_epoch_s >= 0, "sim.start_epoch_s must not be negative"),
        (s.sim.nav_device in ("nav200", "nav350"), "sim.nav_device must be nav200 or nav350"),
        (s.mcu.period_s > 0.005, "mcu.period_s must exceed 0.005"),
        (s.mcu.baud > 0 and s.nav.baud > 0, "baud rates must be positive"),
        (s.nav.rotation_hz > 0.5, "nav.rotation_hz must exceed 0.5"),
        (0 < s.nav.range_min < s.nav.range_max, "nav.range_min must be in (0, nav.range_max)"),
        (s.nav.poll_period_s > 0.05, "nav.poll_period_s must exceed 0.05"),
        (s.nav.min_reflectors >= 2, "nav.min_reflectors must be at least 2"),
        (s.nav.max_reflectors == 0 or s.nav.max_reflectors >= s.nav.min_reflectors,
         "nav.max_reflectors must be 0 (all) or at least nav.min_reflectors"),
        (s.nav.solver_iterations >= 1, "nav.solver_iterations must be at least 1"),
        (s.nav.solver_sigma_range_mm > 0 and s.nav.solver_sigma_bearing_deg > 0,
         "nav.solver_sigma_* must be positive"),
        (s.nav.gate > 0, "nav.gate must be positive"),
        (s.nav.sigma_range_per_m_mm >= 0, "nav.sigma_range_per_m_mm must not be negative"),
        (s.nav.detection_range_m >= 0, "nav.detection_range_m must not be negative"),
        (0 <= s.nav.reflector_radius_mm < 1000, "nav.reflector_radius_mm must be in [0, 1000)"),
        (0 <= s.nav.angle_step_deg <= 5, "nav.angle_step_deg must be in [0, 5]"),
        (s.nav.quality_rms_mm > 0, "nav.quality_rms_mm must be positive"),
        (0 < s.mcu.gyro_scale_udeg_s <= 0xFFFF, "mcu.gyro_scale_udeg_s must be in 1..65535"),
        (s.faults.occlusion_mean_s > 0, "faults.occlusion_mean_s must be positive"),
        (0 <= s.faults.occlusion_fraction < 1, "faults.occlusion_fraction must be in [0, 1)"),
    ]
    for ok, message in checks:
        if not ok:
            raise ConfigError(message)
    nonneg = {
        "mcu": ("send_jitter_s", "host_latency_s", "host_jitter_s", "slip_sigma",
                "gyro_bias_walk_dps", "gyro_noise_dps", "steering_noise_deg", "speed_noise"),
        "nav": ("sigma_range_mm", "sigma_bearing_deg", "latency_s", "reply_delay_s",
                "poll_start_s", "poll_jitter_s", "host_latency_s", "host_jitter_s",
                "map_sigma_mm"),
    }
    for section, keys in nonneg.items():
        for key in keys:
            if getattr(getattr(s, section), key) < 0:
                raise ConfigError(f"{section}.{key} must not be negative")
    probabilities = {
        "mcu": ("split_probability",),
        "nav": ("detection_probability", "split_probability"),
        "faults": ("mcu_drop_rate", "mcu_corrupt_rate", "nav_request_drop_rate",
                   "nav_reply_drop_rate", "nav_corrupt_rate", "nav_invalid_rate",
                   "false_detection_probability"),
    }
    for section, keys in probabilities.items():
        for key in keys:
            p = getattr(getattr(s, section), key)
            if not 0.0 <= p <= 1.0:
                raise ConfigError(f"{section}.{key} must be in [0, 1], got {p}")
    return s
