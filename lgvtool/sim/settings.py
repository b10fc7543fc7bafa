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
from dataclasses import asdict, dataclass, field, replace

from lgvtool.declared import REQUIRED, make, setting
from lgvtool.errors import ConfigError
from lgvtool.json_types import JSON, JSONObject
from lgvtool.suggest import unknown_tail
from lgvtool.values import MAX_COUNT, MAX_RATE_HZ


@dataclass(frozen=True)
class RunSettings:
    """How the simulation is run and time-stamped."""

    rate_hz: float = setting(
        200.0,
        "Integration rate of the ground truth, Hz (at least 200).",
        unit="Hz", minimum=200.0, maximum=MAX_RATE_HZ)
    truth_rate_hz: float = setting(
        20.0,
        "Rate of the logged ground truth /truth/pose, Hz.",
        unit="Hz", minimum=0.0, min_open=True, maximum=MAX_RATE_HZ)
    start_epoch_s: int = setting(
        1_704_067_200,
        "Host time of simulation time 0, whole s since the Unix epoch (2024-01-01T00:00:00Z).",
        unit="s", minimum=0, maximum=7_258_118_400)
    noise: bool = setting(
        True,
        "Master switch: false turns off every random error (NAV, MCU, timing jitter).",
        unit="")
    world: str = setting(
        "site",
        "The world model: 'site' (a real site's imperfections: the drive and site sections "
        "at their defaults) or 'ideal' (the kind world of model 1: a kinematic path, a layout "
        "10 mm off, no reflector bias or tilt, the NAV200's reflector scans logged).",
        unit="", choices=("site", "ideal"))
    paper_scans: bool = setting(
        False,
        "Log the NAV200's per-revolution reflector observations (/nav/reflectors) as the "
        "paper's experiment had them: no NAV200 host protocol delivers them, so a log with them "
        "is marked as the paper's setup; false: a NAV200 log carries poses only.",
        unit="")
    nav_device: str = setting(
        "nav200",
        "The laser device of the log: 'nav200' (serial, polled PP) or 'nav350' (SOPAS over "
        "Ethernet, pose and landmarks of every revolution; lgvtool.sim.nav350_simlink).",
        unit="", choices=("nav200", "nav350"))


@dataclass(frozen=True)
class McuSettings:
    """Encoders, gyro, drive unit and the MCU serial link."""

    period_s: float = setting(
        0.100,
        "Frame period of the MCU by its own clock, s.",
        unit="s", minimum=0.005, min_open=True)
    baud: int = setting(
        115_200,
        "Serial speed of the MCU link (8N1, 10 bits per byte), baud.",
        unit="baud", minimum=0, min_open=True, maximum=4_000_000)
    clock_drift_ppm: float = setting(
        25.0, "MCU crystal error: its clock runs fast by this much, parts per million.", unit="ppm")
    clock_offset_ms: int = setting(
        123_456, "MCU clock reading at simulation time 0, ms.", unit="ms", maximum=2**32 - 1)
    send_jitter_s: float = setting(
        0.0005,
        "Standard deviation of the MCU's send instant around its schedule, s.",
        unit="s", minimum=0.0)
    host_latency_s: float = setting(
        0.001,
        "Delay from the last byte on the wire to the host's read returning it (before jitter), s.",
        unit="s", minimum=0.0)
    host_jitter_s: float = setting(
        0.002, "Extra read delay, uniform in [0, host_jitter_s], s.", unit="s", minimum=0.0)
    split_probability: float = setting(
        0.3,
        "Probability that a frame reaches the host in two reads instead of one.",
        unit="", minimum=0.0, maximum=1.0)
    noise: bool = setting(
        True,
        "False turns off slip, gyro white noise and bias walk, steering and speed noise and the "
        "timing jitter (calibration errors and the constant gyro bias stay).",
        unit="")
    wheel_radius_error_left: float = setting(
        0.002,
        "True left wheel radius is nominal x (1 + this): a calibration error, dimensionless.",
        unit="")
    wheel_radius_error_right: float = setting(
        -0.0015, "True right wheel radius is nominal x (1 + this), dimensionless.", unit="")
    slip_sigma: float = setting(
        0.0015,
        "Wheel slip: random walk of the counted travel, m per sqrt(m) travelled.",
        unit="m/sqrt(m)", minimum=0.0)
    gyro_bias_dps: float = setting(
        0.05, "Constant gyro bias, deg/s.", unit="deg/s")
    gyro_bias_walk_dps: float = setting(
        0.002, "Gyro bias random walk, deg/s per sqrt(s).", unit="deg/s/sqrt(s)", minimum=0.0)
    gyro_noise_dps: float = setting(
        0.05,
        "White noise on each frame's gyro rate (mean over the frame period), deg/s: a rate noise "
        "density of 0.015 deg/s/sqrt(Hz), typical of a +-300 deg/s MEMS gyro, averaged over 0.1 s.",
        unit="deg/s", minimum=0.0)
    gyro_scale_error: float = setting(
        0.003, "Gyro scale factor error, dimensionless.", unit="")
    steering_noise_deg: float = setting(
        0.05, "Noise of the reported steering angle, deg.", unit="deg", minimum=0.0)
    speed_noise: float = setting(
        0.003, "Noise of the reported drive wheel speed, m/s.", unit="m/s", minimum=0.0)
    gyro_scale_udeg_s: int = setting(
        10_986,
        "Gyro quantisation step, micro-deg/s per count (360/32768 deg/s: +-360 deg/s in int16).",
        unit="udeg/s", minimum=1, maximum=0xFFFF)


@dataclass(frozen=True)
class NavSettings:
    """The NAV200: rotating head, reflector measurements, pose solver and serial link."""

    rotation_hz: float = setting(
        8.0,
        "Head revolutions per second relative to the vehicle, Hz.",
        unit="Hz", minimum=0.5, min_open=True, maximum=100.0)
    clockwise: bool = setting(
        False,
        "Direction of the head's rotation; false: counter-clockwise seen from above.",
        unit="")
    scan_start_deg: float = setting(
        90.0,
        "Head angle in the vehicle frame at which a revolution (scan) starts and the device closes "
        "its data set, deg (undocumented for the NAV200; see docs/simulator.md).",
        unit="deg")
    skew: bool = setting(
        True,
        "Each reflector is measured at its own instant of the revolution; false: all at once "
        "(mid-revolution), i.e. an ideal motion-compensated device.",
        unit="")
    range_min: float = setting(
        0.5, "Closest measurable reflector (centre), m.", unit="m", minimum=0.0, min_open=True)
    range_max: float = setting(
        28.0, "Farthest measurable reflector (centre), m.", unit="m", minimum=0.0, min_open=True)
    noise: bool = setting(
        True,
        "False turns off range and bearing noise, missed detections and the poll and read jitter.",
        unit="")
    sigma_range_mm: float = setting(
        12.0, "Range noise, standard deviation, mm.", unit="mm", minimum=0.0)
    sigma_bearing_deg: float = setting(
        0.05, "Bearing noise, standard deviation, deg.", unit="deg", minimum=0.0)
    detection_probability: float = setting(
        0.9,
        "Probability that a visible reflector is detected in a revolution (within "
        "detection_range_m; calibrated to the spread of the paper's Table 1).",
        unit="", minimum=0.0, maximum=1.0)
    sigma_range_per_m_mm: float = setting(
        1.0,
        "Growth of the range noise with range: its standard deviation is sigma_range_mm plus this "
        "times the range in m, mm per m (the echo weakens with range).",
        unit="mm/m", minimum=0.0)
    detection_range_m: float = setting(
        12.0,
        "Beyond this range the detection probability falls as (detection_range_m / range)^2 (echo "
        "energy of a reflector narrower than the beam), m; 0: no fall-off.",
        unit="m", minimum=0.0)
    reflector_radius_mm: float = setting(
        50.0,
        "Radius of the reflector cylinders, mm (the paper's 10 cm diameter): the head measures the "
        "surface it hits and adds this radius, so the apparent centre depends on which pulses hit.",
        unit="mm", minimum=0.0, maximum=1000.0, max_open=True)
    angle_step_deg: float = setting(
        0.1,
        "Angular step between the head's laser pulses, deg: the edges of each reflector's return "
        "fall on this grid (its phase random per revolution); 0: continuous bearings and ranges to "
        "the centre.",
        unit="deg", minimum=0.0, maximum=5.0)
    solver_sigma_range_mm: float = setting(
        12.0,
        "Range standard deviation the device assumes when weighting its fit, mm.",
        unit="mm", minimum=0.0, min_open=True)
    solver_sigma_bearing_deg: float = setting(
        0.04,
        "Bearing standard deviation the device assumes when weighting its fit, deg (calibrated to "
        "the bias of the paper's Table 1).",
        unit="deg", minimum=0.0, min_open=True)
    solver_iterations: int = setting(
        6, "Gauss-Newton iterations per revolution.", unit="", minimum=1, maximum=1000)
    gate: float = setting(
        0.4,
        "An observation is matched to the nearest stored reflector within this distance, m.",
        unit="m", minimum=0.0, min_open=True)
    min_reflectors: int = setting(
        3, "Fewest matched reflectors for a valid position.", unit="", minimum=2, maximum=64)
    max_reflectors: int = setting(
        6,
        "The device fits only this many nearest matched reflectors (NAV200 PC command); 0: all "
        "(calibrated to the spread of the paper's Table 1).",
        unit="", minimum=0, maximum=64)
    quality_rms_mm: float = setting(
        250.0,
        "Quality falls from 100 to 0 as the fit's RMS range residual grows to this, mm.",
        unit="mm", minimum=0.0, min_open=True)
    latency_s: float = setting(
        0.040,
        "Time from the end of a revolution until its pose can be reported, s.",
        unit="s", minimum=0.0)
    reply_delay_s: float = setting(
        0.005, "Time from the end of a request to the first reply byte, s.", unit="s", minimum=0.0)
    poll_period_s: float = setting(
        0.450, "Host poll period of the PP request, s.", unit="s", minimum=0.05, min_open=True)
    poll_start_s: float = setting(
        0.5, "Time of the first poll, s.", unit="s", minimum=0.0)
    poll_jitter_s: float = setting(
        0.002,
        "Host scheduling jitter of each poll, uniform in [0, poll_jitter_s], s.",
        unit="s", minimum=0.0)
    baud: int = setting(
        19_200,
        "Serial speed (8E1, 11 bits per byte), baud.",
        unit="baud", minimum=0, min_open=True, maximum=4_000_000)
    host_latency_s: float = setting(
        0.001,
        "Delay from the last byte on the wire to the host's read returning it (before jitter), s.",
        unit="s", minimum=0.0)
    host_jitter_s: float = setting(
        0.002, "Extra read delay, uniform in [0, host_jitter_s], s.", unit="s", minimum=0.0)
    split_probability: float = setting(
        0.3,
        "Probability that a reply reaches the host in two reads instead of one.",
        unit="", minimum=0.0, maximum=1.0)
    identification: str = setting(
        "device",
        "How reflectors are identified: 'device' (the device matches each observation to its "
        "stored layout from its own predicted pose, its last solution carried forward, and "
        "reports the layout id it matched, none where it matched nothing) or 'truth' (model "
        "1's kind world: matched from the true pose, every observation carrying its true id).",
        unit="", choices=("device", "truth"))


@dataclass(frozen=True)
class DriveSettings:
    """How the true path departs from the kinematic model the plan is made with (the drive
    commands stay as planned; what the vehicle does with them differs)."""

    steering_offset_deg: float = setting(
        -0.1,
        "True drive-wheel angle minus the angle the drive unit commands and reports (the zero "
        "error of its steering sensor, counter-clockwise), deg.",
        unit="deg", minimum=-5.0, maximum=5.0)
    wobble_deg: float = setting(
        0.07,
        "Steering wobble: the true wheel angle also wanders about the commanded one (the "
        "steering servo's and path controller's error), a random process of this standard "
        "deviation, deg.",
        unit="deg", minimum=0.0, maximum=5.0)
    wobble_time_s: float = setting(
        2.0,
        "Correlation time of the steering wobble (Ornstein-Uhlenbeck: the servo pulls the error "
        "back at this time constant), s.",
        unit="s", minimum=0.01, maximum=600.0)
    path_control_m: float = setting(
        1.0,
        "Path controller: it steers the vehicle back to its planned path, critically damped, "
        "over about this distance of travel (its gains in distance: the same path at any "
        "speed), m; 0: none, the steering angle is held as planned (the circle scenarios: the "
        "paper's experiment holds it at 60 deg).",
        unit="m", minimum=0.0, maximum=100.0)
    understeer_deg_per_g: float = setting(
        8.0,
        "Slip while turning: the drive wheel's slip angle, by which the vehicle turns less "
        "than its wheel angle says, per g of lateral acceleration (the understeer gradient), "
        "deg/g.",
        unit="deg/g", minimum=0.0, maximum=30.0)
    load_fraction: float = setting(
        0.5,
        "Load carried, as a fraction of the rated load (0: empty; the paper does not say), "
        "dimensionless.",
        unit="", minimum=0.0, maximum=1.0)
    radius_change_at_rated_load: float = setting(
        -0.006,
        "Relative change of the encoder (load) wheels' effective rolling radius at the rated "
        "load (tyre compression), proportional to the load: the true radius is the MCU's "
        "(mcu.wheel_radius_error_*) x (1 + load_fraction x this), dimensionless.",
        unit="", minimum=-0.05, maximum=0.05)
    dock_sigma_along_m: float = setting(
        0.010,
        "Docking controller: standard deviation of where the vehicle comes to rest at a "
        "station along its approach (O's stop minus the station's nominal one, forward), "
        "drawn per visit, m.",
        unit="m", minimum=0.0, maximum=0.05)
    dock_sigma_across_m: float = setting(
        0.008,
        "Docking controller: standard deviation of O's stop across the approach (to the "
        "left), drawn per visit, m.",
        unit="m", minimum=0.0, maximum=0.05)
    dock_sigma_heading_deg: float = setting(
        0.3,
        "Docking controller: standard deviation of the heading at rest minus the station's "
        "nominal heading (counter-clockwise), drawn per visit, deg.",
        unit="deg", minimum=0.0, maximum=2.0)
    dock_approach_m: float = setting(
        2.0,
        "Docking controller: drive-wheel travel over which the stop's error builds up on the "
        "final approach to a station, and dies away again after it drives off (at most the "
        "straight travel there), m.",
        unit="m", minimum=0.2, maximum=20.0)


MAX_MOVE_M = 5.0
"""Largest shift of a moved reflector per axis (``site.moved``), m: beyond it the reflector is
a different one (remove it and add one), not the same one moved."""


@dataclass(frozen=True)
class MovedReflector:
    """A reflector that stands elsewhere than the stored layout says (``[[simulator.site.moved]]``)."""

    id: int = setting(REQUIRED, "Layout id of the moved reflector.", unit="", minimum=0,
                      maximum=MAX_COUNT)
    dx: float = setting(0.0, "Where it really stands minus its layout position, x, m.", unit="m",
                        minimum=-MAX_MOVE_M, maximum=MAX_MOVE_M)
    dy: float = setting(0.0, "Where it really stands minus its layout position, y, m.", unit="m",
                        minimum=-MAX_MOVE_M, maximum=MAX_MOVE_M)


@dataclass(frozen=True)
class WeakReflector:
    """A dirty or damaged reflector (``[[simulator.site.weak]]``)."""

    id: int = setting(REQUIRED, "Layout id of the weak reflector.", unit="", minimum=0,
                      maximum=MAX_COUNT)
    detection: float = setting(
        REQUIRED, "Its detection probability per revolution (instead of "
        "nav.detection_probability; the fall-off with range still applies).",
        unit="", minimum=0.0, maximum=1.0)


EXTRA_DETECTION = 0.6
"""Default detection probability of a reflective object not in the layout (``site.extra``):
the old shiny object's (``faults.false_detection_probability``)."""


@dataclass(frozen=True)
class ExtraObject:
    """A reflective object not in the layout (``[[simulator.site.extra]]``): a shiny object
    the head takes for a reflector."""

    x: float = setting(REQUIRED, "Where it stands, x, m.", unit="m")
    y: float = setting(REQUIRED, "Where it stands, y, m.", unit="m")
    detection: float = setting(
        EXTRA_DETECTION, "Probability that the head sees it in a revolution (at any range, "
        "noise on or off).", unit="", minimum=0.0, maximum=1.0)


@dataclass(frozen=True)
class SiteSettings:
    """The site as it really is: where the reflectors stand against the stored layout, how
    each one answers, and the floor the vehicle drives on. The NAV and the estimators use the
    stored layout; the NAV model sees the true site."""

    survey_sigma_mm: float = setting(
        10.0,
        "Survey error of the stored layout, per reflector and axis, mm: the layout every "
        "consumer of the log gets; the reflectors really stand this far off it.",
        unit="mm", minimum=0.0, maximum=500.0)
    range_bias_sigma_mm: float = setting(
        5.0,
        "Each reflector's own constant range offset, standard deviation over the reflectors, "
        "mm (drawn once per run; tape against the cylinder, diameter tolerance, incidence): "
        "the head measures every range to it this much long or short.",
        unit="mm", minimum=0.0, maximum=100.0)
    floor_tilt_deg: float = setting(
        0.1,
        "Slope of the floor under the vehicle, standard deviation of each component, deg: the "
        "head (vehicle.nav_height above the floor) leans downhill by that height times the "
        "slope and its scan plane tilts (slant ranges, shifted bearings; docs/simulator.md).",
        unit="deg", minimum=0.0, maximum=5.0)
    floor_wavelength_m: float = setting(
        8.0,
        "Wavelength of the floor's undulation: its height is a sum of waves from half to twice "
        "this long, so the slope under the vehicle changes over a few metres of travel, m.",
        unit="m", minimum=2.0, maximum=1000.0)
    missing: tuple[int, ...] = setting(
        (),
        "Layout ids of reflectors removed or covered: the stored layout keeps them, the head "
        "never sees them.",
        unit="", minimum=0, maximum=MAX_COUNT, item=int)
    moved: tuple[MovedReflector, ...] = setting(
        (),
        "Reflectors that really stand at their layout position plus (dx, dy) m (instead of "
        "the survey error; each |dx|, |dy| at most 5 m): [[simulator.site.moved]] tables.",
        unit="", item=MovedReflector)
    weak: tuple[WeakReflector, ...] = setting(
        (),
        "Dirty or damaged reflectors, seen with their own detection probability (0..1) "
        "instead of nav.detection_probability: [[simulator.site.weak]] tables.",
        unit="", item=WeakReflector)
    extra: tuple[ExtraObject, ...] = setting(
        (),
        "Reflective objects not in the layout, at (x, y) m, each seen with its own detection "
        "probability (default 0.6) and identified by the device like any observation: "
        "[[simulator.site.extra]] tables.",
        unit="", item=ExtraObject)

    def faults(self) -> JSONObject:
        """The site faults as JSON (the ``simulator`` metadata's ``site_faults``); empty when
        there are none."""
        out: JSONObject = {}
        for name in ("missing", "moved", "weak", "extra"):
            value = getattr(self, name)
            if value:
                items: list[JSON] = [v if isinstance(v, int) else asdict(v) for v in value]
                out[name] = items
        return out


@dataclass(frozen=True)
class FaultSettings:
    """Faults injected on purpose (all off by default; the ``degraded`` scenario sets them)."""

    mcu_drop_rate: float = setting(
        0.0, "Fraction of MCU frames lost on the link.", unit="", minimum=0.0, maximum=1.0)
    mcu_corrupt_rate: float = setting(
        0.0,
        "Fraction of MCU frames with one bit flipped after the header (CRC fails).",
        unit="", minimum=0.0, maximum=1.0)
    nav_request_drop_rate: float = setting(
        0.0,
        "Fraction of PP requests that never reach the device (no reply).",
        unit="", minimum=0.0, maximum=1.0)
    nav_reply_drop_rate: float = setting(
        0.0, "Fraction of PP replies lost on the link.", unit="", minimum=0.0, maximum=1.0)
    nav_corrupt_rate: float = setting(
        0.0,
        "Fraction of PP replies with one bit flipped in the data (BCC fails).",
        unit="", minimum=0.0, maximum=1.0)
    nav_invalid_rate: float = setting(
        0.0,
        "Fraction of PP replies in which the device reports no valid position (quality 0xFF).",
        unit="", minimum=0.0, maximum=1.0)
    nav_error_rate: float = setting(
        0.0,
        "Fraction of PP polls the device answers with an error reply instead of a pose "
        "(function E; class 4 spurious measurement, group 7 positioning, detail 7 input not "
        "possible: which codes a NAV200 sends for a failed poll is not documented). Above 0 "
        "it draws its own random numbers first, so the other link faults fall elsewhere.",
        unit="", minimum=0.0, maximum=1.0)
    occlusion_fraction: float = setting(
        0.0,
        "Fraction of the time each reflector is hidden (pallets, people), dimensionless.",
        unit="", minimum=0.0, maximum=1.0, max_open=True)
    occlusion_mean_s: float = setting(
        6.0, "Mean length of one occlusion stretch, s.", unit="s", minimum=0.0, min_open=True)
    false_reflector: bool = setting(
        False,
        "Place a shiny object that the head takes for a reflector (the older form of one "
        "site.extra object, kept so that older logs' configurations stay valid).",
        unit="")
    false_x: float = setting(
        math.nan,
        "Position of the shiny object, m; NaN: beside the reflector ``false_near_id``.",
        unit="m")
    false_y: float = setting(
        math.nan,
        "Position of the shiny object, m; NaN: beside the reflector ``false_near_id``.",
        unit="m")
    false_near_id: int = setting(
        3,
        "Reflector beside which the shiny object stands (when false_x/false_y are NaN).",
        unit="", maximum=MAX_COUNT)
    false_offset: float = setting(
        0.3, "Distance of the shiny object from that reflector, along the wall, m.", unit="m")
    false_detection_probability: float = setting(
        0.6,
        "Probability that the head sees the shiny object in a revolution.",
        unit="", minimum=0.0, maximum=1.0)


WORLD_MODEL = 2
"""Version of the world model, recorded in every simulated log (``simulator`` metadata,
``world``): 1 was the kind world (a kinematic path, true reflector ids in every scan), which
``sim.world = "ideal"`` still gives; 2 added the ``drive`` and ``site`` sections and the
NAV's own reflector identification."""

IDEAL_WORLD: dict[str, object] = {
    "sim.paper_scans": True,
    "nav.identification": "truth",
    "site.range_bias_sigma_mm": 0.0,
    "site.floor_tilt_deg": 0.0,
    "drive.steering_offset_deg": 0.0,
    "drive.wobble_deg": 0.0,
    "drive.path_control_m": 0.0,
    "drive.understeer_deg_per_g": 0.0,
    "drive.load_fraction": 0.0,
    "drive.dock_sigma_along_m": 0.0,
    "drive.dock_sigma_across_m": 0.0,
    "drive.dock_sigma_heading_deg": 0.0,
    "scenario.overrun_deg": 0.0,
}
"""The settings of ``sim.world = "ideal"``: every mechanism of the ``drive`` and ``site``
sections off except the survey error (model 1 had it; the docking controller stops exactly
at each station's nominal pose), no planned turn past the last rotation
(a kinematic vehicle needs none; ``scenario.*`` keys apply to the scenarios that have them),
the NAV200's reflector scans logged, and
the reflectors identified from the true pose, with their true ids (``nav.identification``).
Applied before the scenario's presets, the configuration and ``--set``, which win over it."""

RENAMED: dict[str, str] = {"nav.map_sigma_mm": "site.survey_sigma_mm"}
"""Settings under their old names, as the logs of earlier versions store them -> their names
now (accepted everywhere, so an old log's stored configuration stays valid)."""

ONLY_WHEN_SET: dict[tuple[str, str], object] = {
    ("sim", "nav_device"): "nav200",
    ("site", "missing"): (), ("site", "moved"): (), ("site", "weak"): (), ("site", "extra"): (),
}
"""Settings recorded only when they differ from this default, so that the logs of runs made
before they existed are written again byte for byte."""


@dataclass(frozen=True)
class InstallSettings:
    """Installation errors the host does not know: the true vehicle differs from the configured
    (nominal) one by these amounts; the log's stored configuration keeps the nominal values.

    The true wheel radii and the gyro's scale factor and bias are the ``mcu.wheel_radius_error_*``,
    ``mcu.gyro_scale_error`` and ``mcu.gyro_bias_dps`` settings (see :data:`INSTALLATION`).
    """

    nav_dx_mm: float = setting(
        0.0,
        "True NAV head position minus the configured ``vehicle.nav_x`` (forward), mm.",
        unit="mm")
    nav_dy_mm: float = setting(
        0.0, "True NAV head position minus the configured ``vehicle.nav_y`` (left), mm.", unit="mm")
    nav_yaw_deg: float = setting(
        0.0,
        "True mounting yaw of the head minus the configured ``vehicle.nav_yaw`` "
        "(counter-clockwise), deg: the head measures its bearings from, and reports the heading "
        "of, its own x axis.",
        unit="deg")
    track_error_mm: float = setting(
        0.0,
        "True track between the encoder wheels minus the configured ``vehicle.track``, mm.",
        unit="mm")
    nav_time_offset_ms: float = setting(
        0.0,
        "Constant NAV-to-host time offset: every NAV200 reply reaches the host, and every scan is "
        "stamped on the host's clock, this much later than it happened, ms (may be negative).",
        unit="ms")


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


def setting_value(settings: SimSettings, key: str) -> object:
    """The value of a ``section.name`` setting."""
    section, _, name = key.partition(".")
    return getattr(getattr(settings, section), name)


SECTIONS: dict[str, type] = {
    "sim": RunSettings,
    "mcu": McuSettings,
    "nav": NavSettings,
    "drive": DriveSettings,
    "site": SiteSettings,
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
    drive: DriveSettings = field(default_factory=DriveSettings)
    site: SiteSettings = field(default_factory=SiteSettings)
    faults: FaultSettings = field(default_factory=FaultSettings)
    install: InstallSettings = field(default_factory=InstallSettings)
    scenario: Mapping[str, object] = field(default_factory=dict)
    """Parameters of the scenario (validated by the scenario)."""

    def to_dict(self, installation: bool = True) -> JSONObject:
        """Every setting as a nested JSON-able dict (NaN written as None); the settings of
        :data:`ONLY_WHEN_SET` only when they differ from their default. The ``install``
        section only when ``installation`` and some installation error is set (a log's stored
        configuration leaves it out: the host does not know it)."""
        out: JSONObject = {}
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


def _jsonable(v: object) -> JSON:
    """A setting's value as JSON: a float that is not finite as None, a tuple as a list, a
    table's values in turn; a number, a string, a boolean or None as it is.

    :raises TypeError: a value that no setting holds (a date, an object).
    """
    if isinstance(v, float) and not math.isfinite(v):
        return None
    if isinstance(v, tuple | list):
        return [_jsonable(x) for x in v]
    if isinstance(v, dict):
        return {k: _jsonable(x) for k, x in v.items()}
    if v is None or isinstance(v, str | int | float):
        return v
    raise TypeError(f"a setting's value of type {type(v).__name__} has no JSON form")


def apply_overrides(settings: SimSettings, overrides: Mapping[str, object]) -> SimSettings:
    """Apply ``{"section.key": value}`` overrides (``scenario.*`` unchecked here), each checked
    by its declaration (:mod:`lgvtool.declared`), then the rules between settings.

    Raises ConfigError for an unknown section or key or a value of the wrong type or range.
    """
    grouped: dict[str, dict[str, object]] = {}
    scenario = dict(settings.scenario)
    for full_key, value in overrides.items():
        full_key = RENAMED.get(full_key, full_key)
        section, _, key = full_key.partition(".")
        if not key:
            raise ConfigError(f"setting '{full_key}' must be section.key "
                              f"(sections: {', '.join([*SECTIONS, 'scenario', 'vehicle'])})")
        if section == "scenario":
            scenario[key] = value
            continue
        if section not in SECTIONS:
            raise ConfigError(f"unknown setting section '{section}' in '{full_key}'"
                              + unknown_tail(section, [*SECTIONS, "scenario", "vehicle"],
                                             label="sections"))
        grouped.setdefault(section, {})[key] = value
    out = replace(settings, scenario=scenario)
    for section, values in grouped.items():
        group = make(SECTIONS[section], section, values, base=getattr(out, section),
                     what="setting",
                     more="{n} settings in " + section + "; lgvtool config --parameters lists them")
        out = replace(out, **{section: group})
    return validate(out)


def flatten(table: Mapping[str, object], prefix: str = "") -> dict[str, object]:
    """Flatten a nested table (e.g. a TOML ``[simulator]`` section) to ``section.key`` keys."""
    out: dict[str, object] = {}
    for k, v in table.items():
        key = f"{prefix}{k}"
        if isinstance(v, Mapping):
            out.update(flatten(v, key + "."))
        else:
            out[key] = v
    return out


def validate(s: SimSettings) -> SimSettings:
    """Check the rules between settings (each setting's own range is in its declaration);
    raise ConfigError naming the first broken one."""
    checks: list[tuple[bool, str]] = [
        (s.sim.truth_rate_hz <= s.sim.rate_hz, "sim.truth_rate_hz must be at most sim.rate_hz"),
        (s.nav.range_min < s.nav.range_max, "nav.range_min must be below nav.range_max"),
        (s.nav.max_reflectors == 0 or s.nav.max_reflectors >= s.nav.min_reflectors,
         "nav.max_reflectors must be 0 (all) or at least nav.min_reflectors"),
    ]
    for name, ids in (("missing", list(s.site.missing)),
                      ("moved", [m.id for m in s.site.moved]),
                      ("weak", [w.id for w in s.site.weak])):
        twice = sorted({i for i in ids if ids.count(i) > 1})
        checks.append((not twice, f"site.{name} lists reflector {twice[0] if twice else 0} "
                                  "more than once"))
    for ok, message in checks:
        if not ok:
            raise ConfigError(message)
    return s
