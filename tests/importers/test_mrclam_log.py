"""The conversion to a log: channels, counts, units, time order, schemas, metadata."""

from __future__ import annotations

import hashlib
import json
from collections.abc import Callable
from pathlib import Path
from typing import Any

import jsonschema
import pytest

from lgvtool.errors import InputError
from lgvtool.importers.mrclam import CITATION
from lgvtool.importers.mrclam_log import import_all, import_robot
from lgvtool.json_types import member
from lgvtool.log import LogReader, topics
from lgvtool.log.messages import pose_in_frame, yaw_from_quaternion
from lgvtool.log.schemas import schema_json
from lgvtool.timestamps import from_stamp

NS = 1_000_000_000


def check_log(path: Path) -> dict[str, int]:
    """Every message valid against its schema, log times non-decreasing and equal to the
    message's own stamp; returns the message count per topic."""
    reader = LogReader(path)
    checkers: dict[str, Any] = {}
    counts: dict[str, int] = {}
    last = 0
    for m in reader.raw_messages():
        data = json.loads(m.data)
        if m.schema not in checkers:
            checkers[m.schema] = jsonschema.Draft202012Validator(schema_json(m.schema))
        checkers[m.schema].validate(data)
        assert m.log_time_ns >= last
        last = m.log_time_ns
        if "timestamp" in data:
            assert from_stamp(data["timestamp"]) == m.log_time_ns, m.topic
        counts[m.topic] = counts.get(m.topic, 0) + 1
    return counts


def test_synthetic_log_channels_and_counts(synthetic: Any, tmp_path: Path) -> None:
    out = tmp_path / "robot1.mcap"
    summary = import_robot(synthetic.root, 1, out)
    exp = synthetic.expected
    counts = check_log(out)
    n_kinds = len(synthetic.kinds)
    assert counts == {
        topics.ODOM: exp["odometry"], topics.TRUTH: exp["truth"],
        topics.NAV_REFLECTORS: exp["scans"], topics.MAP: 1, topics.MAP_SCENE: 1,
        topics.DIAGNOSTICS: n_kinds, topics.DIAGNOSTICS_LOG: n_kinds,
    }
    assert summary.messages == sum(counts.values())
    assert summary.counts == {**summary.counts, **exp}
    assert {q["kind"] for q in summary.quirks} == synthetic.kinds


def test_synthetic_log_content_and_units(synthetic: Any, tmp_path: Path) -> None:
    out = tmp_path / "robot1.mcap"
    import_robot(synthetic.root, 1, out)
    reader = LogReader(out)
    odo = reader.dataframe(topics.ODOM)
    assert odo["v"].iloc[0] == 0.1 and odo["omega"].iloc[0] == 0.0       # m/s, rad/s as given
    assert odo["t"].iloc[0] == pytest.approx(synthetic.t0 + 0.5)
    scans = reader.dataframe(topics.NAV_REFLECTORS)
    assert len(scans) == synthetic.expected["landmark_observations"]
    assert (scans["scan_period"] == 0).all() and (scans["time_in_scan"] == 0).all()
    assert set(scans["id"]) <= set(synthetic.landmarks)
    first = scans[scans["t"] == scans["t"].iloc[0]]
    assert first["id"].tolist() == [6, 7]                                 # file order in a scan
    truth = next(reader.messages([topics.TRUTH]))
    x, y, th = 1.0, 0.5, 0.0
    assert truth.data == pose_in_frame(truth.log_time_ns, x, y, th)
    diags = [m.data for m in reader.messages([topics.DIAGNOSTICS])]
    assert {d["source"] for d in diags} == {"importer"}
    assert {d["kind"]: d["count"] for d in diags}["robot_sighting"] == 2
    assert [r.id for r in reader.reflector_map()] == [6, 7, 8]


def test_truth_poses_match_the_file(synthetic: Any, tmp_path: Path) -> None:
    out = tmp_path / "robot1.mcap"
    import_robot(synthetic.root, 1, out)
    truth = LogReader(out).dataframe(topics.TRUTH)
    rows = [ln.split() for ln in (synthetic.root / "Robot1_Groundtruth.dat").read_text()
            .splitlines() if not ln.startswith("#")]
    assert len(truth) == len(rows)
    for (t, x, y, th), (_, row) in zip(rows, truth.iterrows(), strict=True):
        assert row["t"] == pytest.approx(float(t), abs=1e-6)
        assert (row["x"], row["y"]) == (float(x), float(y))
        assert row["heading"] == pytest.approx(float(th), abs=1e-12)


def test_metadata_provenance_citation_and_config(synthetic: Any, tmp_path: Path) -> None:
    out = tmp_path / "robot1.mcap"
    import_robot(synthetic.root, 1, out)
    reader = LogReader(out)
    rec = reader.metadata["importer"]
    assert rec["importer"] == "mrclam" and rec["robot"] == 1
    assert rec["citation"] == CITATION
    assert "Leung" in rec["citation"] and "969-974" in rec["citation"]
    names = ["Barcodes.dat", "Landmark_Groundtruth.dat", "Robot1_Odometry.dat",
             "Robot1_Measurement.dat", "Robot1_Groundtruth.dat"]
    assert sorted(rec["files"]) == sorted(names)
    for name in names:
        digest = hashlib.sha256((synthetic.root / name).read_bytes()).hexdigest()
        assert rec["files"][name] == digest
    assert rec["counts"]["broken_rows"] == 2
    assert rec["quirks"]["odometry_gap"] == 1
    assert rec["camera"]["fov_rad"] > 0 and rec["camera"]["range_max_m"] > 0
    assert rec["settings"]["landmark_radius_m"] == 0.05
    assert reader.metadata["lgvtool"]["source"] == "import mrclam"
    cfg = reader.config()
    assert (cfg.vehicle.nav_x, cfg.vehicle.nav_y) == (0.0, 0.0)
    margin = rec["settings"]["area_margin_m"]
    assert cfg.area.x_min == pytest.approx(-margin) and cfg.area.y_max == pytest.approx(3 + margin)
    assert [(r.id, r.x, r.y, r.radius) for r in cfg.reflectors] == [
        (s, x, y, 0.05) for s, (x, y) in sorted(synthetic.landmarks.items())]


def test_bad_output_paths_leave_no_file(synthetic: Any, tmp_path: Path) -> None:
    with pytest.raises(InputError, match="does not exist"):
        import_robot(synthetic.root, 1, tmp_path / "absent" / "out.mcap")
    with pytest.raises(InputError, match="is a folder"):
        import_robot(synthetic.root, 1, tmp_path)
    with pytest.raises(InputError, match="robot 3: not in"):
        import_robot(synthetic.root, 3, tmp_path / "r3.mcap")
    assert not list(tmp_path.glob("*.mcap*"))


def test_the_import_writes_a_temporary_file_of_its_own(synthetic: Any, tmp_path: Path) -> None:
    """Two imports to one output (two benchmarks sharing a cache) must not write one file: a
    file named like a fixed temporary name beside the output is neither used nor removed, and
    no temporary file is left."""
    folder = tmp_path / "out"
    folder.mkdir()
    out = folder / "r1.mcap"
    bystander = folder / "r1.mcap.part"
    bystander.write_bytes(b"another import's bytes")
    import_robot(synthetic.root, 1, out)
    assert bystander.read_bytes() == b"another import's bytes"
    assert sorted(p.name for p in folder.iterdir()) == ["r1.mcap", "r1.mcap.part"]
    check_log(out)


def test_import_all_writes_one_log_per_complete_robot(synthetic: Any, tmp_path: Path) -> None:
    summaries = import_all(synthetic.root, tmp_path / "logs")
    assert [s.robot for s in summaries] == [1]
    assert sorted(p.name for p in (tmp_path / "logs").iterdir()) == ["robot1.mcap"]
    (tmp_path / "file").write_text("x")
    with pytest.raises(InputError, match="is a file"):
        import_all(synthetic.root, tmp_path / "file")


@pytest.mark.mrclam
def test_excerpt_log_counts_units_and_order(excerpt: Callable[..., Path], tmp_path: Path) -> None:
    root = excerpt(4, odometry=3000, measurement=300, truth=2000)
    out = tmp_path / "robot4.mcap"
    summary = import_robot(root, 4, out)
    counts = check_log(out)
    c = summary.counts
    assert counts[topics.ODOM] == c["odometry"] and counts[topics.TRUTH] == 2000
    assert counts[topics.NAV_REFLECTORS] == c["scans"]
    assert counts[topics.DIAGNOSTICS] == len(summary.quirks)
    reader = LogReader(out)
    first_odo = next(ln.split() for ln in (root / "Robot4_Odometry.dat").read_text()
                     .splitlines() if not ln.startswith("#"))
    msg = next(reader.messages([topics.ODOM]))
    assert msg.log_time_ns == round(float(first_odo[0]) * 1e3) * 1_000_000   # s -> ns
    assert (msg.data["v"], msg.data["omega"]) == (float(first_odo[1]), float(first_odo[2]))
    scans = reader.dataframe(topics.NAV_REFLECTORS)
    assert scans["id"].between(6, 20).all()
    assert len(scans) == c["landmark_observations"]
    # the pre-encoded ground truth equals what the message builder makes, heading included
    rows = [ln.split() for ln in (root / "Robot4_Groundtruth.dat").read_text().splitlines()
            if not ln.startswith("#")]
    for (t, x, y, th), m in zip(rows[:200], reader.messages([topics.TRUTH]), strict=False):
        want = pose_in_frame(round(float(t) * 1e3) * 1_000_000, float(x), float(y), float(th))
        got = m.data
        assert got["timestamp"] == want["timestamp"] and got["frame_id"] == "map"
        assert got["pose"]["position"] == member(want["pose"], "position")
        q = got["pose"]["orientation"]
        assert q == pytest.approx(member(want["pose"], "orientation"), abs=1e-15)
        assert yaw_from_quaternion(q) == pytest.approx(float(th), abs=1e-12)
    assert reader.metadata["importer"]["dataset"] == "UTIAS MRCLAM Dataset 6"
