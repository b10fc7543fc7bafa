"""The bad-input catalogue: every command fed wrong options, wrong numbers, wrong files and
outputs that are inputs.

Each case runs ``lgvtool.cli.main`` in this process and must end cleanly: exit 2 with exactly
one line on stderr (``lgvtool: error: ...``), or, for a case marked ``ok``, a success (exit 0).
Every file of the shared inputs (the log, the configurations, the dataset folder, the
baseline) and any existing output of the case must keep its bytes.
"""

from __future__ import annotations

import hashlib
import json
import math
import os
from dataclasses import MISSING, dataclass, fields
from pathlib import Path
from typing import Any

import pytest

from lgvtool.cli import main

ERROR, OK, CLEAN = "error", "ok", "clean"
"""Expected outcomes: exit 2 and one line; exit 0; either of the two."""


@dataclass(frozen=True)
class Case:
    """One catalogue entry: the arguments (``{w}``: the shared inputs, ``{out}``: this case's
    own folder, ``{existing}``: a file there that already exists) and the expected outcome."""

    id: str
    args: tuple[str, ...]
    expect: str = ERROR
    needle: str = ""


def _case(cid: str, *args: str, expect: str = ERROR, needle: str = "") -> Case:
    return Case(cid, tuple(args), expect, needle)


# --------------------------------------------------------------------------- the shared inputs

CONFIGS: dict[str, str] = {
    "good": "[vehicle]\nh = 1.2\n",
    "unknown_section": "[bogus]\nx = 1\n",
    "unknown_vehicle_key": "[vehicle]\nwheelbase = 1\n",
    "vehicle_h_nan": "[vehicle]\nh = nan\n",
    "vehicle_h_inf": "[vehicle]\nh = inf\n",
    "vehicle_h_negative": "[vehicle]\nh = -1.0\n",
    "vehicle_h_string": "[vehicle]\nh = \"tall\"\n",
    "vehicle_h_huge": "[vehicle]\nh = 1e300\n",
    "vehicle_ppr_float": "[vehicle]\nencoder_ppr = 10.5\n",
    "vehicle_ppr_huge": "[vehicle]\nencoder_ppr = 1000000000000\n",
    "vehicle_not_table": "vehicle = 3\n",
    "area_inverted": "[area]\nx_min = 10.0\nx_max = 0.0\n",
    "area_nan": "[area]\nx_max = nan\n",
    "reference_90": "[reference]\nsteering_angle_deg = 90.0\n",
    "reference_nan": "[reference]\nsteering_angle_deg = nan\n",
    "reflector_duplicate": "[[reflectors]]\nid = 1\nx = 0.0\ny = 0.0\n[[reflectors]]\nid = 1\nx = 1.0\n"
                           "y = 1.0\n",
    "reflector_missing_x": "[[reflectors]]\nid = 1\ny = 0.0\n",
    "reflector_radius_negative": "[[reflectors]]\nid = 1\nx = 0.0\ny = 0.0\nradius = -1.0\n",
    "reflector_x_inf": "[[reflectors]]\nid = 1\nx = inf\ny = 0.0\n",
    "reflector_id_huge": "[[reflectors]]\nid = 100000000000\nx = 0.0\ny = 0.0\n",
    "reflectors_not_array": "reflectors = 3\n",
    "malformed": "[vehicle\nh = 1\n",
    "estimators_bogus": "[estimators.bogus]\nx = 1\n",
    "estimators_not_table": "estimators = 3\n",
    "pf_particles_negative": "[estimators.pf]\nparticles = -5\n",
    "pf_particles_nan": "[estimators.pf]\nparticles = nan\n",
    "pf_particles_huge": "[estimators.pf]\nparticles = 1000000000000\n",
    "pf_sigma_string": "[estimators.pf]\nsigma_range_m = \"wide\"\n",
    "pf_unknown_param": "[estimators.pf]\nbogus = 1\n",
    "simulator_unknown_key": "[simulator]\nfoo = 1\n",
    "simulator_unknown_section": "[simulator.bogus]\nx = 1\n",
    "simulator_latency_nan": "[simulator.nav]\nlatency_s = nan\n",
    "simulator_rate_huge": "[simulator.sim]\nrate_hz = 1e12\n",
    "simulator_scenario_bogus": "[simulator.scenario]\nbogus = 1\n",
    "ekf_skew_sigma_negative": "[estimators.ekf]\npose_skew_sigma_m = -1.0\n",
    "pf_pose_latency_negative": "[estimators.pf]\npose_latency_s = -0.2\n",
    "pf_paper_pose_latency_absurd": "[estimators.pf-paper]\npose_latency_s = 1000.0\n",
    "ekf_sigma_pose_zero": "[estimators.ekf]\nsigma_pose_xy_m = 0.0\n",
    "simulator_scenario_nan": "[simulator.scenario]\nspeed = nan\n",
    "simulator_vehicle_negative": "[simulator.vehicle]\nh = -1.0\n",
}


def _write_foreign(path: Path) -> None:
    """A ROS 2 style MCAP file (CDR messages, a topic name with a terminal escape)."""
    from mcap.writer import Writer

    with path.open("wb") as f:
        w = Writer(f)
        w.start(profile="ros2", library="rosbag2_test")
        sid = w.register_schema(name="nav_msgs/msg/Odometry", encoding="ros2msg", data=b"int32 x")
        cid = w.register_channel(topic="/odom\x1b]0;retitled\x07", message_encoding="cdr",
                                 schema_id=sid)
        for i in range(4):
            w.add_message(cid, log_time=i * 10**9, publish_time=i * 10**9, data=b"\0\1\0\0")
        w.finish()


#: logs whose messages break the contract in one field: name -> (topic, change of the decoded
#: message of the topic's first message, or of every one with ``all``)
BAD_MESSAGES: dict[str, tuple[str, Any, bool]] = {
    "truth_huge": ("/truth/pose", lambda d: d["pose"]["position"].update(x=1e308), False),
    "nav_valid_string": ("/nav/pose", lambda d: d.update(valid="false"), True),
    "nav_huge": ("/nav/pose", lambda d: d.update(x=1e308), True),
    "map_not_list": ("/map/reflectors", lambda d: d.update(reflectors="none"), True),
    "map_huge": ("/map/reflectors", lambda d: d["reflectors"][0].update(x=1e308), True),
    "map_duplicate_id": ("/map/reflectors",
                         lambda d: d["reflectors"][1].update(id=d["reflectors"][0]["id"]), True),
    "mcu_seq_huge": ("/mcu/frame", lambda d: d.update(seq=2**80), False),
    "scan_range_huge": ("/nav/reflectors", lambda d: d["observations"][0].update(range=1e308),
                        False),
    "nav_no_stamp": ("/nav/pose", lambda d: d.pop("timestamp"), True),
    "nav_zero_stamp": ("/nav/pose", lambda d: d.update(timestamp={"sec": 0, "nsec": 0}), False),
}


def _write_changed(src: Path, dst: Path, topic: str, change: Any, every: bool) -> None:
    """``src`` rewritten by the ``mcap`` package with ``change`` applied to the decoded JSON of
    ``topic``'s first message (or of every one)."""
    from mcap.reader import make_reader
    from mcap.writer import Writer

    with src.open("rb") as f, dst.open("wb") as g:
        reader, w = make_reader(f), Writer(g)
        w.start(profile="", library="catalogue")
        schemas: dict[int, int] = {}
        channels: dict[int, int] = {}
        done = False
        for schema, channel, message in reader.iter_messages(log_time_order=False):
            if channel.id not in channels:
                if schema is not None and schema.id not in schemas:
                    schemas[schema.id] = w.register_schema(schema.name, schema.encoding,
                                                           schema.data)
                channels[channel.id] = w.register_channel(
                    channel.topic, channel.message_encoding,
                    schemas[schema.id] if schema is not None else 0, channel.metadata)
            data = message.data
            if channel.topic == topic and (every or not done):
                doc = json.loads(data)
                change(doc)
                data, done = json.dumps(doc).encode(), True
            w.add_message(channels[channel.id], message.log_time, data, message.publish_time)
        for record in reader.iter_metadata():
            w.add_metadata(record.name, record.metadata)
        w.finish()


def _run(argv: list[str], capsys: pytest.CaptureFixture[str]) -> tuple[int, str, str]:
    capsys.readouterr()
    try:
        main(argv)
        code = 0
    except SystemExit as exc:
        code = exc.code if isinstance(exc.code, int) else (0 if exc.code is None else 1)
    out, err = capsys.readouterr()
    return code, out, err


@pytest.fixture(scope="module")
def world(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The shared inputs: a short simulated log, configurations, files that are not logs, a
    dataset folder, links to the log and an evaluation folder whose table1.json is a baseline."""
    w = tmp_path_factory.mktemp("catalogue")
    # in the paper's setup: the log carries reflector scans, as the sample logs do
    for argv in (["simulate", "-s", "paper-circle", "--duration", "12", "--set",
                  "sim.paper_scans=true", "-o", str(w / "log.mcap")],
                 ["evaluate", str(w / "log.mcap"), "-e", "laser", "-o", str(w / "rep")]):
        try:
            main(argv)
        except SystemExit as exc:
            assert not exc.code, argv
    for name, text in CONFIGS.items():
        (w / f"{name}.toml").write_text(text, encoding="utf-8")
    _write_foreign(w / "foreign.mcap")
    (w / "text.txt").write_text("not a log\n", encoding="utf-8")
    (w / "layout.imk").write_text("globID x_mm y_mm type subtype size_mm layer\n"
                                  "1 0 0 1 1 80 0\n2 5000 0 1 1 80 0\n3 0 5000 1 1 80 0\n",
                                  encoding="utf-8")
    (w / "bad.imk").write_text("1 2 3\n", encoding="utf-8")
    (w / "empty.mcap").write_bytes(b"")
    data = (w / "log.mcap").read_bytes()
    (w / "truncated.mcap").write_bytes(data[: len(data) // 3])
    (w / "cut20.mcap").write_bytes(data[:20])
    os.mkfifo(w / "fifo.mcap")  # read, it would block
    for name, (topic, change, every) in BAD_MESSAGES.items():
        _write_changed(w / "log.mcap", w / f"{name}.mcap", topic, change, every)
    (w / "binary.toml").write_bytes(bytes(range(256)))
    (w / "folder").mkdir()
    (w / "link.mcap").symlink_to(w / "log.mcap")
    os.link(w / "log.mcap", w / "hard.mcap")
    (w / "clink.toml").symlink_to(w / "good.toml")
    ds = w / "ds"
    ds.mkdir()
    for name in ("Barcodes.dat", "Landmark_Groundtruth.dat", "Robot1_Odometry.dat",
                 "Robot1_Measurement.dat", "Robot1_Groundtruth.dat"):
        (ds / name).write_text("# empty\n", encoding="utf-8")
    os.link(ds / "Robot1_Odometry.dat", w / "odometry_link.dat")
    return w


def _snapshot(root: Path) -> dict[str, tuple[int, int, str]]:
    """Size, modification time and (below 1 MB) sha256 of every regular file below ``root``
    (links not followed)."""
    out: dict[str, tuple[int, int, str]] = {}
    for p in sorted(root.rglob("*")):
        if p.is_file() and not p.is_symlink():
            st = p.stat()
            digest = hashlib.sha256(p.read_bytes()).hexdigest() if st.st_size < 10**6 else ""
            out[str(p.relative_to(root))] = (st.st_size, st.st_mtime_ns, digest)
    return out


# --------------------------------------------------------------------------- the cases

BAD_FLOATS = ("nan", "inf", "-inf", "abc")
SIM_OUT = ("-o", "{out}/sim.mcap")


def _sim_setting_cases() -> list[Case]:
    """Every simulator setting given a value of the wrong kind through ``simulate --set``."""
    from lgvtool.sim.settings import SECTIONS

    cases: list[Case] = []
    for section, cls in SECTIONS.items():
        for f in fields(cls):
            key = f"{section}.{f.name}"
            default = f.default
            if isinstance(default, bool):
                bad: tuple[str, ...] = ("maybe", "2")
            elif isinstance(default, int):
                bad = ("1.5", "1e30", "nan", "abc")
            elif isinstance(default, float) and math.isnan(default):
                bad = ("inf", "abc")
            else:
                bad = BAD_FLOATS
            for value in bad:
                cases.append(_case(f"simulate-set-{key}={value}", "simulate", "-s", "paper-circle",
                                   "--set", f"{key}={value}", *SIM_OUT))
    return cases


def _estimator_param_cases() -> list[Case]:
    """Every estimator parameter given a value of the wrong kind in a configuration file
    (``lgvtool config``), and a share of them through ``replay --set`` and ``evaluate --set``."""
    from lgvtool.localize.registry import ESTIMATORS

    cases: list[Case] = []
    for name in ESTIMATORS:
        for f in fields(ESTIMATORS[name].Params):
            default = f.default if f.default is not MISSING else None
            if isinstance(default, bool):
                bad: tuple[str, ...] = ('"maybe"', "2")
            elif isinstance(default, int):
                bad = ("1e30", "1.5", "nan")
            elif isinstance(default, float):
                bad = ("nan", "-inf" if math.isinf(default) else "inf", '"abc"')
            else:
                bad = ('"no-such-choice"',) if f.metadata.get("choices") else ()
            for k, value in enumerate(bad):
                cases.append(_case(f"config-{name}.{f.name}={value}", "config",
                                   f"@[estimators.{name}]\n{f.name} = {value}\n"))
                if k == 0:
                    plain = value.strip('"')
                    command = "replay" if len(cases) % 2 else "evaluate"
                    target = ("-o", "{out}/r.mcap") if command == "replay" else ()
                    cases.append(_case(f"{command}-set-{name}.{f.name}={plain}", command,
                                       "{w}/log.mcap", "-e", name, "--set",
                                       f"{name}.{f.name}={plain}", *target))
    return cases


def _option_cases() -> list[Case]:
    """Every numeric option of every command given values it must refuse."""
    nav = ("--nav", "tcp://127.0.0.1:1", "-o", "{out}/rec.mcap", "--no-status")
    table: list[tuple[str, tuple[str, ...], str, tuple[str, ...]]] = [
        ("simulate", ("-s", "paper-circle", *SIM_OUT), "--duration",
         ("nan", "inf", "-1", "0", "1e12", "abc")),
        ("simulate", ("-s", "paper-circle", *SIM_OUT), "--seed", ("-1", "1.5", "abc", "1e30")),
        ("replay", ("{w}/log.mcap", "-o", "{out}/r.mcap"), "--particles",
         ("0", "-1", "1e12", "nan", "abc")),
        ("replay", ("{w}/log.mcap", "-o", "{out}/r.mcap"), "--cloud-period",
         ("nan", "inf", "-1")),
        ("replay", ("{w}/log.mcap", "-o", "{out}/r.mcap"), "--cloud-size", ("-1", "1e12", "nan")),
        ("replay", ("{w}/log.mcap", "-o", "{out}/r.mcap"), "--seed", ("-1", "abc")),
        ("record", nav, "--duration", ("nan", "inf", "0", "-1", "1e12")),
        ("record", nav, "--poll-period", ("nan", "inf", "0", "-0.1")),
        ("record", nav, "--reply-timeout", ("nan", "inf", "0")),
        ("record", nav, "--split-size", ("nan", "inf", "0", "1e12")),
        ("record", nav, "--split-duration", ("nan", "inf", "0")),
        ("record", nav, "--sliding-mean", ("0", "256", "abc")),
        ("record", nav, "--nearest", ("0", "1000")),
        ("record", nav, "--layer", ("-1", "256")),
        ("simulate serve", ("--nav", "none"), "--duration", ("nan", "inf", "0")),
        ("simulate serve", ("--nav", "none"), "--speed", ("0", "nan", "inf", "1e9")),
        ("simulate serve", ("--nav", "none"), "--exit-after", ("nan", "inf", "-1")),
        ("simulate serve", ("--nav", "none"), "--seed", ("-1", "abc")),
        ("sweep", ("{w}/log.mcap", "-o", "{out}/sw"), "--seeds", ("0", "1e12", "nan")),
        ("sweep", ("{w}/log.mcap", "-o", "{out}/sw"), "--workers", ("0", "100000", "nan")),
        ("evaluate", ("{w}/log.mcap",), "--seed", ("-1", "abc")),
        ("evaluate", ("{w}/log.mcap",), "--workers", ("0", "1000000")),
        ("evaluate", ("{w}/log.mcap",), "--threads", ("0", "-1", "1e12", "abc")),
        ("replay", ("{w}/log.mcap", "-o", "{out}/r.mcap"), "--threads", ("0", "1e12", "abc")),
        ("export", ("{w}/log.mcap", "-o", "{out}/ex"), "--threads", ("0", "-1", "1e12", "abc")),
        ("import mrclam", ("{w}/ds", "-o", "{out}/m.mcap", "--robot", "1"), "--gap-threshold",
         ("0", "nan", "inf")),
        ("import mrclam", ("{w}/ds", "-o", "{out}/m.mcap", "--robot", "1"), "--landmark-radius",
         ("nan", "-1")),
        ("import mrclam", ("{w}/ds", "-o", "{out}/m.mcap", "--robot", "1"), "--area-margin",
         ("inf", "-1")),
        ("import mrclam", ("{w}/ds", "-o", "{out}/m.mcap", "--robot", "1"), "--odometry-delay",
         ("nan", "soon", "-1", "6")),
        ("import mrclam", ("{w}/ds", "-o", "{out}/m.mcap"), "--robot", ("0", "-1", "abc", "1e9")),
    ]
    cases = []
    for command, base, option, values in table:
        for v in values:
            cases.append(_case(f"{command.replace(' ', '-')}{option}={v}", *command.split(),
                               *base, option, v))
    cases.append(_case("record--action-radii-nan", "record", *nav, "--action-radii", "nan", "1"))
    cases.append(_case("record--action-radii-inverted", "record", *nav, "--action-radii", "2",
                       "1"))
    return cases


def _fault_cases() -> list[Case]:
    specs = ("drop:mcu:nan:1", "drop:mcu:1:nan", "drop:mcu:inf:1", "drop:mcu:1:inf",
             "garbage:mcu:1:1000000000000", "garbage:mcu:1:0", "garbage:mcu:1:nan",
             "reset:mcu:1", "reset:nav200:nan", "bogus:mcu:1:1", "drop:xyz:1:1", "drop:mcu:1",
             "drop:mcu:-1:1", "drop:mcu:abc:1", "silent:all:1:1e300", "", "drop")
    return [_case(f"serve--fault={s}", "simulate", "serve", "--nav", "none", "--fault", s)
            for s in specs]


def _serve_cases() -> list[Case]:
    base = ("simulate", "serve", "--duration", "10")
    return [
        _case("serve-port-99999", *base, "--nav", "tcp://127.0.0.1:99999", "--mcu", "none"),
        _case("serve-port-negative", *base, "--nav", "tcp://127.0.0.1:-1", "--mcu", "none"),
        _case("serve-port-word", *base, "--nav", "tcp://127.0.0.1:http", "--mcu", "none"),
        _case("serve-unresolvable-host", *base, "--nav", "tcp://no-such-host.invalid:5000",
              "--mcu", "none"),
        _case("serve-one-port-for-both", *base, "--nav", "tcp://127.0.0.1:45991", "--mcu",
              "tcp://127.0.0.1:45991"),
        _case("serve-serial-dev-null", *base, "--nav", "serial:///dev/null", "--mcu", "none"),
        _case("serve-pty-dir-unwritable", *base, "--pty-dir", "/proc", "--mcu", "none"),
        _case("serve-nothing-served", *base, "--nav", "none", "--mcu", "none"),
        _case("serve-log-and-scenario", "simulate", "serve", "{w}/log.mcap", "-s", "paper-circle"),
        _case("serve-transcript-is-log", "simulate", "serve", "{w}/log.mcap", "--transcript",
              "{w}/log.mcap", needle="is the input"),
        _case("serve-transcript-is-log-link", "simulate", "serve", "{w}/log.mcap", "--transcript",
              "{w}/hard.mcap", "--force", needle="is the input"),
        _case("serve-transcript-is-config", "simulate", "serve", "--config", "{w}/good.toml",
              "--transcript", "{w}/good.toml", needle="is the input"),
        _case("serve-transcript-exists", "simulate", "serve", "--transcript", "{existing}",
              needle="--force"),
        _case("serve-foreign-log", "simulate", "serve", "{w}/foreign.mcap"),
        _case("serve-bad-config", "simulate", "serve", "--config", "{w}/estimators_bogus.toml"),
    ]


def _record_cases() -> list[Case]:
    out = ("-o", "{out}/rec.mcap", "--no-status", "--duration", "20")
    return [
        _case("record-mcu-regular-file", "record", "--mcu", "serial://{w}/text.txt", *out,
              needle="not a character device"),
        _case("record-mcu-dev-null", "record", "--mcu", "serial:///dev/null", *out,
              needle="not a terminal"),
        _case("record-mcu-directory", "record", "--mcu", "serial://{w}/folder", *out),
        _case("record-nav-no-such-host", "record", "--nav", "tcp://no-such-host.invalid:4001",
              *out, needle="resolve"),
        _case("record-no-device", "record", *out),
        _case("record-two-nav-units", "record", "--nav", "tcp://127.0.0.1:1", "--nav350",
              "tcp://127.0.0.1:2", *out, needle="would both write /nav/pose"),
        _case("record-bad-url", "record", "--nav", "ftp://x", *out),
        _case("record-port-too-big", "record", "--nav", "tcp://127.0.0.1:99999", *out),
        _case("record-speed-input-without-mcu", "record", "--nav", "tcp://127.0.0.1:1",
              "--speed-input", *out),
        _case("record-write-layout-missing", "record", "--nav350", "tcp://127.0.0.1:1",
              "--write-layout", "{w}/no-such-layout.toml", *out, needle="cannot read"),
        _case("record-write-layout-not-a-layout", "record", "--nav350", "tcp://127.0.0.1:1",
              "--write-layout", "{w}/good.toml", *out, needle="no [[reflectors]]"),
        _case("record-map-at-on-a-nav200", "record", "--nav", "tcp://127.0.0.1:1",
              "--map-at", "0,0,0", *out, needle="for the NAV350"),
        _case("record-map-at-two-numbers", "record", "--nav350", "tcp://127.0.0.1:1",
              "--map-at", "1,2", *out, needle="X,Y,DEG"),
        _case("record-map-at-nan", "record", "--nav350", "tcp://127.0.0.1:1",
              "--map-at", "1,2,nan", *out, needle="--map-at"),
        _case("record-map-layout-without-map-at", "record", "--nav350", "tcp://127.0.0.1:1",
              "--map-layout", "{out}/site.toml", *out, needle="--map-at"),
        _case("record-map-layout-is-the-output", "record", "--nav350", "tcp://127.0.0.1:1",
              "--map-at", "0,0,0", "--map-layout", "{out}/rec.mcap", *out,
              needle="is the input"),
        _case("layout-convert-missing", "layout", "convert", "{w}/no-such-layout.imk", "-o",
              "{out}/l.toml", needle="cannot read"),
        _case("layout-convert-bad-imk", "layout", "convert", "{w}/bad.imk", "-o",
              "{out}/l.toml", needle="line 1"),
        _case("layout-convert-onto-itself", "layout", "convert", "{w}/layout.imk", "-o",
              "{w}/layout.imk", needle="is the input"),
        _case("layout-convert-empty-layer", "layout", "convert", "{w}/layout.imk", "-o",
              "{out}/l.toml", "--layer", "7", needle="no reflector in layer 7"),
        _case("record-config-as-output", "record", "--nav", "tcp://127.0.0.1:1", "--config",
              "{w}/good.toml", "-o", "{w}/good.toml", "--force", needle="is the input"),
        _case("record-config-link-as-output", "record", "--nav", "tcp://127.0.0.1:1",
              "--config", "{w}/good.toml", "-o", "{w}/clink.toml", "--force",
              needle="is the input"),
        _case("record-existing-output", "record", "--nav", "tcp://127.0.0.1:1", "-o",
              "{existing}", needle="--force"),
        *[_case(f"record-config-{name}", "record", "--nav", "tcp://127.0.0.1:1", "--config",
                f"{{w}}/{name}.toml", *out)
          for name in ("estimators_bogus", "pf_particles_negative", "pf_particles_nan",
                       "pf_particles_huge", "pf_sigma_string", "simulator_unknown_key")],
    ]


#: (command, arguments before the output, arguments after it, the inputs it reads)
WRITERS: list[tuple[str, tuple[str, ...], tuple[str, ...]]] = [
    ("simulate", ("simulate", "-s", "paper-circle", "--config", "{w}/good.toml", "--duration",
                  "10", "-o"), ()),
    ("replay", ("replay", "{w}/log.mcap", "--config", "{w}/good.toml", "-e", "laser", "-o"), ()),
    ("decode", ("decode", "{w}/log.mcap", "-o"), ()),
    ("recover", ("recover", "{w}/log.mcap", "-o"), ()),
    ("calibrate", ("calibrate", "{w}/log.mcap", "--config", "{w}/good.toml", "-o"), ()),
    ("layout-refine", ("layout", "refine", "{w}/log.mcap", "--config", "{w}/good.toml", "-o"),
     ()),
]


def _output_cases() -> list[Case]:
    """Outputs that are inputs, through every path to them, for every command that writes."""
    cases: list[Case] = []
    targets = {"log": "{w}/log.mcap", "symlink": "{w}/link.mcap", "hardlink": "{w}/hard.mcap",
               "config": "{w}/good.toml", "config-symlink": "{w}/clink.toml"}
    for name, before, after in WRITERS:
        for what, target in targets.items():
            if name in ("decode", "recover") and what.startswith("config"):
                continue  # not an input of theirs
            if name == "simulate" and not what.startswith("config"):
                continue  # the log is no input of simulate
            for force in ((), ("--force",)):
                cases.append(_case(f"{name}-output-is-{what}{'-force' if force else ''}",
                                   *before, target, *after, *force, needle="is the input"))
        cases.append(_case(f"{name}-existing-output", *before, "{existing}", *after,
                           needle="--force"))
        cases.append(_case(f"{name}-output-is-folder", *before, "{w}/folder", "--force"))
        cases.append(_case(f"{name}-output-in-missing-folder", *before, "{out}/no/such/x.mcap"))
    cases += [
        _case("import-output-in-dataset", "import", "mrclam", "{w}/ds", "--robot", "1", "-o",
              "{w}/ds/Robot1_Odometry.dat", "--force", needle="input"),
        _case("import-output-new-in-dataset", "import", "mrclam", "{w}/ds", "--robot", "1", "-o",
              "{w}/ds/robot1.mcap", needle="inside the input"),
        _case("import-output-hardlink-of-dataset-file", "import", "mrclam", "{w}/ds", "--robot",
              "1", "-o", "{w}/odometry_link.dat", "--force", needle="input"),
        _case("import-all-into-dataset", "import", "mrclam", "{w}/ds", "--all", "-o", "{w}/ds",
              needle="input"),
        _case("import-robot-and-all", "import", "mrclam", "{w}/ds", "--all", "--robot", "1", "-o",
              "{out}/x"),
        _case("import-neither", "import", "mrclam", "{w}/ds", "-o", "{out}/x.mcap"),
        _case("import-existing-output", "import", "mrclam", "{w}/ds", "--robot", "1", "-o",
              "{existing}", needle="--force"),
        _case("import-not-a-dataset", "import", "mrclam", "{w}/folder", "--robot", "1", "-o",
              "{out}/x.mcap"),
        _case("evaluate-baseline-in-output", "evaluate", "{w}/log.mcap", "-e", "laser",
              "--baseline", "{w}/rep/table1.json", "-o", "{w}/rep", needle="is the input"),
        _case("evaluate-baseline-in-output-force", "evaluate", "{w}/log.mcap", "-e", "laser",
              "--baseline", "{w}/rep/table1.json", "-o", "{w}/rep", "--force",
              needle="is the input"),
        _case("evaluate-output-exists", "evaluate", "{w}/log.mcap", "-e", "laser", "-o",
              "{w}/rep", needle="--force"),
        _case("evaluate-output-is-log", "evaluate", "{w}/log.mcap", "-o", "{w}/log.mcap"),
        _case("sweep-output-is-log", "sweep", "{w}/log.mcap", "-o", "{w}/log.mcap"),
        _case("sweep-output-inside-input-folder", "sweep", "{w}", "-o", "{w}/sw", needle="input"),
        _case("sweep-output-has-results", "sweep", "{w}/log.mcap", "-o", "{w}/rep",
              needle="--force"),
        _case("export-output-is-log", "export", "{w}/log.mcap", "-e", "laser", "-o",
              "{w}/log.mcap"),
        _case("export-output-inside-input-folder", "export", "{w}/rep/table1.json", "-o",
              "{w}/rep"),
        _case("import-ros2-output-is-input", "import", "ros2", "{w}/foreign.mcap", "-o",
              "{w}/foreign.mcap", "--force", needle="input"),
        _case("import-ros2-output-in-bag-folder", "import", "ros2", "{w}/folder", "-o",
              "{w}/folder/out.mcap"),
        _case("import-ros2-existing-output", "import", "ros2", "{w}/foreign.mcap", "-o",
              "{existing}"),
        _case("import-ros2-unknown-role", "import", "ros2", "{w}/foreign.mcap", "--topic",
              "bogus=/x", "-o", "{out}/b.mcap"),
        _case("calibrate-unknown-quantity", "calibrate", "{w}/log.mcap", "--estimate", "bogus",
              "-o", "{out}/v.toml"),
        _case("calibrate-short-straight-drive", "calibrate", "{w}/log.mcap", "-o",
              "{out}/v.toml"),
        _case("view-bad-address", "view", "{w}/log.mcap", "--live", "no.such.host.invalid:1"),
        _case("view-bad-port", "view", "{w}/log.mcap", "--live", "127.0.0.1:99999"),
        _case("view-speed-nan", "view", "{w}/log.mcap", "--speed", "nan"),
        _case("record-live-bad-port", "record", "--mcu", "tcp://127.0.0.1:9", "--live",
              "127.0.0.1:99999", "-o", "{out}/r.mcap"),
    ]
    return cases


def _message_cases() -> list[Case]:
    """Logs whose messages break the contract (a position of 1e308 m, a flag that is a
    string, a map that is no list, an integer too large for 64 bits): one line naming the
    topic, never a hang or an internal error; a NAV pose of 1e308 m is not valid (like a
    NaN one) and the run goes on."""
    commands = {
        "replay": ("replay", "{file}", "-o", "{out}/r.mcap", "-e", "laser,ekf"),
        "replay-pf-paper": ("replay", "{file}", "-o", "{out}/r.mcap", "-e", "pf-paper",
                            "--no-view"),
        "evaluate": ("evaluate", "{file}", "-e", "ekf"),
        "export": ("export", "{file}", "-o", "{out}/ex", "-e", "laser"),
        "view": ("view", "{file}", "--live", "127.0.0.1:0", "--speed", "0", "--no-progress"),
    }
    needles = {"truth_huge": "/truth/pose", "nav_valid_string": "/nav/pose",
               "map_not_list": "/map/reflectors", "map_huge": "/map/reflectors",
               "map_duplicate_id": "duplicate id",
               "mcu_seq_huge": "/mcu/frame", "scan_range_huge": "/nav/reflectors",
               "nav_no_stamp": "/nav/pose", "nav_zero_stamp": "/nav/pose"}
    cases = []
    for name in BAD_MESSAGES:
        for command, args in commands.items():
            full = tuple(a.replace("{file}", f"{{w}}/{name}.mcap") for a in args)
            if name == "nav_huge":
                expect, needle = (ERROR, "laser has no usable") if command in (
                    "replay", "export") else (OK, "")
            elif command == "view":  # plays the messages as they are, draws what it can
                expect, needle = CLEAN, ""
            elif name == "truth_huge" and command == "replay-pf-paper":
                expect, needle = OK, ""  # no truth is read without the view
            elif name == "scan_range_huge" and command == "export":
                expect, needle = OK, ""  # laser: the scans are not read
            else:
                expect, needle = ERROR, needles[name]
            cases.append(_case(f"{command}-{name}", *full, expect=expect, needle=needle))
    cases.append(_case("info-cut20", "info", "{w}/cut20.mcap", needle="not a readable MCAP"))
    cases.append(_case("config-map_not_list", "config", "{w}/map_not_list.mcap",
                       needle="/map/reflectors"))
    return cases


def _file_cases() -> list[Case]:
    """Files that are not lgvtool logs, given to every command that reads a log."""
    readers = {
        "info": ("info",),
        "replay": ("replay", "{file}", "-o", "{out}/r.mcap"),
        "evaluate": ("evaluate", "{file}"),
        "decode": ("decode", "{file}", "-o", "{out}/d.mcap"),
        "recover": ("recover", "{file}", "-o", "{out}/v.mcap"),
        "serve": ("simulate", "serve", "{file}", "--nav", "none"),
        "sweep": ("sweep", "{file}", "-o", "{out}/sw"),
        "export": ("export", "{file}", "-o", "{out}/ex"),
        "calibrate": ("calibrate", "{file}", "-o", "{out}/v.toml"),
        "layout-refine": ("layout", "refine", "{file}", "-o", "{out}/l.toml"),
        "view": ("view", "{file}", "--live", "127.0.0.1:0", "--speed", "0"),
        "import-ros2": ("import", "ros2", "{file}", "-o", "{out}/b.mcap"),
    }
    #: a sweep reports a bad log and goes on, a server would serve a salvaged one: not here
    skip = {"sweep": ("empty", "text", "config", "truncated", "foreign"), "serve": ("truncated",),
            "view": ("truncated",)}
    files = {"missing": ("{w}/no-such.mcap", ERROR), "folder": ("{w}/folder", ERROR),
             "empty": ("{w}/empty.mcap", ERROR), "text": ("{w}/text.txt", ERROR),
             "config": ("{w}/good.toml", ERROR), "truncated": ("{w}/truncated.mcap", CLEAN),
             "foreign": ("{w}/foreign.mcap", ERROR), "fifo": ("{w}/fifo.mcap", ERROR)}
    cases = []
    for command, args in readers.items():
        for what, (path, expect) in files.items():
            if what in skip.get(command, ()):
                continue
            if command == "info" and what == "foreign":
                expect = OK
            full = (*args, path) if command == "info" else tuple(a.replace("{file}", path)
                                                                 for a in args)
            cases.append(_case(f"{command}-{what}", *full, expect=expect))
    return cases


def _config_cases() -> list[Case]:
    cases = [_case(f"config-file-{name}", "config", f"{{w}}/{name}.toml",
                   expect=OK if name == "good" else ERROR) for name in CONFIGS]
    cases += [_case("config-binary", "config", "{w}/binary.toml"),
              _case("config-missing", "config", "{w}/no-such.toml"),
              _case("config-folder", "config", "{w}/folder"),
              _case("config-json", "config", "--json", "{w}/good.toml", expect=OK)]
    for name in ("estimators_bogus", "pf_particles_negative", "simulator_unknown_key",
                 "vehicle_h_nan"):
        for command in (("simulate", "-s", "paper-circle", *SIM_OUT),
                        ("replay", "{w}/log.mcap", "-o", "{out}/r.mcap"),
                        ("evaluate", "{w}/log.mcap"),
                        ("sweep", "{w}/log.mcap", "-o", "{out}/sw")):
            cases.append(_case(f"{command[0]}-config-{name}", *command, "--config",
                               f"{{w}}/{name}.toml"))
    return cases


def _grammar_cases() -> list[Case]:
    log = "{w}/log.mcap"
    return [
        *[_case(f"{cmd}-empty-estimator-name-{k}", *args, "-e", value, needle="empty name")
          for cmd, args in (("replay", ("replay", log, "-o", "{out}/r.mcap")),
                            ("evaluate", ("evaluate", log)),
                            ("export", ("export", log, "-o", "{out}/ex")))
          for k, value in enumerate(("", ",", "laser,,ekf", " "))],
        _case("calibrate-empty-estimate", "calibrate", log, "-o", "{out}/v.toml", "--estimate",
              "", needle="--estimate"),
        _case("calibrate-empty-compare", "calibrate", log, "-o", "{out}/v.toml", "--compare",
              "laser,", needle="--compare"),
        _case("evaluate-json-and-format-csv", "evaluate", log, "--json", "--format", "csv"),
        _case("evaluate-json-and-format-md", "evaluate", log, "--json", "--format", "md"),
        _case("evaluate-png-without-output", "evaluate", log, "--png"),
        _case("evaluate-workers-and-scheduler", "evaluate", log, "--workers", "2", "--scheduler",
              "tls://127.0.0.1:1"),
        _case("evaluate-bad-tolerance", "evaluate", log, "--tolerance", "abc"),
        _case("evaluate-bad-max", "evaluate", log, "--max", "pf.circle.rmse_mm"),
        _case("evaluate-bad-min", "evaluate", log, "--min", "x=abc"),
        _case("evaluate-baseline-missing", "evaluate", log, "--baseline", "{w}/no.json"),
        _case("evaluate-baseline-not-json", "evaluate", log, "--baseline", "{w}/text.txt"),
        _case("evaluate-unknown-estimator", "evaluate", log, "-e", "laser,bogus"),
        _case("evaluate-set-unknown", "evaluate", log, "-e", "pf", "--set", "pf.bogus=1"),
        _case("evaluate-set-no-equals", "evaluate", log, "--set", "pf.particles"),
        _case("replay-unknown-estimator", "replay", log, "-o", "{out}/r.mcap", "-e", "bogus"),
        _case("replay-empty-estimator-list", "replay", log, "-o", "{out}/r.mcap", "-e",
              "laser,,bogus"),
        _case("replay-set-unknown-estimator", "replay", log, "-o", "{out}/r.mcap", "--set",
              "bogus.x=1"),
        _case("replay-particles-without-pf", "replay", log, "-o", "{out}/r.mcap", "-e", "laser",
              "--particles", "100"),
        _case("replay-bad-compression", "replay", log, "-o", "{out}/r.mcap", "--compression",
              "gzip"),
        _case("simulate-list-with-output", "simulate", "--list", "-o", "{out}/x.mcap"),
        _case("simulate-list-with-scenario", "simulate", "--list", "-s", "paper-circle"),
        _case("simulate-no-scenario", "simulate", *SIM_OUT),
        _case("simulate-no-output", "simulate", "-s", "paper-circle"),
        _case("simulate-unknown-scenario", "simulate", "-s", "bogus", *SIM_OUT),
        _case("simulate-set-no-section", "simulate", "-s", "paper-circle", "--set", "rate=1",
              *SIM_OUT),
        _case("simulate-set-unknown-section", "simulate", "-s", "paper-circle", "--set",
              "bogus.x=1", *SIM_OUT),
        _case("simulate-set-unknown-key", "simulate", "-s", "paper-circle", "--set",
              "nav.bogus=1", *SIM_OUT),
        _case("simulate-set-rotations-huge", "simulate", "-s", "paper-circle", "--set",
              "scenario.rotations=1e12", *SIM_OUT),
        _case("simulate-set-scenario-unknown", "simulate", "-s", "paper-circle", "--set",
              "scenario.bogus=1", *SIM_OUT),
        _case("simulate-set-scenario-nan", "simulate", "-s", "paper-circle", "--set",
              "scenario.speed=nan", *SIM_OUT),
        _case("simulate-set-laps-huge", "simulate", "-s", "warehouse", "--set",
              "scenario.laps=1e9", *SIM_OUT),
        _case("simulate-set-vehicle-nan", "simulate", "-s", "paper-circle", "--set",
              "vehicle.h=nan", *SIM_OUT),
        _case("simulate-rate-times-duration", "simulate", "-s", "paper-circle", "--set",
              "sim.rate_hz=10000", "--duration", "80000", *SIM_OUT),
        _case("sweep-workers-and-scheduler", "sweep", log, "-o", "{out}/sw", "--workers", "2",
              "--scheduler", "tls://127.0.0.1:1"),
        _case("sweep-scheduler-bad-scheme", "sweep", log, "-o", "{out}/sw", "--scheduler",
              "ftp://127.0.0.1:1"),
        _case("sweep-scheduler-no-port", "sweep", log, "-o", "{out}/sw", "--scheduler",
              "tcp://127.0.0.1"),
        _case("sweep-tls-without-ca", "sweep", log, "-o", "{out}/sw", "--scheduler",
              "tls://127.0.0.1:1"),
        _case("sweep-tls-options-on-tcp", "sweep", log, "-o", "{out}/sw", "--scheduler",
              "tcp://127.0.0.1:1", "--tls-ca-file", "{w}/good.toml"),
        _case("sweep-tls-option-without-scheduler", "sweep", log, "-o", "{out}/sw",
              "--tls-cert", "{w}/good.toml"),
        _case("sweep-tls-key-without-cert", "sweep", log, "-o", "{out}/sw", "--scheduler",
              "tls://127.0.0.1:1", "--tls-ca-file", "{w}/good.toml", "--tls-key",
              "{w}/good.toml"),
        _case("evaluate-tls-without-ca", "evaluate", log, "--scheduler", "tls://127.0.0.1:1"),
        *[_case(f"sweep-grid-{g}", "sweep", log, "-o", "{out}/sw", "--grid", g)
          for g in ("pf.particles=nan", "pf.particles=1e30", "pf.particles=0", "pf.bogus=1,2",
                    "bogus.x=1", "pf.particles=", "noequals", "pf.particles=100,100",
                    "pf.sigma_range_m=inf", "pf.resample=bogus")],
        _case("sweep-grid-twice", "sweep", log, "-o", "{out}/sw", "--grid", "pf.particles=1,2",
              "--grid", "pf.particles=3"),
        _case("sweep-set-for-estimator-not-run", "sweep", log, "-o", "{out}/sw", "-e", "laser",
              "--set", "pf.particles=100"),
        _case("unknown-command", "bogus"),
        _case("unknown-option", "info", "--bogus", log),
        _case("completion-unknown-shell", "completion", "tcsh"),
        *[_case(f"completion-{shell}", "completion", shell, expect=OK)
          for shell in ("bash", "zsh", "fish")],
        _case("info-log", "info", log, expect=OK),
        _case("info-json", "info", "--json", log, expect=OK),
        _case("simulate-list", "simulate", "--list", expect=OK),
        _case("replay-comma-and-repeated-estimators", "replay", log, "-o", "{out}/r.mcap", "-e",
              "laser,deadreckoning", "-e", "laser", expect=OK),
        _case("replay-force-replaces", "replay", log, "-o", "{existing}", "-e", "laser",
              "--force", expect=OK),
    ]


def _pose_model_cases() -> list[Case]:
    """A pose-model parameter out of its range (a negative skew spread, a negative or absurd
    pose age, a noise of 0) through ``--set`` of replay and evaluate and a configuration of
    calibrate, and calibrate of a log whose NAV poses carry no time stamp (or a zero one):
    one line naming the parameter or the channel."""
    cases = [
        _case("replay-set-ekf.pose_skew_sigma_m=-1", "replay", "{w}/log.mcap", "-e", "ekf",
              "--set", "ekf.pose_skew_sigma_m=-1", "-o", "{out}/r.mcap",
              needle="pose_skew_sigma_m must be at least 0"),
        _case("evaluate-set-pf.pose_latency_s=-0.1", "evaluate", "{w}/log.mcap", "-e", "pf",
              "--set", "pf.pose_latency_s=-0.1", needle="pose_latency_s must be at least 0"),
        _case("evaluate-set-ekf.pose_latency_s=1e6", "evaluate", "{w}/log.mcap", "-e", "ekf",
              "--set", "ekf.pose_latency_s=1e6", needle="pose_latency_s must be at most"),
        _case("replay-set-pf-paper.sigma_pose_heading_rad=0", "replay", "{w}/log.mcap", "-e",
              "pf-paper", "--set", "pf-paper.sigma_pose_heading_rad=0", "-o", "{out}/r.mcap",
              needle="sigma_pose_heading_rad must be at least"),
        _case("evaluate-set-ekf.pose_period_s=0", "evaluate", "{w}/log.mcap", "-e", "ekf",
              "--set", "ekf.pose_period_s=0", needle="pose_period_s must be at least"),
    ]
    for name, needle in (("ekf_skew_sigma_negative", "pose_skew_sigma_m"),
                         ("pf_pose_latency_negative", "pose_latency_s"),
                         ("pf_paper_pose_latency_absurd", "pose_latency_s"),
                         ("ekf_sigma_pose_zero", "sigma_pose_xy_m")):
        cases.append(_case(f"calibrate-config-{name}", "calibrate", "{w}/log.mcap", "-o",
                           "{out}/v.toml", "--config", f"{{w}}/{name}.toml", needle=needle))
    for name in ("nav_no_stamp", "nav_zero_stamp"):
        cases.append(_case(f"calibrate-{name}", "calibrate", f"{{w}}/{name}.mcap", "-o",
                           "{out}/v.toml", needle="/nav/pose"))
    return cases


CASES: list[Case] = [*_sim_setting_cases(), *_estimator_param_cases(), *_option_cases(),
                     *_fault_cases(), *_serve_cases(), *_record_cases(), *_output_cases(),
                     *_file_cases(), *_message_cases(), *_config_cases(), *_grammar_cases(),
                     *_pose_model_cases()]


def test_the_catalogue_is_large_and_its_ids_unique() -> None:
    ids = [c.id for c in CASES]
    assert len(ids) == len(set(ids)), [i for i in ids if ids.count(i) > 1]
    assert len(CASES) >= 450


@pytest.mark.parametrize("case", CASES, ids=[c.id for c in CASES])
def test_bad_input_is_refused_cleanly(case: Case, world: Path, tmp_path: Path,
                                      capsys: pytest.CaptureFixture[str]) -> None:
    existing = tmp_path / "existing.mcap"
    existing.write_bytes(b"an earlier output\n")
    argv: list[str] = []
    for a in case.args:
        if a.startswith("@"):  # an inline configuration file
            cfg = tmp_path / "inline.toml"
            cfg.write_text(a[1:], encoding="utf-8")
            a = str(cfg)
        argv.append(a.format(w=world, out=tmp_path, existing=existing))
    before, own = _snapshot(world), existing.read_bytes()
    code, _, err = _run(argv, capsys)
    lines = err.splitlines()
    if case.expect == OK or (case.expect == CLEAN and code == 0):
        assert code == 0, err
    else:
        assert code == 2, f"exit {code}: {err}"
        # one error line, last; only warnings about the input (a salvaged log) may precede it
        assert lines and lines[-1].startswith("lgvtool: error: "), err
        assert all(line.startswith("lgvtool: warning: ") for line in lines[:-1]), err
        assert "\x1b" not in err
        assert case.needle in err
    assert _snapshot(world) == before, "an input changed"
    if case.id != "replay-force-replaces":
        assert existing.read_bytes() == own, "an existing output changed"
    assert not list(tmp_path.glob(".*.part")), "a temporary file was left behind"


# --------------------------------------------------------------------------- beyond exit codes


def test_json_errors_are_a_json_object_on_stdout(world: Path,
                                                 capsys: pytest.CaptureFixture[str]) -> None:
    code, out, err = _run(["info", "--json", str(world / "no-such.mcap")], capsys)
    assert code == 2 and err.startswith("lgvtool: error: ")
    doc = json.loads(out)
    assert doc["exit_code"] == 2 and "no-such.mcap" in doc["error"]
    code, out, _ = _run(["evaluate", str(world / "log.mcap"), "--json", "--format", "csv"],
                        capsys)
    assert code == 2 and "--format csv" in json.loads(out)["error"]


def test_info_describes_a_foreign_mcap_and_strips_escapes(world: Path,
                                                          capsys: pytest.CaptureFixture[str]
                                                          ) -> None:
    code, out, _ = _run(["info", str(world / "foreign.mcap")], capsys)
    assert code == 0
    assert "not an lgvtool log" in out
    assert "nav_msgs/msg/Odometry" in out and "ros2msg" in out and "cdr" in out
    assert "\x1b" not in out and "\x07" not in out
    code, out, _ = _run(["info", "--json", str(world / "foreign.mcap")], capsys)
    doc = json.loads(out)
    assert doc["lgvtool_log"] is False and doc["message_count"] == 4
    (topic,) = doc["topics"].values()
    assert topic == {**topic, "schema": "nav_msgs/msg/Odometry", "schema_encoding": "ros2msg",
                     "message_encoding": "cdr", "count": 4}


def test_a_failed_write_leaves_the_old_output(world: Path, tmp_path: Path,
                                              monkeypatch: pytest.MonkeyPatch,
                                              capsys: pytest.CaptureFixture[str]) -> None:
    """decode, recover, replay and simulate write through a temporary file: a run that fails
    half way leaves an existing output as it was and no temporary file."""
    import lgvtool.app.decode_job as decode_mod
    import lgvtool.log.salvage as salvage_mod
    from lgvtool.errors import InputError

    def half_then_fail(*args: Any, **kw: Any) -> Any:
        Path(args[1]).write_bytes(b"half a log")  # every writer's second argument: the output
        raise InputError("disk trouble")

    import lgvtool.app.replay_job as replay_mod
    import lgvtool.sim.logfile as logfile_mod

    old = tmp_path / "out.mcap"
    old.write_bytes(b"the old output")
    log = str(world / "log.mcap")
    for module, name, argv in (
            (decode_mod, "decode_log", ["decode", log]),
            (salvage_mod, "recover", ["recover", log]),
            (replay_mod, "write_replay_log", ["replay", log, "-e", "laser"]),
            (logfile_mod, "write_log", ["simulate", "-s", "paper-circle", "--duration", "10"])):
        monkeypatch.setattr(module, name, half_then_fail)
        code, _, err = _run([*argv, "-o", str(old), "--force"], capsys)
        assert code == 2 and "disk trouble" in err
        assert old.read_bytes() == b"the old output"
        assert not list(tmp_path.glob(".*.part"))


def test_record_stops_at_once_on_a_permanent_device_error(world: Path, tmp_path: Path,
                                                          capsys: pytest.CaptureFixture[str]
                                                          ) -> None:
    """A regular file as serial port is not retried until --duration ends."""
    import time

    t0 = time.monotonic()
    code, _, err = _run(["record", "--mcu", f"serial://{world / 'text.txt'}", "-o",
                         str(tmp_path / "r.mcap"), "--duration", "60", "--no-status"], capsys)
    assert code == 2 and "not a character device" in err
    assert time.monotonic() - t0 < 30  # far from the 60 s it would have retried


def test_tcp_scheduler_on_another_machine_warns(capsys: pytest.CaptureFixture[str]) -> None:
    from lgvtool.fleet.connect import scheduler_spec

    assert scheduler_spec("tcp://127.0.0.1:8786") is not None
    assert capsys.readouterr().err == ""
    spec = scheduler_spec("tcp://10.0.0.5:8786")
    assert spec is not None and not spec.tls
    assert "neither encrypted nor authenticated" in capsys.readouterr().err


def test_without_the_fleet_extra(world: Path, monkeypatch: pytest.MonkeyPatch,
                                 capsys: pytest.CaptureFixture[str]) -> None:
    """sweep and evaluate --workers name the extra in one line; evaluate of several logs runs
    them one after the other."""
    import importlib.util

    from lgvtool.extras import install_hint

    real = importlib.util.find_spec

    def find_spec(name: str, *args: Any, **kw: Any) -> Any:
        return None if name in ("dask", "distributed", "pyarrow") else real(name, *args, **kw)

    monkeypatch.setattr(importlib.util, "find_spec", find_spec)
    log = str(world / "log.mcap")
    for argv in (["sweep", log, "-o", str(world / "never")],
                 ["evaluate", log, "--workers", "2"],
                 ["evaluate", log, "--scheduler", "tls://127.0.0.1:1"]):
        code, _, err = _run(argv, capsys)
        assert code == 2 and install_hint("fleet") in err and err.count("\n") == 1
    code, out, err = _run(["evaluate", log, log, "-e", "laser", "--json"], capsys)
    assert code == 0, err
    assert json.loads(out)["format"]
