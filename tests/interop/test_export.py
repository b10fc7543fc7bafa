"""``lgvtool export``: the files of every format, the overwrite policy, and evo's APE on the
exported TUM files against lgvtool's true position RMSE."""

from __future__ import annotations

import math
import sys
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from lgvtool.app.evaluate_job import evaluate_log
from lgvtool.errors import InputError
from lgvtool.interop import trajfile
from lgvtool.interop.trajectory_export import export_log
from lgvtool.trajectory import Trajectory

FAST = ["laser", "ekf"]

CLI = Callable[..., tuple[int, str, str]]


@pytest.fixture(scope="module")
def exported(sim_log: Path, tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("tum")
    export_log(sim_log, out, "tum", estimators=FAST)
    return out


def test_export_writes_estimators_nav_truth_and_resampled_truth(exported: Path) -> None:
    names = sorted(p.name for p in exported.iterdir())
    assert names == sorted(["laser.tum", "ekf.tum", "nav.tum", "truth.tum", "truth-at-laser.tum",
                            "truth-at-ekf.tum", "truth-at-nav.tum"])
    rows = [line.split() for line in (exported / "ekf.tum").read_text().splitlines()
            if not line.startswith("#")]
    assert rows and all(len(r) == 8 for r in rows)
    q = np.array([[float(v) for v in r[4:]] for r in rows])
    assert np.allclose(np.linalg.norm(q, axis=1), 1.0, atol=1e-8)
    assert np.allclose(q[:, :2], 0.0)


def test_nav_file_is_the_laser_baseline(exported: Path) -> None:
    """The NAV pose converted to O is what the laser baseline reports."""
    nav = trajfile.read_trajectory(exported / "nav.tum").to_frame()
    laser = trajfile.read_trajectory(exported / "laser.tum").to_frame()
    assert len(nav) == len(laser)
    assert np.allclose(nav[["x", "y"]].to_numpy(), laser[["x", "y"]].to_numpy(), atol=2e-6)


def test_evo_ape_equals_lgvtool_truth_rmse(sim_log: Path, exported: Path) -> None:
    """evo's APE (translation, no alignment) on NAME.tum against truth-at-NAME.tum equals
    lgvtool's true position RMSE to 0.1 mm."""
    from evo.core import metrics, sync
    from evo.tools import file_interface

    result = evaluate_log(sim_log, estimators=FAST)
    for name in FAST:
        ref = file_interface.read_tum_trajectory_file(str(exported / f"truth-at-{name}.tum"))
        est = file_interface.read_tum_trajectory_file(str(exported / f"{name}.tum"))
        ref, est = sync.associate_trajectories(ref, est)
        ape = metrics.APE(metrics.PoseRelation.translation_part)
        ape.process_data((ref, est))
        evo_rmse = ape.get_statistic(metrics.StatisticsType.rmse)
        truth = result.estimators[name].truth
        assert truth is not None and truth.samples == est.num_poses
        assert evo_rmse == pytest.approx(truth.position_rmse, abs=1e-4)


def test_every_format_round_trips_the_poses(sim_log: Path, exported: Path,
                                            tmp_path: Path) -> None:
    tum = trajfile.read_trajectory(exported / "ekf.tum").to_frame()
    for fmt in ("kitti", "csv", "parquet"):
        export_log(sim_log, tmp_path / fmt, fmt, estimators=["ekf"])
    csv = trajfile.read_trajectory(tmp_path / "csv" / "ekf.csv").to_frame()
    assert (tmp_path / "csv" / "ekf.csv").read_text().splitlines()[0] == \
        "t_s,x_m,y_m,heading_rad"
    assert np.allclose(csv.to_numpy(), tum.to_numpy(), atol=2e-6)
    kitti = np.loadtxt(tmp_path / "kitti" / "ekf.kitti.txt")
    times = np.loadtxt(tmp_path / "kitti" / "ekf.times.txt")
    assert kitti.shape == (len(tum), 12) and times.shape == (len(tum),)
    assert np.allclose(kitti[:, 3], tum["x"], atol=2e-6)
    assert np.allclose(kitti[:, 7], tum["y"], atol=2e-6)
    assert np.allclose(np.arctan2(kitti[:, 4], kitti[:, 0]), tum["heading"], atol=1e-6)
    assert np.allclose(times, tum["t"], atol=1e-8)
    import pyarrow.parquet as pq

    table = pq.read_table(tmp_path / "parquet" / "ekf.parquet")
    assert table.column_names == list(trajfile.COLUMNS)
    assert {f.name: f.metadata[b"unit"].decode() for f in table.schema} == trajfile.COLUMNS
    assert table.schema.metadata[b"point"] == b"target rotation centre O"
    df = table.to_pandas()
    assert np.allclose(df["x_m"], tum["x"], atol=2e-6)


def test_existing_files_need_force(sim_log: Path, tmp_path: Path,
                                   cli: CLI) -> None:
    out = tmp_path / "out"
    assert cli("export", sim_log, "-e", "laser", "-o", out)[0] == 0
    before = (out / "laser.tum").read_bytes()
    code, _, err = cli("export", sim_log, "-e", "laser", "-o", out)
    assert code == 2 and "exists; pass --force" in err and len(err.strip().splitlines()) == 1
    assert (out / "laser.tum").read_bytes() == before
    code, out_text, _ = cli("export", sim_log, "-e", "laser", "-o", out, "--force")
    assert code == 0 and "laser" in out_text


def test_parquet_without_pyarrow_names_the_extra(sim_log: Path, tmp_path: Path,
                                                 monkeypatch: pytest.MonkeyPatch,
                                                 cli: CLI) -> None:
    monkeypatch.setitem(sys.modules, "pyarrow", None)
    code, _, err = cli("export", sim_log, "--format", "parquet", "-o", tmp_path / "p")
    assert code == 2
    assert "[fleet]'" in err and len(err.strip().splitlines()) == 1
    assert not (tmp_path / "p").exists()


def test_unknown_estimator_and_output_is_a_file(sim_log: Path, tmp_path: Path,
                                                cli: CLI) -> None:
    code, _, err = cli("export", sim_log, "-e", "nosuch", "-o", tmp_path / "x")
    assert code == 2 and "nosuch" in err
    code, _, err = cli("export", sim_log, "-o", sim_log)
    assert code == 2 and len(err.strip().splitlines()) == 1
    assert sim_log.stat().st_size > 0


def test_estimates_of_a_replayed_log_are_exported_as_logged(sim_log: Path, tmp_path: Path,
                                                            cli: CLI) -> None:
    from lgvtool.log import LogReader, topics

    replayed = tmp_path / "replayed.mcap"
    assert cli("replay", sim_log, "-e", "ekf", "-o", replayed)[0] == 0
    summary = export_log(replayed, tmp_path / "r", "csv")
    assert summary.source == "log" and "ekf" in summary.trajectories
    logged = LogReader(replayed).dataframe(topics.estimate_pose("ekf"))
    got = pd.read_csv(tmp_path / "r" / "ekf.csv")
    assert len(got) == len(logged)
    assert np.allclose(got["x_m"], logged["x"], atol=2e-6)
    with pytest.raises(InputError, match="no estimates of pf"):
        export_log(replayed, tmp_path / "r2", "csv", estimators=["pf"])


def test_tum_reader_tells_the_bad_line(tmp_path: Path) -> None:
    good = "1.0 0 0 0 0 0 0 1"
    p = tmp_path / "a.tum"
    p.write_text(f"# comment\n{good}\n1.1 0 0 0 0 0\n")
    with pytest.raises(InputError, match=r"a\.tum:3: expected 8 numbers"):
        trajfile.read_trajectory(p)
    p.write_text(f"{good}\n{good}\n1.2 0 zz 0 0 0 0 1\n")
    with pytest.raises(InputError, match=r"a\.tum:3: y 'zz' is not a number"):
        trajfile.read_trajectory(p)
    p.write_text("1.2 0 0 0 0 0 0 0\n")
    with pytest.raises(InputError, match=r"a\.tum:1: the quaternion is zero"):
        trajfile.read_trajectory(p)
    p.write_text("# nothing\n\n")
    with pytest.raises(InputError, match="no poses"):
        trajfile.read_trajectory(p)
    p.write_text(f"{good}\n2.0 1 2 0 0 0 {math.sin(0.5)} {math.cos(0.5)}\n")
    df = trajfile.read_trajectory(p).to_frame()
    assert df["heading"].iloc[1] == pytest.approx(1.0, abs=1e-12)
    assert df["x"].iloc[1] == 1.0 and df["y"].iloc[1] == 2.0


def test_a_log_without_observations_exports_its_truth(tmp_path: Path, cli: CLI) -> None:
    from lgvtool.log import LogWriter, topics
    from lgvtool.log.messages import pose_in_frame

    log = tmp_path / "truth_only.mcap"
    with LogWriter(log, source="test") as w:
        for i in range(50):
            ns = 1_700_000_000_000_000_000 + i * 100_000_000
            w.write(topics.TRUTH, pose_in_frame(ns, 1.0 + 0.01 * i, 2.0, 0.1), ns)
    code, _, err = cli("export", log, "--format", "csv", "-o", tmp_path / "o")
    assert code == 0 and "no estimator exported" in err
    assert sorted(p.name for p in (tmp_path / "o").iterdir()) == ["truth.csv"]
    assert len(pd.read_csv(tmp_path / "o" / "truth.csv")) == 50
    code, _, err = cli("export", log, "-e", "pf", "-o", tmp_path / "o2")
    assert code == 2 and "no observations" in err and str(log) in err


def test_csv_reader_takes_spreadsheet_exports_and_tells_the_bad_row(tmp_path: Path) -> None:
    p = tmp_path / "sheet.csv"
    p.write_text("\ufefftime;X;Y\n1.0;2.0;3.0\n1.5;2.5;3.5\n", encoding="utf-8")
    df = trajfile.read_trajectory(p).to_frame()
    assert df["x"].tolist() == [2.0, 2.5] and df["heading"].isna().all()
    p.write_text("t_s,x_m,y_m,heading_rad\n1,2,3,0\n\n2,2,x,0\n")
    with pytest.raises(InputError, match=r"sheet\.csv:4: y_m 'x' is not a number"):
        trajfile.read_trajectory(p)
    p.write_text("a,b,c\n1,2,3\n")
    with pytest.raises(InputError, match=r"sheet\.csv:1: the header names no t, x, y"):
        trajfile.read_trajectory(p)
    p.write_text("t_s,x_m,y_m\n1,2\n")
    with pytest.raises(InputError, match=r"sheet\.csv:2: 2 field\(s\), the header has 3"):
        trajfile.read_trajectory(p)


def test_a_replayed_log_is_exported_in_one_pass_with_the_same_files(
        sim_log: Path, exported: Path, tmp_path: Path, chunk_passes: list[list[str]]) -> None:
    """A log written by ``replay`` holds every topic in every chunk: its estimates, truth and
    NAV poses are read in one pass, and the files are those of the estimators run by export
    (the same seed: the same estimates)."""
    from lgvtool.app.replay_job import ReplayOptions, replay_log
    from lgvtool.log import topics

    replayed = tmp_path / "replayed.mcap"
    replay_log(ReplayOptions(str(sim_log), str(replayed), estimators=tuple(FAST),
                             show_progress=False))
    chunk_passes.clear()
    out = tmp_path / "tum"
    export_log(replayed, out, "tum")
    assert chunk_passes == [sorted([*(topics.estimate_pose(n) for n in FAST), topics.TRUTH,
                                    topics.NAV_POSE])]
    for path in sorted(exported.iterdir()):
        mine = trajfile.read_trajectory(out / path.name).to_frame()
        theirs = trajfile.read_trajectory(path).to_frame()
        pd.testing.assert_frame_equal(mine, theirs, check_exact=False, rtol=0, atol=1e-9)


def test_a_raw_log_is_exported_in_the_estimators_pass(
        sim_log: Path, exported: Path, tmp_path: Path, chunk_passes: list[list[str]]) -> None:
    """The truth and NAV poses a raw log's export writes beside the estimates are taken in the
    estimators' reading of it: one pass over the chunks, the same files."""
    from lgvtool.log import topics

    out = tmp_path / "tum"
    export_log(sim_log, out, "tum", estimators=FAST)
    assert len(chunk_passes) == 1
    assert {topics.TRUTH, topics.NAV_POSE, topics.NAV_REFLECTORS} <= set(chunk_passes[0])
    for path in sorted(exported.iterdir()):
        assert (out / path.name).read_bytes() == path.read_bytes(), path.name


def test_threads_write_the_same_files_and_one_is_the_default(
        sim_log: Path, exported: Path, tmp_path: Path, cli: CLI,
        monkeypatch: pytest.MonkeyPatch) -> None:
    """The estimators export runs use one thread unless ``--threads`` says otherwise (two
    filters side by side hold their working memory at once), and any count writes the same
    files."""
    import lgvtool.localize

    asked: list[int | None] = []
    real = lgvtool.localize.run_replay

    def run_replay(*args: object, threads: int | None = None, **kw: object) -> object:
        asked.append(threads)
        return real(*args, threads=threads, **kw)  # type: ignore[arg-type]

    monkeypatch.setattr(lgvtool.localize, "run_replay", run_replay)
    for threads in ((), ("--threads", "2")):
        out = tmp_path / f"tum{len(threads)}"
        code, _, err = cli("export", sim_log, "-e", ",".join(FAST), "-o", out, *threads)
        assert code == 0, err
        for path in sorted(exported.iterdir()):
            assert (out / path.name).read_bytes() == path.read_bytes(), path.name
    assert asked == [1, 2]


@pytest.mark.parametrize("fmt", ["tum", "kitti", "csv"])
def test_text_files_written_a_block_of_rows_at_a_time_are_the_same(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch, fmt: str) -> None:
    """The text writers turn a block of rows at a time into lines (memory holds a block's,
    not the file's): blocks of 3 rows, which do not divide the 10 poses, write the same
    bytes as one block."""
    t = 1.7e9 + np.arange(10) * 0.05
    df = pd.DataFrame({"t": t, "x": np.linspace(-3, 4, 10), "y": np.linspace(2, -1, 10),
                       "heading": np.linspace(-3, 3, 10)})
    written = []
    for block in (3, 10_000):
        monkeypatch.setattr(trajfile, "_BLOCK", block)
        paths = [tmp_path / f"{block}-{n}" for n in trajfile.file_names("a", fmt)]
        trajfile.write_trajectory(Trajectory.from_frame(df), paths, fmt, {"content": "test"})
        written.append([p.read_bytes() for p in paths])
    assert written[0] == written[1]
    assert all(f.count(b"\n") >= 10 for f in written[0])
